"""PhysicsReplay: the physics-only rate of an env run, measured by replaying its inputs."""

from __future__ import annotations

import time

import mujoco
import numpy as np

_STATE_FIELDS = ("qpos", "qvel", "act", "history", "qacc_warmstart", "time")


class PhysicsReplay:
    """Records the controls and pushes an env applies, then replays them on the bare Batch.

    :meth:`start` snapshots the Batch's state; the env then runs as usual (each
    ``env._physics()`` call is recorded as the ``(ctrl, xfrc_applied)`` it applied);
    :meth:`replay` restores the snapshot, steps the Batch through the recorded inputs,
    ``decimation`` substeps each, with no observation, reward, contact-hull or reset work,
    and puts the env back where its own run ended. Envs the env run reset continue in the
    replay without the reset: the same physics, step for step, otherwise.
    """

    def __init__(self, env) -> None:
        self.env = env
        self.inputs: list[tuple[np.ndarray, np.ndarray]] = []
        self.replayed: dict[str, np.ndarray] = {}
        """The Batch's state where the last replay ended (field → (nsim, ...) array)."""
        self._start: dict[str, np.ndarray] = {}
        physics = env._physics

        def recording_physics(*args, **kwargs):
            sim, xp = env._sim, env._xp  # the step's arrays (numpy, or the device's views)
            self.inputs.append((xp.asarray(sim["ctrl"], copy=True),
                                xp.asarray(sim["xfrc_applied"], copy=True)))
            return physics(*args, **kwargs)

        env._physics = recording_physics

    def start(self) -> None:
        """Snapshots the Batch's state and forgets the inputs recorded so far."""
        self._start = self._snapshot()
        self.inputs.clear()

    def replay(self) -> float:
        """Replays the inputs recorded since :meth:`start` from its state [s of wall time].

        Raises:
            RuntimeError: when :meth:`start` was not called.
        """
        if not self._start:
            raise RuntimeError("PhysicsReplay.replay() needs start() first")
        env = self.env
        end = self._snapshot()
        self._restore(self._start)
        t = time.perf_counter()
        for ctrl, xfrc in self.inputs:
            env._sim["ctrl"][:], env._sim["xfrc_applied"][:] = ctrl, xfrc
            env.sims.step(nstep=env.cfg.decimation, stage=mujoco.mjtStage.mjSTAGE_VEL)
        elapsed = time.perf_counter() - t
        self.replayed = self._snapshot()
        self._restore(end)  # the env carries on from its own state
        return elapsed

    @property
    def steps(self) -> int:
        """Env steps recorded since :meth:`start`, summed over the envs."""
        return len(self.inputs) * self.env.num_envs

    def _snapshot(self) -> dict[str, np.ndarray]:
        """The state, from where it is held (MuJoCo Warp: the device)."""
        sims = self.env.sims
        if hasattr(sims, "tensor"):
            return {f: sims.tensor(f).cpu().numpy().copy() for f in _STATE_FIELDS}
        return {f: sims.bind(f).copy() for f in _STATE_FIELDS}

    def _restore(self, state: dict[str, np.ndarray]) -> None:
        """Writes ``state`` to the host arrays, which the forward call takes to the
        device, and computes its derived fields."""
        sims = self.env.sims
        if hasattr(sims, "download"):
            sims.download()  # host copies: the other fields as the device holds them
        for f, value in state.items():
            sims.bind(f)[:] = value
        sims.forward()
