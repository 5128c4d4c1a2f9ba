"""WarpBatch: N worlds of one model in MuJoCo Warp behind the ``mujoco.batch.Batch`` calls
the recovery environment makes.

The environment's MDP (observations, rewards, terminations, resets, pushes, domain
randomisation, curriculum) runs over ``(N, …)`` arrays; this class gives it those arrays
for MuJoCo Warp's state, so that the same code runs on either physics backend:

* on the ``cpu`` device, :meth:`bind` and :meth:`expand` return **zero-copy** numpy views
  of the Warp arrays (float32, MuJoCo Warp's precision): a write by the environment is a
  write to the simulation;
* on a ``cuda`` device the arrays live in GPU memory. Each bound or expanded field then
  has a host copy: before every call that runs kernels all of them are uploaded, after it
  the bound ones are downloaded (``mirror=True``, a few MB per control step at 4096
  worlds). The same mirror runs on the CPU device with ``mirror=True``, which is how it
  is tested without a GPU;
* on either device :meth:`tensor` returns a zero-copy torch view of a data field, which
  the per-step terms (:mod:`hybrid_recovery.envs.step_state`, array API) read in place.

Semantics follow ``Batch``: ``step(nstep, stage)`` runs ``nstep`` ``mj_step`` and then the
stages up to ``stage`` at the new state (acceleration-stage sensors such as contact
sensors keep the values of the last substep, as in C); a ``forward``, ``reset`` or
``set_const`` on some worlds leaves every bound field of the other worlds unchanged
(MuJoCo Warp runs its kernels on all worlds: the other worlds' rows are put back).
"""

from __future__ import annotations

import copy
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import TYPE_CHECKING

import mujoco
import mujoco_warp as mjw
import numpy as np
import warp as wp

if TYPE_CHECKING:
    import torch

DERIVED_FIELDS = ("body_subtreemass", "body_invweight0", "dof_invweight0", "actuator_acc0")
"""Model fields ``set_const`` derives from mass, inertia and armature: per world as soon
as those are."""

_MATRIX_FIELDS = ("xmat", "geom_xmat", "site_xmat", "ximat", "cam_xmat")
"""Data fields MuJoCo stores as 9 numbers per object (Warp: a 3×3 matrix)."""


def _ids(ids: Sequence[int] | np.ndarray | None, nsim: int) -> np.ndarray:
    return np.arange(nsim) if ids is None else np.asarray(ids, dtype=int).reshape(-1)


class WarpBatch:
    """``nsim`` worlds of ``model`` in MuJoCo Warp on ``device``.

    Args:
        model: the compiled model (its ``opt`` is MuJoCo Warp's options too).
        nsim: number of worlds N.
        device: Warp device, ``"cpu"`` or ``"cuda"`` / ``"cuda:<k>"``.
        expand: model fields to give per-world values (:meth:`expand` returns only
            these), named as in ``MjModel``.
        nconmax: contacts allocated per world.
        njmax: constraint rows allocated per world.
        mirror: keep host copies of the arrays (forced on a ``cuda`` device).

    Raises:
        ValueError: ``nsim`` < 1.
    """

    def __init__(self, model: mujoco.MjModel, nsim: int, device: str = "cpu",
                 expand: Sequence[str] = (), nconmax: int = 64, njmax: int = 384,
                 mirror: bool = False) -> None:
        if nsim < 1:
            raise ValueError(f"WarpBatch needs nsim >= 1, got {nsim}")
        self.model, self.nsim = model, nsim
        self.device = wp.get_device(device)
        self.mirror = mirror or not self.device.is_cpu
        expanded = tuple(dict.fromkeys(expand))
        sizes = {name: nsim for name in (*expanded, *DERIVED_FIELDS)}
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        with wp.ScopedDevice(self.device):
            self.m = mjw.put_model(model, batch_sizes=sizes)
            self.d = mjw.put_data(model, data, nworld=nsim, nconmax=nconmax, njmax=njmax)
        self.expanded = expanded
        self._bound: dict[str, np.ndarray] = {}
        self._models: dict[str, np.ndarray] = {}
        self._shapes: dict[int, tuple[int, ...]] = {}
        """Each host array's shape in Warp's layout (matrices 3×3), by Warp array id."""

    # ------------------------------------------------------------------ arrays
    def bind(self, name: str) -> np.ndarray:
        """The live (N, …) array of MjData field ``name``, in MuJoCo's layout (rotation
        matrices as 9 numbers), float32.

        Raises:
            KeyError: a field MuJoCo Warp's data does not hold.
        """
        if name not in self._bound:
            if not hasattr(self.d, name):
                raise KeyError(f"MuJoCo Warp data has no field '{name}'")
            self._bound[name] = self._host(getattr(self.d, name), name in _MATRIX_FIELDS)
        return self._bound[name]

    def tensor(self, name: str) -> torch.Tensor:
        """A zero-copy torch view of MjData field ``name`` on the simulation's device,
        (N, …) in MuJoCo's layout (rotation matrices as 9 numbers), float32: what the
        MDP's array-API terms (:mod:`hybrid_recovery.envs.step_state`) read on a GPU with
        no host copy. In mirror mode it holds the device's values: current after a call
        that ran kernels, until the host copies are uploaded by the next one.

        Raises:
            KeyError: a field MuJoCo Warp's data does not hold.
        """
        if not hasattr(self.d, name):
            raise KeyError(f"MuJoCo Warp data has no field '{name}'")
        view = wp.to_torch(getattr(self.d, name))
        return view.reshape(*view.shape[:-2], 9) if name in _MATRIX_FIELDS else view

    def expand(self, name: str) -> np.ndarray:
        """The live (N, …) per-world values of model field ``name``, float32.

        Raises:
            ValueError: a field not named in ``expand`` at construction.
        """
        if name not in self.expanded:
            raise ValueError(f"model field '{name}' was not expanded: give it in "
                             f"WarpBatch(expand=...) (expanded: {list(self.expanded)})")
        if name not in self._models:
            self._models[name] = self._host(getattr(self.m, name), False)
        return self._models[name]

    def _host(self, array: wp.array, matrix: bool) -> np.ndarray:
        host = array.numpy()  # a view on the CPU device, a copy on a GPU
        if self.mirror and self.device.is_cpu:
            host = host.copy()
        self._shapes[id(array)] = host.shape
        if matrix:
            host = host.reshape(*host.shape[:-2], 9)
        return host

    def _push(self) -> None:
        """Uploads the host copies (mirror mode) before kernels run."""
        if not self.mirror:
            return
        for fields, owner in ((self._bound, self.d), (self._models, self.m)):
            for name, host in fields.items():
                target = getattr(owner, name)
                target.assign(host.reshape(self._shapes[id(target)]))

    def _pull(self) -> None:
        """Downloads the bound fields (mirror mode) after kernels ran."""
        if not self.mirror:
            return
        for name, host in self._bound.items():
            host[:] = getattr(self.d, name).numpy().reshape(host.shape)

    @contextmanager
    def _kernels(self, ids: np.ndarray | None = None) -> Iterator[None]:
        """Runs kernels on the device; with ``ids``, the other worlds' bound rows are
        left as they were."""
        others = None if ids is None else np.setdiff1d(np.arange(self.nsim), ids)
        kept = {} if others is None or not len(others) else \
            {name: host[others].copy() for name, host in self._bound.items()}
        self._push()
        with wp.ScopedDevice(self.device):
            yield
        self._pull()
        for name, rows in kept.items():
            self._bound[name][others] = rows
        if kept and self.mirror:
            self._push()

    # ------------------------------------------------------------------ stages
    def _stages(self, stage: int) -> None:
        if stage >= int(mujoco.mjtStage.mjSTAGE_ACC):
            mjw.forward(self.m, self.d)
            return
        if stage >= int(mujoco.mjtStage.mjSTAGE_POS):
            mjw.fwd_position(self.m, self.d)
            mjw.sensor_pos(self.m, self.d)
        if stage >= int(mujoco.mjtStage.mjSTAGE_VEL):
            mjw.fwd_velocity(self.m, self.d)
            mjw.sensor_vel(self.m, self.d)

    def step(self, ids: Sequence[int] | np.ndarray | None = None, nstep: int = 1,
             stage: int = mujoco.mjtStage.mjSTAGE_NONE) -> None:
        """``nstep`` ``mj_step`` of every world, then the stages up to ``stage`` at the new
        state (``Batch.step``).

        Raises:
            ValueError: ``ids`` naming fewer than all worlds (MuJoCo Warp steps all).
            RuntimeError: more contacts or constraint rows than allocated.
        """
        if ids is not None and len(np.unique(ids)) != self.nsim:
            raise ValueError("WarpBatch steps every world: ids must be None or all worlds")
        with self._kernels():
            for _ in range(nstep):
                mjw.step(self.m, self.d)
            self._stages(int(stage))
        self._check_overflow()

    def forward(self, ids: Sequence[int] | np.ndarray | None = None,
                stage: int = mujoco.mjtStage.mjSTAGE_ACC) -> None:
        """The forward stages up to ``stage`` for worlds ``ids`` (``Batch.forward``)."""
        with self._kernels(None if ids is None else _ids(ids, self.nsim)):
            self._stages(int(stage))

    def reset(self, ids: Sequence[int] | np.ndarray | None = None,
              stage: int = mujoco.mjtStage.mjSTAGE_ACC) -> None:
        """Resets worlds ``ids`` to the model's defaults, then computes ``stage``
        (``Batch.reset`` without keyframes)."""
        rows = _ids(ids, self.nsim)
        mask = np.zeros(self.nsim, dtype=bool)
        mask[rows] = True
        with self._kernels(None if ids is None else rows):
            mjw.reset_data(self.m, self.d, reset=wp.array(mask, dtype=bool))
            self._stages(int(stage))

    def set_const(self, ids: Sequence[int] | np.ndarray | None = None) -> None:
        """Recomputes the constants derived from the per-world model fields
        (``mj_setConst``); runs on every world, leaving the others' values as they were."""
        with self._kernels(None if ids is None else _ids(ids, self.nsim)):
            mjw.set_const(self.m, self.d)

    def _check_overflow(self) -> None:
        contacts = int(self.d.nacon.numpy()[0])
        rows = int(self.d.nefc.numpy().max())
        if contacts > self.d.naconmax or rows > self.d.njmax:
            raise RuntimeError(
                f"MuJoCo Warp ran out of room: {contacts} contacts for {self.d.naconmax}, "
                f"{rows} constraint rows for {self.d.njmax} per world; raise nconmax/njmax")

    # ------------------------------------------------------------------ one world
    def get_model(self, sim: int, model: mujoco.MjModel | None = None) -> mujoco.MjModel:
        """World ``sim``'s model: the nominal model with its per-world fields."""
        out = copy.copy(self.model) if model is None else model
        for name in self.expanded:
            getattr(out, name)[:] = self.expand(name)[sim].reshape(getattr(out, name).shape)
        return out

    def get_data(self, sim: int, data: mujoco.MjData | None = None) -> mujoco.MjData:
        """World ``sim``'s state and derived fields, as an ``MjData``."""
        out = mujoco.MjData(self.model) if data is None else data
        self._push()
        mjw.get_data_into(out, self.get_model(sim), self.d, world_id=sim)
        return out
