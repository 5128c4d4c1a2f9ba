"""WarpBatch: N worlds of one model in MuJoCo Warp behind the ``mujoco.batch.Batch`` calls
the recovery environment makes.

The device arrays hold the state. The environment reads and writes them at every
control step through zero-copy torch views (:meth:`tensor`, :meth:`model_tensor`); its
resets, which are host code over rows, use numpy arrays (:meth:`bind`, :meth:`expand`):

* on the ``cpu`` device these are zero-copy views of the Warp arrays (float32, MuJoCo
  Warp's precision): a write by the environment is a write to the simulation;
* on a ``cuda`` device (or with ``host_copies=True``, which is how that path is tested
  without a GPU) they are host copies, synchronised by rows: a ``reset``, ``forward`` or
  ``set_const`` on some worlds uploads the host's rows of those worlds before its kernels
  and downloads them after; a ``step`` moves nothing.

Semantics follow ``Batch``: ``step(nstep, stage)`` runs ``nstep`` ``mj_step`` and then the
stages up to ``stage`` at the new state (acceleration-stage sensors such as contact
sensors keep the values of the last substep, as in C); a ``forward``, ``reset`` or
``set_const`` on some worlds leaves every bound field of the other worlds unchanged
(MuJoCo Warp runs the stages and ``set_const`` on all worlds: the other worlds' rows are
put back, on the device; its reset is masked).
"""

from __future__ import annotations

import copy
import warnings
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager

import mujoco
import mujoco_warp as mjw
import numpy as np
import torch
import warp as wp

DERIVED_FIELDS = ("body_subtreemass", "body_invweight0", "dof_invweight0", "actuator_acc0")
"""Model fields ``set_const`` derives from mass, inertia and armature: per world as soon
as those are."""

_MATRIX_FIELDS = ("xmat", "geom_xmat", "site_xmat", "ximat", "cam_xmat")
"""Data fields MuJoCo stores as 9 numbers per object (Warp: a 3×3 matrix)."""


def _ids(ids: Sequence[int] | np.ndarray | None, nsim: int) -> np.ndarray:
    return np.arange(nsim) if ids is None else np.asarray(ids, dtype=int).reshape(-1)


def _by_dtype(pairs: list[tuple[torch.Tensor, np.ndarray]]
              ) -> list[list[tuple[torch.Tensor, np.ndarray]]]:
    """(device view, host copy) pairs grouped by dtype: each group moves as one array."""
    groups: dict[torch.dtype, list[tuple[torch.Tensor, np.ndarray]]] = {}
    for view, host in pairs:
        groups.setdefault(view.dtype, []).append((view, host))
    return list(groups.values())


def _columns(group: list[tuple[torch.Tensor, np.ndarray]]
             ) -> Iterator[tuple[torch.Tensor, np.ndarray, slice]]:
    """Each pair of a dtype group with its columns in the group's packed (rows, …) array."""
    start = 0
    for view, host in group:
        yield view, host, slice(start, start + host[0].size)
        start += host[0].size


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
        host_copies: host arrays are copies, synchronised by rows (forced on a ``cuda``
            device; on the CPU device they are views of Warp's memory otherwise).
        graphs: on a ``cuda`` device, run each call (step, forward, reset, set_const) as
            one captured CUDA graph.

    Raises:
        ValueError: ``nsim`` < 1.
    """

    def __init__(self, model: mujoco.MjModel, nsim: int, device: str = "cpu",
                 expand: Sequence[str] = (), nconmax: int = 64, njmax: int = 384,
                 host_copies: bool = False, graphs: bool = True) -> None:
        if nsim < 1:
            raise ValueError(f"WarpBatch needs nsim >= 1, got {nsim}")
        self.model, self.nsim = model, nsim
        self.device = wp.get_device(device)
        self.host_copies = host_copies or not self.device.is_cpu
        self.torch_device = torch.device(wp.device_to_torch(self.device))
        self._graphs: dict[tuple, wp.Graph | None] | None = \
            None if not graphs else {}
        """Captured CUDA graphs of the calls, by call and arguments (None: launched kernel by
        kernel)."""
        self._reset_mask = wp.zeros(nsim, dtype=bool, device=self.device)
        """The worlds a reset resets (the graph's input)."""
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
        self._views: dict[str, torch.Tensor] = {}
        self._model_views: dict[str, torch.Tensor] = {}
        """Zero-copy torch views of the data and model arrays (which MuJoCo Warp keeps
        for the batch's life)."""

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
        no host copy: the state itself (with host copies, the host's rows are current
        only for the worlds of the last call that synchronised them).

        Raises:
            KeyError: a field MuJoCo Warp's data does not hold.
        """
        if name not in self._views:
            if not hasattr(self.d, name):
                raise KeyError(f"MuJoCo Warp data has no field '{name}'")
            view = wp.to_torch(getattr(self.d, name))
            self._views[name] = view.reshape(*view.shape[:-2], 9) \
                if name in _MATRIX_FIELDS else view
        return self._views[name]

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
        with self._launching():  # a view on the CPU device, a copy on a GPU
            host = array.numpy()
        if self.host_copies and self.device.is_cpu:
            host = host.copy()
        if matrix:
            host = host.reshape(*host.shape[:-2], 9)
        return host

    def model_tensor(self, name: str) -> torch.Tensor:
        """A zero-copy torch view of the per-world values of model field ``name`` (N, …),
        float32, on the simulation's device.

        Raises:
            ValueError: a field not named in ``expand`` at construction.
        """
        self.expand(name)  # checks the name
        if name not in self._model_views:
            self._model_views[name] = wp.to_torch(getattr(self.m, name))
        return self._model_views[name]

    def download(self, ids: Sequence[int] | np.ndarray | None = None) -> None:
        """The device's rows of worlds ``ids`` (None: all) to the host copies of the bound
        fields, to read or write them on the host after a step (nothing to do on views)."""
        rows = _ids(ids, self.nsim)
        self._download(rows, torch.from_numpy(rows).to(self.torch_device))

    def _upload(self, rows: np.ndarray, index: torch.Tensor) -> None:
        """Host copies: the host's rows ``rows`` of every bound and expanded field to the
        device (the caller wrote them), in one transfer per dtype; ``index``: ``rows`` on
        the device."""
        if not self.host_copies:
            return
        pairs = [(self.tensor(name), host) for name, host in self._bound.items()]
        pairs += [(self.model_tensor(name), host) for name, host in self._models.items()]
        for group in _by_dtype(pairs):
            packed = np.concatenate([host[rows].reshape(len(rows), -1) for _, host in group],
                                    axis=1)
            columns = torch.from_numpy(packed).to(self.torch_device)
            for view, _, cols in _columns(group):
                view[index] = columns[:, cols].reshape(len(rows), *view.shape[1:])

    def _download(self, rows: np.ndarray, index: torch.Tensor) -> None:
        """Host copies: the device's rows ``rows`` of every bound field to the host, in one
        transfer per dtype; ``index``: ``rows`` on the device."""
        if not self.host_copies:
            return
        pairs = [(self.tensor(name), host) for name, host in self._bound.items()]
        for group in _by_dtype(pairs):
            packed = torch.cat([view[index].reshape(len(rows), -1) for view, _ in group],
                               dim=1).cpu().numpy()
            for _, host, cols in _columns(group):
                host[rows] = packed[:, cols].reshape(len(rows), *host.shape[1:])

    @contextmanager
    def _launching(self) -> Iterator[None]:
        """Warp's launches on the device, on torch's current stream there: ordered after
        the torch writes to the views (joint targets, pushes) and before the reads."""
        with wp.ScopedDevice(self.device):
            if self.device.is_cpu:
                yield
                return
            with wp.ScopedStream(wp.stream_from_torch(self.torch_device)):
                yield

    @contextmanager
    def _kernels(self, ids: np.ndarray | None = None,
                 all_worlds: bool = True) -> Iterator[torch.Tensor]:
        """Runs kernels on the device, which holds the state, for the worlds ``ids``
        (None: all): the host's rows of them are uploaded before and downloaded after,
        and, for kernels that run on ``all_worlds``, every other world's bound rows are
        put back as they were (on the device); it yields ``ids`` on the device. (A step
        moves nothing: it launches in :meth:`_launching` alone.)"""
        chosen = np.zeros(self.nsim, dtype=bool)
        chosen[_ids(ids, self.nsim)] = True
        rows = np.flatnonzero(chosen)
        # the chosen worlds, then the others: one transfer of indices
        order = torch.from_numpy(np.argsort(~chosen, kind="stable")).to(self.torch_device)
        index, others = order[:len(rows)], order[len(rows):]
        self._upload(rows, index)
        kept = {name: self.tensor(name)[others].clone() for name in self._bound} \
            if all_worlds and len(others) else {}
        with self._launching():
            yield index
        for name, saved in kept.items():
            self.tensor(name)[others] = saved
        self._download(rows, index)

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
        with self._launching():
            self._launch(("step", nstep, int(stage)), lambda: self._substeps(nstep, int(stage)))
        self._check_overflow()

    def _substeps(self, nstep: int, stage: int) -> None:
        for _ in range(nstep):
            mjw.step(self.m, self.d)
        self._stages(stage)

    def _launch(self, key: tuple, kernels: Callable[[], None]) -> None:
        """Runs ``kernels``: on a GPU (``graphs``) as one CUDA graph captured at its first
        use under ``key`` (MuJoCo Warp launches many kernels per call; a graph launches
        them at once); where capture fails, launch by launch, with a warning."""
        if self.device.is_cpu or self._graphs is None:
            kernels()
            return
        if key not in self._graphs:
            self._graphs[key] = self._capture(key, kernels)
        graph = self._graphs[key]
        if graph is None:
            kernels()
        else:
            wp.capture_launch(graph)

    def _capture(self, key: tuple, kernels: Callable[[], None]) -> wp.Graph | None:
        try:
            with wp.ScopedCapture(device=self.device,
                                  stream=wp.stream_from_torch(self.torch_device)) as capture:
                kernels()
        except Exception as err:  # noqa: BLE001  (any capture failure: run uncaptured)
            warnings.warn(f"CUDA graph capture of {key} failed, running uncaptured: {err}",
                          stacklevel=4)
            return None
        return capture.graph

    def forward(self, ids: Sequence[int] | np.ndarray | None = None,
                stage: int = mujoco.mjtStage.mjSTAGE_ACC) -> None:
        """The forward stages up to ``stage`` for worlds ``ids`` (``Batch.forward``)."""
        with self._kernels(None if ids is None else _ids(ids, self.nsim)):
            self._launch(("forward", int(stage)), lambda: self._stages(int(stage)))

    def reset(self, ids: Sequence[int] | np.ndarray | None = None,
              stage: int = mujoco.mjtStage.mjSTAGE_ACC) -> None:
        """Resets worlds ``ids`` to the model's defaults, then computes ``stage``
        (``Batch.reset`` without keyframes). The reset itself runs on the masked worlds
        only; the stages, on all."""
        rows = _ids(ids, self.nsim)
        staged = int(stage) > int(mujoco.mjtStage.mjSTAGE_NONE)
        with self._kernels(None if ids is None else rows, all_worlds=staged) as index:
            mask = wp.to_torch(self._reset_mask)
            mask.zero_()
            mask[index] = True

            def kernels() -> None:
                mjw.reset_data(self.m, self.d, reset=self._reset_mask)
                self._stages(int(stage))

            self._launch(("reset", int(stage)), kernels)

    def set_const(self, ids: Sequence[int] | np.ndarray | None = None) -> None:
        """Recomputes the constants derived from the per-world model fields
        (``mj_setConst``); runs on every world, leaving the others' values as they were."""
        with self._kernels(None if ids is None else _ids(ids, self.nsim)):
            self._launch(("set_const",), lambda: mjw.set_const(self.m, self.d))

    def _check_overflow(self) -> None:
        # on torch's stream, after the step; one read from the device
        counts = torch.stack([wp.to_torch(self.d.nacon)[0], wp.to_torch(self.d.nefc).max()])
        contacts, rows = counts.cpu().tolist()
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
        with self._launching():  # after the kernels on torch's stream
            mjw.get_data_into(out, self.get_model(sim), self.d, world_id=sim)
        return out
