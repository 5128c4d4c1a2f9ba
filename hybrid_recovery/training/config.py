"""Typed training configuration (paper §III-B) and its rsl-rl-lib 5 runner dictionary."""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass, field, fields, replace
from typing import TYPE_CHECKING, Any, get_type_hints

from hybrid_recovery.envs.config_values import checked_value
from hybrid_recovery.envs.removed import drop_removed

if TYPE_CHECKING:
    from hybrid_recovery.training.precision import PrecisionChoice


@dataclass
class PPOConfig:
    """PPO hyperparameters: the paper's (paper §III-B) where it gives them."""

    clip_param: float = 0.2
    gamma: float = 0.99
    lam: float = 0.95
    learning_rate: float = 1e-3
    schedule: str = "adaptive"
    desired_kl: float = 0.01
    entropy_coef: float = 0.005
    value_loss_coef: float = 1.0
    num_learning_epochs: int = 5
    """E passes over the rollout per update (rsl-rl's default; the paper does not state
    it). 4 cut the update by a fifth and learned as much per env step on ``recovery``, but
    less reward on ``full`` in two of three seeds (training/README.md "Training
    throughput"): not the default."""
    num_mini_batches: int = 4
    max_grad_norm: float = 1.0
    use_clipped_value_loss: bool = True
    symmetry: bool = False
    """Left/right mirror data augmentation (rsl-rl's symmetry extension); off as in the paper."""
    mixed_precision: bool | None = None
    """bf16 autocast on the CPU for the update's forward passes and losses (rsl-rl's
    ``use_mixed_precision``; True), or float32 (False). Weights, gradients and the Adam
    state stay float32; the rollout's inference stays float32. None: chosen by the
    machine at every start and resume, the faster of the two measured on the run's
    networks (:func:`~hybrid_recovery.training.precision.choose_precision`; recorded per
    segment): bf16 halves the update on a CPU with native bf16 and is several times
    slower than float32 on one without. Beyond the paper; bf16's rounding puts noise
    into PPO's ratio that grows as the action noise σ shrinks (docs/experiments.md,
    training throughput). A run saved without this field trained in float32 and resumes
    so (:func:`train_config_from_dict`)."""


@dataclass
class TeacherConfig:
    """Imitation of the recorded ground moves after each PPO update
    (:mod:`hybrid_recovery.training.teacher`; beyond the paper, off by default). Its
    states and actions come from the run's ``rises.files``, which must then hold the
    moves' joint targets."""

    learning_rate: float = 0.0
    """lr₀, the Adam step size of the first update's teacher steps; 0: off (the paper)."""
    anneal_iterations: int = 500
    """PPO updates over which the step size falls linearly from lr₀ to zero."""
    steps: int = 4
    """Adam steps per PPO update."""
    batch_size: int = 2048
    """Recorded states per step, drawn uniformly with replacement (and as many of the
    rollout's states for the anchor)."""
    anchor: float = 1.0
    """Weight of L_A = ‖μ_θ(o) − μ_ref(o)‖² on the rollout's own states o, μ_ref the
    actor as it was at the teacher's first step (frozen, checkpointed), added to each
    teacher step: the teacher must not move the actor where the moves do not go.
    Without it (0), lr₀ 1e-4 took a fork of the live lineage from standing up in 100 %
    of its squatting episodes to 0–14 % within 130 iterations, and anchored to the
    rollout's own means, which move with the actor, as well (docs/experiments.md §11)."""


@dataclass(frozen=True)
class StageConfig:
    """When a staged run (:mod:`~hybrid_recovery.training.stages`) moves on; paper §III-F
    advances its curriculum on success rates the same way."""

    probe_interval: int = 200
    """Iterations of the ``recovery`` stage between probes (≈ 5 M env steps at 1024 envs)."""
    probe_episodes: int = 6
    """Hybrid trials per pose in one probe."""
    probe_duration: float = 25.0
    """Length of a probe or recording trial [s] (settle, ground moves, then the policy)."""
    rise_rate: float = 0.5
    """Share of a pose's probe trials that must stand up for the run to record rises."""
    record_episodes: int = 12
    """Hybrid trials per pose of the recording."""
    min_kept: int = 4
    """Fewest kept rises per pose for the ``rises`` stage; fewer: back to ``recovery``."""
    poses: tuple[str, ...] = ("sitting", "supine")
    """Poses whose rises are probed and recorded."""
    recorder: str = "hybrid"
    """Whose rises are recorded: ``hybrid`` (the ground moves, then the run's own policy,
    recorded once a probe passes) or ``model`` (the model-based half alone: it needs no
    policy, so nothing is probed and the rises are recorded after the first
    ``probe_interval`` iterations)."""

    def __post_init__(self) -> None:
        if self.recorder not in ("hybrid", "model"):
            raise ValueError(f"StageConfig.recorder must be 'hybrid' or 'model', got "
                             f"{self.recorder!r}")
        for name in ("probe_interval", "probe_episodes", "record_episodes", "min_kept"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"StageConfig.{name} must be >= 1, got {getattr(self, name)}")
        if not 0.0 < self.rise_rate <= 1.0:
            raise ValueError(f"StageConfig.rise_rate must be in (0, 1], got {self.rise_rate}")
        if not 0.0 < self.probe_duration < float("inf"):
            raise ValueError(f"StageConfig.probe_duration must be a finite number > 0, got "
                             f"{self.probe_duration}")
        if self.min_kept > self.record_episodes:
            raise ValueError(f"StageConfig.min_kept ({self.min_kept}) exceeds record_episodes "
                             f"({self.record_episodes})")
        if not self.poses:
            raise ValueError("StageConfig.poses must name at least one pose")


@dataclass
class TrainConfig:
    """A training run."""

    variant: str = "full"
    """One of :data:`hybrid_recovery.training.variants.VARIANTS`."""
    num_envs: int = 1024
    iterations: int = 50_000
    """PPO iterations (the paper: 50,000 on a GPU)."""
    num_steps_per_env: int = 24
    hidden_dims: tuple[int, ...] = (512, 256, 128)
    activation: str = "elu"
    init_std: float = 1.0
    max_std: float | None = None
    """Upper bound of the action-noise std (rsl-rl's ``std_range``); None: unbounded, as in
    the paper. The std is a learned parameter; this caps its use in sampling and in the
    PPO ratio."""
    obs_normalization: bool = True
    save_interval: int = 50
    """Iterations between checkpoints; a kill loses at most this many."""
    keep_checkpoints: int = 3
    """Numbered checkpoints kept besides ``latest.pt``."""
    milestone_interval: int | None = None
    """Checkpoints of iterations that are multiples of this (and of ``save_interval``)
    are kept as well, to evaluate the run's progress later; None: none beyond
    ``keep_checkpoints``."""
    seed: int = 0
    num_threads: int = field(default_factory=lambda: usable_cpus())
    """Physics threads (MuJoCo's Batch), and torch threads unless ``torch_threads`` is set;
    default: the CPUs this process may run on (:func:`usable_cpus`)."""
    torch_threads: int | None = None
    """Torch intra-op threads for inference and the PPO update; None: ``num_threads``."""
    backend: str = "batch"
    """Physics backend, ``batch`` or ``warp`` (:mod:`hybrid_recovery.sim.backend`)."""
    device: str = "cpu"
    """``cpu``, or ``cuda`` for MuJoCo Warp and the learner on the process's GPU."""
    ppo: PPOConfig = field(default_factory=PPOConfig)
    teacher: TeacherConfig = field(default_factory=TeacherConfig)
    env_overrides: dict[str, Any] = field(default_factory=dict)
    """Dotted EnvConfig overrides applied after the variant's."""
    stages: StageConfig | None = None
    """A staged recipe's stage conditions (:mod:`~hybrid_recovery.training.stages`);
    None: one stage, the settings above throughout."""


def usable_cpus() -> int:
    """The CPUs this process may run on (its affinity; ``os.cpu_count()`` where the
    platform has none)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


REMOVED_TEACHER = frozenset({"anchor_to_start"})
"""Teacher settings removed since (the anchor is always the actor frozen at the teacher's
first step): ignored where saved configs and recorded amendments hold them."""


def train_config_from_dict(data: dict[str, Any]) -> TrainConfig:
    """The TrainConfig saved in a run's ``config.json`` (``train_config``); environment
    options removed since (:data:`hybrid_recovery.envs.removed.REMOVED`) are dropped from
    its ``env_overrides`` where they hold their neutral values.

    Raises:
        KeyError: naming an unknown key.
        ValueError: a removed environment option set away from its neutral value.
    """
    data = dict(data)
    for keys, cls, where in ((set(data) - {"ppo", "teacher"}, TrainConfig, "train_config"),
                             (set(data.get("stages") or {}), StageConfig, "train_config.stages"),
                             (set(data.get("ppo", {})), PPOConfig, "train_config.ppo"),
                             (set(data.get("teacher", {})) - REMOVED_TEACHER, TeacherConfig,
                              "train_config.teacher")):
        unknown = sorted(keys - {f.name for f in fields(cls)})
        if unknown:
            raise KeyError(f"{where} has unknown keys {unknown} (saved by another version "
                           f"of hybrid_recovery?)")
    ppo = PPOConfig(**{"mixed_precision": False,  # saved before bf16 existed: float32
                       **data.pop("ppo", {})})
    teacher = TeacherConfig(**{k: v for k, v in data.pop("teacher", {}).items()
                               if k not in REMOVED_TEACHER})
    if data.get("stages") is not None:
        data["stages"] = StageConfig(**{**data["stages"], "poses": tuple(data["stages"]["poses"])})
    if "hidden_dims" in data:
        data["hidden_dims"] = tuple(data["hidden_dims"])
    if "env_overrides" in data:
        data["env_overrides"] = drop_removed(data["env_overrides"])
    return TrainConfig(ppo=ppo, teacher=teacher, **data)


AMENDABLE = ("max_std", "save_interval", "keep_checkpoints", "num_steps_per_env")
"""TrainConfig fields a resumed run may change (``train.<field>``); the others fix the
networks' shapes or the run's identity."""


def amend_train_config(cfg: TrainConfig, changes: dict[str, Any]) -> TrainConfig:
    """``cfg`` with ``changes`` applied: ``ppo.<field>`` keys set PPO hyperparameters,
    ``teacher.<field>`` the teacher's settings, ``train.<field>`` keys the
    :data:`AMENDABLE` TrainConfig fields (all checked against the field's declared type),
    every other key is a dotted EnvConfig override (checked when the env config is built).

    Raises:
        KeyError: naming an unknown PPO or teacher field or a TrainConfig field that cannot
            change.
        ValueError: ``config key 'ppo.<field>' must be ..., got ...``.
    """
    ppo = asdict(cfg.ppo)
    teacher = asdict(cfg.teacher)
    env = dict(cfg.env_overrides)
    train: dict[str, Any] = {}
    for key, value in changes.items():
        if key.startswith("train."):
            name = key.removeprefix("train.")
            if name not in AMENDABLE:
                raise KeyError(f"'{name}' cannot change in a resumed run; amendable: "
                               f"{list(AMENDABLE)}")
            train[name] = checked_value(key, value, get_type_hints(TrainConfig)[name])
        elif key.startswith("ppo."):
            name = key.removeprefix("ppo.")
            if name not in ppo:
                raise KeyError(f"unknown PPO setting '{name}'; known: {sorted(ppo)}")
            ppo[name] = checked_value(key, value, get_type_hints(PPOConfig)[name])
        elif key.startswith("teacher."):
            name = key.removeprefix("teacher.")
            if name in REMOVED_TEACHER:
                continue
            if name not in teacher:
                raise KeyError(f"unknown teacher setting '{name}'; known: {sorted(teacher)}")
            teacher[name] = checked_value(key, value, get_type_hints(TeacherConfig)[name])
        else:
            env[key] = value
    return replace(cfg, ppo=PPOConfig(**ppo), teacher=TeacherConfig(**teacher),
                   env_overrides=env, **train)


def runner_dict(cfg: TrainConfig, precision: PrecisionChoice | None = None
                ) -> dict[str, Any]:
    """The rsl-rl-lib 5 ``OnPolicyRunner`` configuration for ``cfg``; ``precision``
    decides the update's precision where ``cfg.ppo.mixed_precision`` is None.

    Raises:
        ValueError: ``mixed_precision`` None and no ``precision``.
    """
    ppo = asdict(cfg.ppo)
    symmetry = ppo.pop("symmetry")
    mixed = ppo.pop("mixed_precision")
    if mixed is None:
        if precision is None:
            raise ValueError("ppo.mixed_precision is None (chosen by the machine): pass "
                             "the PrecisionChoice of choose_precision")
        mixed = precision.mixed_precision
    ppo["use_mixed_precision"] = bool(mixed)
    algorithm: dict[str, Any] = {"class_name": "hybrid_recovery.training.teacher:TeacherPPO"
                                 if cfg.teacher.learning_rate > 0.0 else
                                 "hybrid_recovery.training.split_update:SplitUpdatePPO", **ppo}
    if symmetry:
        algorithm["symmetry_cfg"] = {
            "use_data_augmentation": True, "use_mirror_loss": False,
            "data_augmentation_func": "hybrid_recovery.training.symmetry:mirror_batch",
        }
    model = {"class_name": "MLPModel", "hidden_dims": list(cfg.hidden_dims),
             "activation": cfg.activation, "obs_normalization": cfg.obs_normalization}
    distribution: dict[str, Any] = {"class_name": "GaussianDistribution",
                                    "init_std": cfg.init_std}
    if cfg.max_std is not None:
        distribution["std_range"] = (1e-6, float(cfg.max_std))
    return {
        "num_steps_per_env": cfg.num_steps_per_env,
        "save_interval": cfg.save_interval,
        "obs_groups": {"actor": ["policy"], "critic": ["critic"]},
        "actor": {**model, "distribution_cfg": distribution},
        "critic": dict(model),
        "algorithm": algorithm,
        "multi_gpu": None,
        "check_for_nan": True,
    }
