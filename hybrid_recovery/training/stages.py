"""The stages of a staged recipe (``recovery_rises``) and the run's place among them.

A staged run trains in three stages, each left on a measured condition:

1. ``recovery``: the variant's environment without recorded rises and without the
   teacher, until the run's own policy, handed over by the hybrid's ground moves, stands
   up from every one of :attr:`StageConfig.poses` in at least :attr:`StageConfig.rise_rate`
   of :attr:`StageConfig.probe_episodes` probe trials (a probe every
   :attr:`StageConfig.probe_interval` iterations);
2. ``record``: the hybrid's rises recorded with that policy (``getup record``'s code),
   :attr:`StageConfig.record_episodes` per pose, into ``<run>/rises/<pose>.npz``; back to
   ``recovery`` when a pose keeps fewer than :attr:`StageConfig.min_kept`;
3. ``rises``: starts along those rises and the teacher (:data:`RISES_STAGE`) to the
   run's last iteration.

With :attr:`StageConfig.recorder` ``"model"`` the recordings are the model-based half's
(no policy): ``recovery`` then lasts :attr:`StageConfig.probe_interval` iterations with no
probe, and ``record`` keeps the whole rise, from the ground to standing, as the move.

The state (:class:`StageState`) is ``<run>/stages.json``, written atomically before
each stage's work begins, so a run killed anywhere resumes in the stage it was in.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

from hybrid_recovery.files import atomic_write_text
from hybrid_recovery.training.config import StageConfig, TeacherConfig, TrainConfig

STAGES = ("recovery", "record", "rises")
"""The stages, in order."""
STATE_FILE = "stages.json"
"""File name of a staged run's :class:`StageState` in its run directory."""
RISES_DIR = "rises"
"""Folder of a staged run's own recordings in its run directory."""

RISES_STAGE: dict[str, Any] = {"rises.levels": 16, "teacher.learning_rate": 1e-4,
                               "teacher.anneal_iterations": 300}
"""Settings the ``rises`` stage adds (``rises.files`` are the run's own recordings): 16
stretches per move, the teacher at lr₀ 1e-4 annealed over 300 updates, anchored to the
actor as the stage begins."""


@dataclass
class StageState:
    """Where a staged run stands."""

    stage: str = STAGES[0]
    changes: list[dict] = field(default_factory=list)
    """Each stage change: ``{"iteration", "env_steps", "from", "to", "why"}``."""
    probes: list[dict] = field(default_factory=list)
    """Each probe: ``{"iteration", "env_steps", "stood_up": {pose: [k, n]}, "passed"}``."""
    recordings: list[dict] = field(default_factory=list)
    """Each recording: ``{"iteration", "kept": {pose: [k, n]}, "files": [...]}``."""

    def move(self, to: str, iteration: int, env_steps: int, why: str) -> None:
        """Changes the stage to ``to``, recording why."""
        if to not in STAGES:
            raise ValueError(f"unknown stage '{to}': one of {list(STAGES)}")
        self.changes.append({"iteration": iteration, "env_steps": env_steps,
                             "from": self.stage, "to": to, "why": why})
        self.stage = to

    def save(self, run_dir: str | Path) -> None:
        atomic_write_text(json.dumps(asdict(self), indent=1) + "\n",
                          Path(run_dir) / STATE_FILE)

    @classmethod
    def load(cls, run_dir: str | Path) -> StageState | None:
        """The run's state; None where it has none (a run not staged, or not begun).

        Raises:
            ValueError: a damaged state file or an unknown stage, naming the file.
        """
        path = Path(run_dir) / STATE_FILE
        if not path.is_file():
            return None
        try:
            data = json.loads(path.read_text())
            state = cls(**data)
        except (json.JSONDecodeError, TypeError) as err:
            raise ValueError(f"stage state {path} is damaged ({err})") from None
        if state.stage not in STAGES:
            raise ValueError(f"stage state {path} names an unknown stage '{state.stage}'")
        return state


def rise_files(run_dir: str | Path, cfg: StageConfig) -> list[str]:
    """The run's own recordings, one per pose: ``<run>/rises/<pose>.npz``."""
    return [str(Path(run_dir) / RISES_DIR / f"{pose}.npz") for pose in cfg.poses]


def stage_config(cfg: TrainConfig, stage: str, run_dir: str | Path,
                 stages: StageConfig) -> TrainConfig:
    """The TrainConfig a staged run trains with in ``stage``: ``cfg`` (the variant's
    ``recovery`` settings) as it is in ``recovery`` and ``record``, with the run's own
    recordings and :data:`RISES_STAGE` in ``rises``."""
    if stage not in STAGES:
        raise ValueError(f"unknown stage '{stage}': one of {list(STAGES)}")
    if stage != "rises":
        return cfg
    env = {**cfg.env_overrides, "rises.files": rise_files(run_dir, stages)}
    teacher = asdict(cfg.teacher)
    for key, value in RISES_STAGE.items():
        if key.startswith("teacher."):
            teacher[key.removeprefix("teacher.")] = value
        else:
            env[key] = value
    return replace(cfg, env_overrides=env, teacher=TeacherConfig(**teacher))
