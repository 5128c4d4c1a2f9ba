"""Each episode's ground in the batched env: flat, a slope, rough ground or a step, drawn
per episode at the terrain curriculum's level (:class:`~hybrid_recovery.envs.config.TerrainConfig`).

Every simulation holds the same terrain slots
(:func:`~hybrid_recovery.sim.terrain_model.add_terrain_slots`); an episode raises its own
(``geom_pos``) or tilts its floor (``geom_quat``), so that its ground is exactly the
:class:`~hybrid_recovery.sim.terrain.Terrain` that evaluation builds, and the ground's
height under any point is :func:`~hybrid_recovery.sim.terrain.ground_height`'s.
"""

from __future__ import annotations

import mujoco
import numpy as np

from hybrid_recovery.envs.config import TerrainConfig
from hybrid_recovery.envs.outcome_window import OutcomeWindow
from hybrid_recovery.robot.mjcf import FLOOR_NAME
from hybrid_recovery.sim.backend import PhysicsBatch
from hybrid_recovery.sim.terrain import (
    KINDS,
    Terrain,
    ground_height,
    slope_height,
    step_height,
)
from hybrid_recovery.sim.terrain_model import (
    FIELD_RADIUS,
    PARKED,
    STEP_GEOM,
    rough_slot_name,
    seat_on_terrain,
    slope_quat,
)

ROUGH_START = 3.0
"""Half-width of the random start offset on rough ground [m] (a new patch each episode)."""


def rough_terrains(cfg: TerrainConfig) -> tuple[Terrain, ...]:
    """The rough fields of the scene: heights max_rough · k / K, k = 1 … K, seed k."""
    return tuple(Terrain("rough", height=cfg.max_rough * k / cfg.rough_levels, seed=k)
                 for k in range(1, cfg.rough_levels + 1))


class TerrainTiles:
    """Per-episode terrain of a batch and its curriculum level.

    Args:
        model: the scene's model (with terrain slots).
        sims: the batch.
        cfg: the terrain settings.
    """

    def __init__(self, model: mujoco.MjModel, sims: PhysicsBatch, cfg: TerrainConfig) -> None:
        self.cfg, self.model = cfg, model
        self.rough = rough_terrains(cfg)
        self.floor = model.geom(FLOOR_NAME).id
        self.step_geom = model.geom(STEP_GEOM).id
        self.rough_geoms = np.array([model.geom(rough_slot_name(k)).id
                                     for k in range(len(self.rough))])
        self.quat, self.pos = sims.expand("geom_quat"), sims.expand("geom_pos")
        n = sims.nsim
        self.terrains: list[Terrain] = [Terrain()] * n
        """Each simulation's ground this episode."""
        self.kind = np.zeros(n, dtype=int)
        """Index into :data:`KINDS` of each simulation's ground (flat 0), (N,)."""
        self.slope, self.heading = np.zeros(n), np.zeros(n)
        """Slopes and their headings [deg], (N,)."""
        self.height = np.zeros(n)
        """Step heights [m], (N,)."""
        self.rough_index = np.full(n, -1)
        """Index into :attr:`rough` of each rough ground (−1: none), (N,)."""
        self.level = cfg.start_level
        self.window = OutcomeWindow(cfg.window)
        self._scratch = mujoco.MjData(model)
        names = [k for k in KINDS if cfg.weights.get(k, 0.0) > 0]
        weights = np.array([cfg.weights[k] for k in names])
        if not len(names):
            raise ValueError(f"terrain.weights give no terrain to draw: {cfg.weights}")
        self._kinds, self._p = names, weights / weights.sum()

    def draw(self, ids: np.ndarray, rng: np.random.Generator, flat: np.ndarray) -> None:
        """Draws and builds the ground of new episodes ``ids`` at the present level (flat
        where ``flat`` (len(ids),) bool: starts the terrain cannot take)."""
        kinds = rng.choice(self._kinds, size=len(ids), p=self._p)
        share = self.level * rng.uniform(0.5, 1.0, len(ids))
        for i, kind, size, keep_flat in zip(ids, kinds, share, flat, strict=True):
            terrain = Terrain()
            if keep_flat or kind == "flat" or size <= 0:
                pass
            elif kind == "slope":
                terrain = Terrain("slope", slope=float(size * self.cfg.max_slope),
                                  heading=float(rng.uniform(0.0, 360.0)))
            elif kind == "rough":
                k = int(np.clip(np.ceil(size * len(self.rough)), 1, len(self.rough)))
                terrain = self.rough[k - 1]
            else:
                terrain = Terrain("step", height=float(size * self.cfg.max_step))
            self.terrains[i] = terrain
            self.kind[i] = 0 if terrain.is_flat else KINDS.index(terrain.kind)
            self.slope[i], self.heading[i] = terrain.slope, terrain.heading
            self.height[i] = terrain.height if terrain.kind == "step" else 0.0
            self.rough_index[i] = self.rough.index(terrain) if self.kind[i] == 2 else -1
            self._build(i, terrain)

    def _build(self, i: int, terrain: Terrain) -> None:
        """Writes simulation ``i``'s slots for ``terrain`` (the caller sets constants)."""
        self.quat[i, self.floor] = slope_quat(terrain)
        full = 2 * self.model.geom_size[self.step_geom, 2]
        top = terrain.height if terrain.kind == "step" else PARKED
        self.pos[i, self.step_geom] = (FIELD_RADIUS, 0.0, top - full / 2)
        for k, geom in enumerate(self.rough_geoms):
            up = terrain.kind == "rough" and terrain == self.rough[k]
            self.pos[i, geom] = (0.0, 0.0, 0.0 if up else PARKED)

    def seat(self, ids: np.ndarray, qpos: np.ndarray, rng: np.random.Generator) -> None:
        """Places start states ``qpos`` (len(ids), nq), seated on flat ground, onto each
        episode's terrain in place (:func:`~hybrid_recovery.sim.terrain_model.seat_on_terrain`;
        on rough ground first moved by up to :data:`ROUGH_START` m)."""
        data = self._scratch
        for row, i in enumerate(ids):
            terrain = self.terrains[i]
            if terrain.is_flat:
                continue
            if terrain.kind == "rough":
                qpos[row, :2] += rng.uniform(-ROUGH_START, ROUGH_START, 2)
            data.qpos[:] = qpos[row]
            seat_on_terrain(self.model, data, terrain)
            qpos[row] = data.qpos

    def ground(self, xy: np.ndarray, ids: np.ndarray | None = None) -> np.ndarray:
        """The ground's height under points of simulations ``ids`` (None: all), ``xy``
        (len(ids), ..., 2) [m] → (len(ids), ...) [m]."""
        ids = np.arange(len(self.kind)) if ids is None else ids
        kind, out = self.kind[ids], np.zeros(xy.shape[:-1])
        extra = (1,) * (xy.ndim - 2)
        rows = kind == 1
        if rows.any():
            out[rows] = slope_height(self.slope[ids][rows].reshape(-1, *extra),
                                     self.heading[ids][rows].reshape(-1, *extra), xy[rows])
        rows = kind == 3
        if rows.any():
            out[rows] = step_height(self.height[ids][rows].reshape(-1, *extra), xy[rows])
        for k, terrain in enumerate(self.rough):
            rows = self.rough_index[ids] == k
            if rows.any():
                out[rows] = ground_height(terrain, xy[rows])
        return out

    @property
    def num_heights(self) -> int:
        """G², the critic's terrain inputs per env (:meth:`heights_around`)."""
        return self.cfg.height_grid ** 2

    def heights_around(self, base: np.ndarray, yaw: np.ndarray) -> np.ndarray:
        """The critic's terrain input: base height above the ground at a G × G grid
        around the base in its heading frame, (N, G²) [m].

        Args:
            base: base positions (N, 3) [m]; yaw: headings (N,) [rad].
        """
        g, s = self.cfg.height_grid, self.cfg.height_spacing
        offsets = (np.arange(g) - (g - 1) / 2) * s
        u, v = (a.ravel() for a in np.meshgrid(offsets, offsets, indexing="ij"))
        c, si = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
        points = np.stack([base[:, :1] + c * u - si * v, base[:, 1:2] + si * u + c * v], -1)
        return base[:, 2:3] - self.ground(points)

    def record(self, outcomes: np.ndarray) -> None:
        """Adds finished episodes' outcomes (n,) bool; moves the level by ``step``."""
        self.window.extend(outcomes)
        verdict = self.window.verdict(self.cfg.advance, self.cfg.retreat)
        if verdict:  # rounded: ten steps of 0.1 reach exactly 1.0
            self.level = float(np.clip(round(self.level + verdict * self.cfg.step, 9), 0, 1))
            self.window.clear()

    def state_dict(self) -> dict:
        """The curriculum's state (for checkpoints)."""
        return {"level": self.level, "outcomes": self.window.state()}

    def load_state_dict(self, state: dict) -> None:
        self.level = float(state["level"])
        self.window = OutcomeWindow(self.cfg.window, state.get("outcomes", []))
