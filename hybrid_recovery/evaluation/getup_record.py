"""Recorded rises: physically valid states along successful stand-ups.

``hybrid-recovery getup record --pose sitting --episodes N --policy P --out FILE`` runs N
hybrid trials with the ground moves first (``GetupConfig.policy_first`` off: moves,
policy ``P``, QP) from a start pose with the paper's initialisation noise and keeps the
successful ones, sampled at 50 Hz up to the moment of success, in one ``.npz``, written
whole or not at all; an existing file is replaced only when asked, and a run that keeps
no rise writes nothing. With ``--controller model`` the trials are the model-based
half's alone (moves, push-up, hands and knees → squat, the QP's rise; no policy): the
whole rise is then the move (no ``policy`` phase).

* ``qpos`` (T, nq), ``qvel`` (T, nv): MuJoCo state;
* ``time`` (T,) [s] from the episode start; ``episode`` (T,) its index;
* ``phase`` (T,): ``settle``, ``<move>/<keyframe>``, ``policy`` or ``qp`` (the model
  controller: its mode in place of ``policy``, e.g. ``push_up``, ``to_squat``);
* ``target`` (T, 27) [rad]: the moves' joint targets q_ref at each sample (the servo
  targets the ground moves command, motor order), NaN where the moves do not act;
* ``goal`` (T, 27) [rad]: the keyframe the current phase's targets move to and hold,
  NaN where the moves do not act;
* ``contacts`` (T, B) bool: body b touches the floor; ``contact_bodies`` (B,) names;
* ``seeds`` (E,) and ``recovery_time`` (E,) [s] of the kept episodes;
  ``attempted`` the number of episodes run.
"""

from __future__ import annotations

import dataclasses
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import mujoco
import numpy as np

from hybrid_recovery.controllers import HybridController, make
from hybrid_recovery.evaluation.scenario import Scenario, check_pose
from hybrid_recovery.evaluation.trial import run_trial
from hybrid_recovery.files import atomic_path, refuse_existing
from hybrid_recovery.getup.contact_map import touching_bodies
from hybrid_recovery.robot import constants


def move_target(ctrl: object, goal: bool = False) -> np.ndarray:
    """The ground moves' current joint targets q_ref (27,) [rad] (``goal``: the keyframe
    the current phase moves to) of a controller with moves in progress (``ctrl.moves``
    acting, a phase ``<move>/<keyframe>``); NaN otherwise."""
    moves = getattr(ctrl, "moves", None)
    if moves is None or "/" not in str(getattr(ctrl, "phase", "")):
        return np.full(constants.NUM_JOINTS, np.nan)
    return np.asarray(moves.goal if goal else moves.q_ref, dtype=float).copy()


class NoRiseKept(RuntimeError):
    """A recording in which no trial rose: nothing is written."""


def _is_run_dir(path: Path) -> bool:
    """Whether ``path`` holds a training run's checkpoint (``latest.pt`` or a numbered one)."""
    from hybrid_recovery.training.checkpoint import LATEST, numbered_checkpoints

    return path.is_dir() and ((path / LATEST).is_file() or bool(numbered_checkpoints(path)))


@contextmanager
def recording_policy(policy: str | Path) -> Iterator[str]:
    """The exported policy a recording runs: ``shipped``, an export directory or its
    ``policy.onnx``, or a training run directory (its newest checkpoint exported to a
    temporary directory, removed afterwards).

    Yields:
        The policy's path, checked: ``policy.onnx`` and ``policy.json`` load.

    Raises:
        ValueError: one line naming a missing or unreadable policy.
    """
    from hybrid_recovery.policy import OnnxPolicy, resolve_policy

    path = Path(policy)
    if str(policy) != "shipped" and _is_run_dir(path):
        from hybrid_recovery.training.export import export_policy

        with tempfile.TemporaryDirectory(prefix="policy-") as tmp:
            try:
                exported = export_policy(path, Path(tmp) / "policy", record=False)
            except (OSError, ValueError, KeyError, RuntimeError) as err:
                raise ValueError(f"cannot export the policy of run {path}: {err}") from None
            yield str(exported)
        return
    try:
        resolved = resolve_policy(policy)
        OnnxPolicy(resolved, require_description=True)
    except FileNotFoundError as err:
        raise ValueError(f"{err}; --policy takes an exported policy, its policy.onnx, a "
                         f"training run directory or 'shipped'") from None
    except (OSError, ValueError, KeyError) as err:
        raise ValueError(f"cannot load policy {policy}: {err}") from None
    yield str(resolved)


def npz_path(out: str | Path) -> Path:
    """``out`` as numpy writes it: with the suffix ``.npz`` added where it has another."""
    out = Path(out)
    return out if out.suffix == ".npz" else out.with_name(out.name + ".npz")


RECORDERS = ("hybrid", "model")
"""The controllers whose rises a recording keeps: the hybrid (moves, then a policy) and
the model-based half alone."""


def record_rises(pose: str, episodes: int, out: str | Path, *,
                 policy: str | Path | None = None, duration: float = 30.0, seed: int = 0,
                 controller: str = "hybrid", force: bool = False) -> dict:
    """Runs ``episodes`` trials from ``pose`` and writes the successful rises to ``out``.

    Args:
        policy: the hybrid's policy after the hand-over (:func:`recording_policy`):
            ``shipped``, an exported policy, or a training run directory; None with
            ``controller="model"``, which runs none.
        controller: one of :data:`RECORDERS`.
        force: replace an existing ``out``.

    Returns:
        ``{"attempted": n, "kept": k, "path": out}`` (``out`` with ``.npz``).

    Raises:
        ValueError: an unknown pose or controller, ``episodes`` < 1, ``duration`` ≤ 0, a
            hybrid without a policy or a model controller with one, or a policy that
            cannot be loaded.
        FileExistsError: ``out`` exists and ``force`` is not set (before any trial).
        OSError: ``cannot write <out>: <why>``, before any trial.
        NoRiseKept: no trial rose; nothing is written.
    """
    check_pose(pose)
    if controller not in RECORDERS:
        raise ValueError(f"unknown recording controller '{controller}': one of "
                         f"{list(RECORDERS)}")
    if controller == "hybrid" and policy is None:
        raise ValueError("the hybrid records with the policy after its hand-over: give "
                         "--policy")
    if controller != "hybrid" and policy is not None:
        raise ValueError(f"the {controller} controller runs no policy: --policy is the "
                         f"hybrid's")
    if episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {episodes}")
    if not 0.0 < duration < float("inf"):
        raise ValueError(f"duration must be a finite number > 0, got {duration}")
    out = npz_path(out)
    refuse_existing(out, force, "a recording")
    try:  # before any trial: a place that cannot be written is found now
        out.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=out.parent, prefix=f".{out.stem}."):
            pass
    except FileExistsError:
        raise OSError(f"cannot write {out}: {out.parent} is not a directory") from None
    except OSError as err:
        raise OSError(f"cannot write {out}: {err.strerror or err}") from None
    if policy is None:
        return _record(pose, episodes, out, duration, seed, make(controller))
    with recording_policy(policy) as path:
        return _record(pose, episodes, out, duration, seed, make(f"hybrid:{path}"))


def _record(pose: str, episodes: int, out: Path, duration: float, seed: int, ctrl) -> dict:
    """The trials of :func:`record_rises` with ``ctrl``, written to ``out``."""
    if isinstance(ctrl, HybridController):  # a rise through the moves, not around them
        ctrl.config = dataclasses.replace(ctrl.config, policy_first=False)
    rows: dict[str, list] = {k: [] for k in ("qpos", "qvel", "time", "episode", "phase",
                                             "target", "goal", "contacts")}
    seeds, times = [], []
    bodies: list[str] = []
    for k in range(episodes):
        sample: dict[str, list] = {key: [] for key in rows}

        def grab(model: mujoco.MjModel, data: mujoco.MjData, push: np.ndarray,
                 sample: dict[str, list] = sample) -> None:
            del push
            if not bodies:
                bodies.extend(model.body(b).name for b in range(1, model.nbody))
            touching = touching_bodies(model, data)
            sample["qpos"].append(data.qpos.copy())
            sample["qvel"].append(data.qvel.copy())
            sample["time"].append(float(data.time))
            sample["phase"].append(getattr(ctrl, "phase", ctrl.name))
            sample["target"].append(move_target(ctrl))
            sample["goal"].append(move_target(ctrl, goal=True))
            sample["contacts"].append([b in touching for b in bodies])

        scenario = Scenario(pose, duration=duration, seed=seed + k)
        row = run_trial(ctrl, scenario, on_sample=grab, stop_on_success=True)
        if not row["success"] or row.get("diverged"):
            continue
        seeds.append(scenario.seed)
        times.append(row["recovery_time"])
        sample["episode"] = [len(seeds) - 1] * len(sample["time"])
        for key in rows:
            rows[key] += sample[key]
    if not seeds:
        raise NoRiseKept(f"no rise kept from {pose} in {episodes} episodes: nothing written "
                         f"to {out}")
    out.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(out) as tmp:
        _write(tmp, rows, bodies, seeds, times, episodes, pose)
    return {"attempted": episodes, "kept": len(seeds), "path": out}


def _write(out: Path, rows: dict[str, list], bodies: list[str], seeds: list[int],
           times: list[float], episodes: int, pose: str) -> None:
    np.savez_compressed(
        out, qpos=np.array(rows["qpos"]).reshape(-1, 7 + constants.NUM_JOINTS),
        qvel=np.array(rows["qvel"]).reshape(-1, 6 + constants.NUM_JOINTS),
        time=np.array(rows["time"]), episode=np.array(rows["episode"], dtype=int),
        phase=np.array(rows["phase"], dtype=str),
        target=np.array(rows["target"], dtype=float).reshape(-1, constants.NUM_JOINTS),
        goal=np.array(rows["goal"], dtype=float).reshape(-1, constants.NUM_JOINTS),
        contacts=np.array(rows["contacts"], dtype=bool).reshape(-1, len(bodies)),
        contact_bodies=np.array(bodies, dtype=str), seeds=np.array(seeds, dtype=int),
        recovery_time=np.array(times), attempted=np.array(episodes), pose=np.array(pose))

