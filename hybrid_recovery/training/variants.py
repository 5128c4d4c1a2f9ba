"""Training variants: the shipped recipe, the paper's full and reduced policies, ablations.

A variant is a set of EnvConfig overrides and, where it needs them, TrainConfig settings
(:data:`VARIANT_TRAIN`); ``hybrid-recovery train --variant NAME`` starts a run of it.
"""

from __future__ import annotations

from dataclasses import asdict, fields, replace
from typing import Any

from hybrid_recovery.training.config import PPOConfig, StageConfig, TeacherConfig, TrainConfig

RECOVERY_ENV: dict[str, Any] = {
    "pose_weights": {"standing": 0.5, "squatting": 0.5, "kneeling": 1.5, "half_kneeling": 1.0,
                     "sitting": 3, "supine": 2, "prone": 0.125},
    "rewards.w_action_rate": 0.05,
    "rewards.w_feet": 2.0,
    "curriculum.advance_poses": ["standing", "squatting", "kneeling"],
    "assist.fraction": 0.8,
    "assist.decay": 0.9,
    "assist.max_tilt": 3.1416,
    "assist.max_height": 0.85,
    "assist.poses": ["prone"],
    "bridge.levels": 16,
    "bridge.pairs": [["squatting", "sitting"], ["squatting", "supine"]],
    "bridge.advance": 0.3,
    "bridge.retreat": 0.1,
    "bridge.window": 128,
}
"""The environment of the shipped policy's lineage before the recorded rises (its
record's configuration with every amendment to iteration 12,650 applied): beyond the
paper's setting, pose weights toward the hard poses, the flat-feet reward r_feet, a torso
pull of 0.8 m g for prone starts annealed by their stand-ups, and start-pose bridges from
squatting to sitting and supine in 16 levels (unused for a pose with recorded rises)."""

VARIANTS: dict[str, dict[str, Any]] = {
    "full": {},
    # the recipe of the lineage's first 12,650 iterations (no recorded rises)
    "recovery": RECOVERY_ENV,
    # the recipe in three stages: it, its own rises recorded, starts along them and the
    # teacher (hybrid_recovery.training.stages)
    "recovery_rises": RECOVERY_ENV,
    # the same stages with the model-based half's rises (no policy needed to record them)
    "recovery_model_rises": RECOVERY_ENV,
    # the paper's ablation: all three removed together
    "reduced": {"privileged_critic": False, "rewards.use_capture_point": False,
                "curriculum.enabled": False},
    # single-factor ablations (beyond the paper)
    "no_privileged": {"privileged_critic": False},
    "no_capture_point": {"rewards.use_capture_point": False},
    "no_curriculum": {"curriculum.enabled": False},
}
"""Variant name → EnvConfig overrides."""

VARIANT_TRAIN: dict[str, dict[str, Any]] = {
    "recovery": {"init_std": 0.5, "max_std": 0.6, "save_interval": 25,
                 "ppo.mixed_precision": False},
    "recovery_rises": {"init_std": 0.5, "max_std": 0.6, "save_interval": 25,
                       "milestone_interval": 500, "stages": StageConfig()},
    "recovery_model_rises": {
        "init_std": 0.5, "max_std": 0.6, "save_interval": 25, "milestone_interval": 500,
        "stages": StageConfig(recorder="model", poses=("kneeling", "sitting", "supine"),
                              record_episodes=16)},
}
"""Variant name → TrainConfig settings other than the defaults (``ppo.<field>`` for PPO,
``teacher.<field>`` for the teacher, ``stages`` for a staged recipe whose last stage adds
its own recorded rises and the teacher, :mod:`~hybrid_recovery.training.stages`);
absent: the defaults. ``recovery`` keeps the float32 update its iterations were trained
with; ``recovery_rises`` takes the faster precision of the machine. ``recovery_model_rises``
records the model-based half's rises from the kneel, sitting and supine after the first
probe interval instead of waiting for the run's own policy to rise after the hybrid's
hand-over."""


def variant_overrides(name: str) -> dict[str, Any]:
    """The EnvConfig overrides of variant ``name``.

    Raises:
        KeyError: naming the unknown variant and the known ones.
    """
    if name not in VARIANTS:
        raise KeyError(f"unknown variant '{name}': choose one of {sorted(VARIANTS)}")
    return dict(VARIANTS[name])


def variant_train_config(name: str, **settings: Any) -> TrainConfig:
    """The TrainConfig of variant ``name``: defaults, the variant's settings
    (:data:`VARIANT_TRAIN`), then ``settings`` (TrainConfig fields; None leaves a field
    as the variant has it).

    Raises:
        KeyError: an unknown variant or TrainConfig field.
    """
    variant_overrides(name)  # checks the name
    names = {f.name for f in fields(TrainConfig)}
    given = {k: v for k, v in settings.items() if v is not None}
    unknown = sorted(set(given) - names)
    if unknown:
        raise KeyError(f"unknown TrainConfig fields {unknown}; known: {sorted(names)}")
    ppo, teacher = asdict(PPOConfig()), asdict(TeacherConfig())
    plain = {}
    for key, value in VARIANT_TRAIN.get(name, {}).items():
        if key.startswith("ppo."):
            ppo[key.removeprefix("ppo.")] = value
        elif key.startswith("teacher."):
            teacher[key.removeprefix("teacher.")] = value
        else:
            plain[key] = value
    cfg = replace(TrainConfig(variant=name), ppo=PPOConfig(**ppo),
                  teacher=TeacherConfig(**teacher), **plain)
    return replace(cfg, **given)
