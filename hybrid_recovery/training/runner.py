"""Training runs: rsl-rl's OnPolicyRunner with atomic checkpoints, resume and provenance."""

from __future__ import annotations

import contextlib
import dataclasses
import json
import os
import subprocess
import time
from collections.abc import Callable, Collection
from pathlib import Path

import torch
from rsl_rl.runners import OnPolicyRunner

from hybrid_recovery.envs import RecoveryEnv, apply_overrides, default_config
from hybrid_recovery.envs.config import EnvConfig
from hybrid_recovery.files import exclusive_lock
from hybrid_recovery.observation import ACTOR_OBS_DIM, ACTOR_TERMS
from hybrid_recovery.robot.constants import JOINT_NAMES
from hybrid_recovery.sim.backend import check_backend
from hybrid_recovery.sim.scene import build_scene
from hybrid_recovery.training.checkpoint import (
    LATEST,
    RUN_CONFIG,
    atomic_save,
    atomic_write_text,
    check_state_shapes,
    grow_critic_inputs,
    load_checkpoint,
    load_latest,
    numbered_checkpoints,
    read_run_config,
)
from hybrid_recovery.training.config import (
    TrainConfig,
    amend_train_config,
    runner_dict,
    train_config_from_dict,
)
from hybrid_recovery.training.distributed import Rank, join_cpu_group, process_rank
from hybrid_recovery.training.graceful_stop import StopRequest, TrainingStopped, stop_on_signals
from hybrid_recovery.training.memory import check_num_envs
from hybrid_recovery.training.precision import PrecisionChoice, choose_precision, fixed_precision
from hybrid_recovery.training.record import hardware
from hybrid_recovery.training.stages import RISES_DIR, STATE_FILE, StageState, stage_config
from hybrid_recovery.training.teacher import Teacher, TeacherPPO, make_teacher
from hybrid_recovery.training.variants import variant_overrides


class RecoveryRunner(OnPolicyRunner):
    """OnPolicyRunner whose checkpoints are atomic and carry the env's curriculum state, and
    which stops, saved, at the end of an iteration once :attr:`stop` is asked
    (:mod:`~hybrid_recovery.training.graceful_stop`)."""

    env: RecoveryEnv

    def __init__(self, env: RecoveryEnv, train_cfg: dict, log_dir: str | None,
                 meta: dict, keep: int = 3, device: str = "cpu") -> None:
        super().__init__(env, train_cfg, log_dir=log_dir, device=device)
        self.meta, self.keep = meta, keep
        self.milestone_interval: int | None = None
        """Checkpoints of iterations that are multiples of this are never removed."""
        self.compute_s: float | None = 0.0  # None: a resumed run whose earlier time is unknown
        self.segments = [{"iteration": 0, "hardware": hardware(),
                          "precision": meta.get("precision")}]
        self._clock = time.time()
        self.stop = StopRequest()
        self.after_iteration: Callable[[RecoveryRunner, int], None] | None = None
        """Called with the runner and the iteration after each iteration is logged (a
        staged recipe's probes); it may save and raise to end the run."""
        log = self.logger.log  # called by learn() at the end of every iteration

        def log_then_stop(**iteration) -> None:
            log(**iteration)
            if self.after_iteration is not None:
                self.after_iteration(self, int(iteration["it"]))
            if self._stop_agreed():
                self._stop_saved(int(iteration["it"]))

        self.logger.log = log_then_stop  # type: ignore[method-assign]

    def _configure_multi_gpu(self) -> None:
        """rsl-rl's multi-GPU set-up; CPU processes under ``torchrun`` join over gloo."""
        rank = process_rank()
        if self.device != "cpu" or rank.world_size == 1:
            super()._configure_multi_gpu()
            return
        self.gpu_world_size, self.is_distributed = rank.world_size, True
        self.gpu_global_rank, self.gpu_local_rank = rank.rank, rank.local_rank
        self.cfg["multi_gpu"] = join_cpu_group(rank)

    def _stop_agreed(self) -> bool:
        """Whether the run stops after this iteration: asked here or, under ``torchrun``,
        on any rank (one flag all-reduced), so that every rank stops after the same
        iteration; a rank stopping alone would leave the others waiting in the next
        update's all-reduce, and rank 0 would not save."""
        if not self.is_distributed:
            return self.stop.asked
        flag = torch.tensor([float(self.stop.asked)], device=self.device)
        torch.distributed.all_reduce(flag, op=torch.distributed.ReduceOp.MAX)
        return bool(flag.item() > 0.0)

    def _stop_saved(self, it: int) -> None:
        """Saves iteration ``it`` (on the rank that writes) and ends the run."""
        if self.logger.writer is not None:
            self.save(os.path.join(self.logger.log_dir, f"model_{it}.pt"))
        asked = self.stop.signal.name if self.stop.signal else "a stop asked on another rank"
        raise TrainingStopped(f"{asked}: stopped after iteration {it}, saved; continue with "
                              f"--resume")

    @property
    def teacher(self) -> Teacher | None:
        """The imitation teacher, when the run has one (:mod:`~.teacher`)."""
        return getattr(self.alg, "teacher", None)

    def save(self, path: str, infos: dict | None = None) -> None:
        saved = self.alg.save()
        saved["iter"] = self.current_learning_iteration
        env_steps = (self.current_learning_iteration + 1) * self.cfg["num_steps_per_env"] \
            * self.env.num_envs * self.gpu_world_size
        now = time.time()
        if self.compute_s is not None:
            self.compute_s += now - self._clock
        self._clock = now
        saved["infos"] = {**(infos or {}), "meta": self.meta,
                          "curriculum": self.env.curriculum.state_dict(),
                          "assist": self.env.assist.state_dict(),
                          "bridge": self.env.bridge.state_dict(),
                          "rises": self.env.rises.state_dict(),
                          "teacher": self.teacher.state_dict() if self.teacher else None,
                          "env_steps": env_steps, "compute_time_s": self.compute_s,
                          "segments": self.segments}
        if (terrain := getattr(self.env, "terrain", None)) is not None:  # absent without
            saved["infos"]["terrain"] = terrain.state_dict()
        atomic_save(saved, path)
        run = Path(path).parent
        atomic_save(saved, run / LATEST)
        every = self.milestone_interval
        for old in numbered_checkpoints(run)[:-self.keep]:
            if every is None or int(old.stem[6:]) % every:
                old.unlink(missing_ok=True)

    def load_run(self, path: Path) -> None:
        """Resumes from a checkpoint: weights, optimiser, normalisers, curriculum, bridge and
        rise levels, terrain level, iteration."""
        data = load_checkpoint(path)
        variant = data.get("infos", {}).get("meta", {}).get("variant")
        check_state_shapes(data["actor_state_dict"], self.alg.actor.state_dict(), "actor",
                           path, variant)
        if (terrain := getattr(self.env, "terrain", None)) is not None:
            width = int(self.alg.critic.state_dict()["mlp.0.weight"].shape[1])
            first = len(list(self.alg.actor.parameters()))
            if added := grow_critic_inputs(data, width, first):
                if added != terrain.num_heights:
                    raise ValueError(f"checkpoint {path}: its critic takes {width - added} "
                                     f"inputs; with the terrain's {terrain.num_heights} "
                                     f"heights this run's takes {width}")
                print(f"[hybrid-recovery] the critic gains the terrain's {added} heights "
                      "(their weights start at zero)", flush=True)
        check_state_shapes(data["critic_state_dict"], self.alg.critic.state_dict(), "critic",
                           path, variant)
        self.alg.load(data, None, True)
        self.current_learning_iteration = int(data["iter"]) + 1
        self.env.curriculum.load_state_dict(data["infos"]["curriculum"])
        if "assist" in data["infos"]:
            self.env.assist.load_state_dict(data["infos"]["assist"])
        if "bridge" in data["infos"]:
            self.env.bridge.load_state_dict(data["infos"]["bridge"])
        if "rises" in data["infos"]:
            self.env.rises.load_state_dict(data["infos"]["rises"])
        if terrain is not None and data["infos"].get("terrain"):
            terrain.load_state_dict(data["infos"]["terrain"])
        if self.teacher and data["infos"].get("teacher"):
            self.teacher.load_state_dict(data["infos"]["teacher"])
        self.compute_s = data["infos"].get("compute_time_s")
        self.segments = [*data["infos"].get("segments", []),
                         {"iteration": self.current_learning_iteration, "hardware": hardware(),
                          "precision": self.meta.get("precision")}]
        self._clock = time.time()


def make_env_config(cfg: TrainConfig) -> EnvConfig:
    """The EnvConfig of a run: defaults, then the variant's overrides, then the run's."""
    env_cfg = default_config()
    apply_overrides(env_cfg, variant_overrides(cfg.variant))
    apply_overrides(env_cfg, cfg.env_overrides)
    env_cfg.num_envs, env_cfg.seed, env_cfg.num_threads = cfg.num_envs, cfg.seed, cfg.num_threads
    env_cfg.backend, env_cfg.device = cfg.backend, cfg.device
    return env_cfg


def update_precision(cfg: TrainConfig, critic_dim: int, num_actions: int) -> PrecisionChoice:
    """The PPO update's precision for ``cfg``: its own setting, else (None) bf16 on a GPU
    and the faster of the two measured on the run's networks on a CPU
    (:func:`~hybrid_recovery.training.precision.choose_precision`, with torch's thread
    count as set for the update)."""
    if cfg.ppo.mixed_precision is not None:
        return fixed_precision(cfg.ppo.mixed_precision)
    if cfg.device != "cpu":
        return PrecisionChoice(True, "bf16: the learner is on a GPU")
    batch = cfg.num_envs * cfg.num_steps_per_env // cfg.ppo.num_mini_batches
    return choose_precision((ACTOR_OBS_DIM, critic_dim), cfg.hidden_dims, num_actions, batch)


def _git_commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                              cwd=Path(__file__).parent, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def policy_meta(cfg: TrainConfig, env_cfg: EnvConfig, critic_dim: int) -> dict:
    """What a checkpoint says about itself (checked when it is loaded or exported)."""
    return {"joint_names": list(JOINT_NAMES), "actor_obs_dim": ACTOR_OBS_DIM,
            "actor_terms": [list(t) for t in ACTOR_TERMS], "critic_obs_dim": critic_dim,
            "variant": cfg.variant, "git_commit": _git_commit(),
            "train_config": dataclasses.asdict(cfg), "env_config": dataclasses.asdict(env_cfg)}


_KEPT_ON_RESUME = ("iterations", "num_threads", "torch_threads", "backend", "device")
"""TrainConfig fields a resume takes from the options given now (when given): where and
how long it runs, not what it learns."""
_OPTION = {"env_overrides": "--set", "ppo": "--symmetry"}
"""The ``train`` option of a TrainConfig field, where it is not ``--<field-name>``."""


def _resumed_config(run_dir: Path, cfg: TrainConfig,
                    given: Collection[str] | None = None) -> TrainConfig:
    """The run's own saved TrainConfig (a resume continues the same run), taking from
    ``cfg`` only the thread counts and, where given, ``iterations`` (else the run's own
    target); the other ``given`` fields that differ from the run's are named as ignored.

    Args:
        given: TrainConfig field names the caller set (the CLI: the options given);
            None: every field.
    """
    if not (run_dir / RUN_CONFIG).is_file():
        return cfg
    saved = train_config_from_dict(read_run_config(run_dir)["train_config"])
    given = {f.name for f in dataclasses.fields(TrainConfig)} if given is None else set(given)
    saved.num_threads, saved.torch_threads = cfg.num_threads, cfg.torch_threads
    saved.backend, saved.device = cfg.backend, cfg.device
    if "iterations" in given:
        saved.iterations = cfg.iterations
    ignored = sorted(_OPTION.get(name, "--" + name.replace("_", "-"))
                     for name in given - set(_KEPT_ON_RESUME)
                     if getattr(cfg, name) != getattr(saved, name))
    if ignored:
        print(f"[hybrid-recovery] resuming with the run's saved settings "
              f"({run_dir / RUN_CONFIG}); these options given now are ignored: "
              f"{', '.join(ignored)}", flush=True)
    return saved


_RUN_FILES = (LATEST, RUN_CONFIG, STATE_FILE, "model_*.pt", "events.out.tfevents.*",
              f"{RISES_DIR}/*.npz")
"""What a training run writes into its directory (``--force`` removes these)."""


def _run_files(run_dir: Path) -> list[Path]:
    return sorted(p for pattern in _RUN_FILES for p in run_dir.glob(pattern))


RUN_LOCK_HINT = "wait for it to end, or stop it (kill PID: it saves and stops)"
"""What a second writer of a run directory is told."""


def train(run_dir: str | Path, cfg: TrainConfig, resume: bool = False,
          amend: dict | None = None, force: bool = False,
          given: Collection[str] | None = None, rank: Rank | None = None,
          after_iteration: Callable[[RecoveryRunner, int], None] | None = None
          ) -> RecoveryRunner:
    """Trains (or resumes) a run in ``run_dir`` up to ``cfg.iterations`` iterations.

    The run directory holds ``config.json`` (resolved train and env configs, git commit,
    amendments), TensorBoard logs, ``model_<it>.pt`` checkpoints and ``latest.pt``. Every
    setting is checked before a file is written.

    Args:
        amend: changes to a resumed run's saved settings (``ppo.<field>`` or dotted
            EnvConfig keys, see :func:`amend_train_config`). Each amendment is kept in
            ``config.json`` and the checkpoints' metadata with the iteration it starts at,
            so a run's history stays readable.
        force: start over in a directory that holds a run: its checkpoints, settings
            and TensorBoard logs are removed (only once the new settings are checked).
        given: with ``resume``, the TrainConfig fields the caller set (see
            :func:`_resumed_config`); None: all.
        rank: this process among several (``torchrun``, see
            :mod:`~hybrid_recovery.training.distributed`); None: read from the
            environment. Each rank simulates its own envs with seed ``seed + rank`` on its
            GPU; only rank 0 writes the run directory.
        after_iteration: see :attr:`RecoveryRunner.after_iteration`.

    The process that writes the run directory holds its lock
    (:func:`~hybrid_recovery.files.exclusive_lock`) throughout: a second writer of the
    same directory is refused at once, naming the holder's pid.

    A staged run (``cfg.stages``) trains with the settings of the stage its
    ``stages.json`` names (a new run: the first), :func:`~.stages.stage_config`;
    ``config.json`` keeps the recipe's own settings and names the stage.

    Raises:
        FileExistsError: a new run (no ``resume``, no ``force``) in a directory that
            holds one; nothing is touched.
        FileLockedError: another process trains in ``run_dir``.
        NotEnoughMemory: ``cfg.num_envs`` environments would not fit in the available
            memory (:func:`~.memory.check_num_envs`).
        FileNotFoundError: resuming a directory without a checkpoint.
        ValueError: ``amend`` without ``resume``, ``resume`` with ``force``, no intact
            checkpoint, a damaged ``config.json`` (named), or a bad setting.
        TrainingStopped: a SIGINT or SIGTERM (the main thread's), after the iteration under
            way was finished and saved.
    """
    run_dir = Path(run_dir)
    check_backend(cfg.backend, cfg.device)
    rank = rank or process_rank()
    lock = exclusive_lock(run_dir, RUN_LOCK_HINT) if rank.writes else contextlib.nullcontext()
    with lock:
        return _train(run_dir, cfg, resume, amend, force, given, rank, after_iteration)


def _train(run_dir: Path, cfg: TrainConfig, resume: bool, amend: dict | None, force: bool,
           given: Collection[str] | None, rank: Rank,
           after_iteration: Callable[[RecoveryRunner, int], None] | None) -> RecoveryRunner:
    """:func:`train` with the run directory's lock held."""
    if amend and not resume:
        raise ValueError("amendments change a resumed run; give a new run its settings "
                         "as options instead")
    if resume and force:
        raise ValueError("--resume continues the run and --force starts it over: give one")
    existing = _run_files(run_dir)
    if existing and not resume and not force:
        raise FileExistsError(
            f"{run_dir} already holds a training run ({existing[0].name}); continue it with "
            "--resume or start it over with --force")
    latest = run_dir / LATEST
    if resume:
        try:
            checkpoint, latest = load_latest(run_dir)
        except FileNotFoundError as err:
            raise FileNotFoundError(f"cannot resume: {err}") from None
    amendments: list[dict] = []
    saved_meta = read_run_config(run_dir) \
        if resume and (run_dir / RUN_CONFIG).is_file() else {}
    start = int(checkpoint["iter"]) + 1 if resume else 0
    if resume:
        cfg = _resumed_config(run_dir, cfg, given)
        amendments = saved_meta.get("amendments", [])
        if amend:
            cfg = amend_train_config(cfg, amend)
            amendments.append({"iteration": start, "changes": dict(amend),
                               "git_commit": _git_commit()})
            print(f"[hybrid-recovery] amending the run's settings: {amend}", flush=True)
    recipe_cfg, stage_state = cfg, None
    if cfg.stages is not None:
        stage_state = (StageState.load(run_dir) if resume else None) or StageState()
        if stage_state.stage == "record":
            raise ValueError(f"{run_dir} is in stage 'record': its rises are recorded, not "
                             f"trained (hybrid-recovery train --resume records them)")
        cfg = stage_config(cfg, stage_state.stage, run_dir, cfg.stages)
    env_cfg = make_env_config(cfg)  # every setting checked before a file is written
    check_num_envs(cfg.num_envs, build_scene(env_cfg.model_path, env_cfg.physics_dt)[0],
                   cfg.num_steps_per_env)
    torch.manual_seed(rank.seed(cfg.seed))
    torch.set_num_threads(cfg.torch_threads or cfg.num_threads)
    env = RecoveryEnv(dataclasses.replace(env_cfg, seed=rank.seed(cfg.seed)),
                      local_rank=rank.local_rank)
    critic_dim = int(env.get_observations()["critic"].shape[1])
    teacher = make_teacher(cfg.teacher, env, rank.seed(cfg.seed)) \
        if cfg.teacher.learning_rate > 0.0 else None
    precision = update_precision(cfg, critic_dim, env.num_actions)
    print(f"[hybrid-recovery] update precision {precision.reason}", flush=True)
    meta = {**policy_meta(recipe_cfg, env_cfg, critic_dim), "amendments": amendments,
            "precision": precision.as_dict()}
    if stage_state is not None:
        meta["stage"] = stage_state.stage
    if rank.writes:
        if force and not resume:
            for old in existing:
                old.unlink()
        run_dir.mkdir(parents=True, exist_ok=True)
        atomic_write_text(json.dumps(meta, indent=2, default=str), run_dir / RUN_CONFIG)
        if stage_state is not None:
            stage_state.save(run_dir)
    runner = RecoveryRunner(env, runner_dict(cfg, precision),
                            str(run_dir) if rank.writes else None, meta,
                            cfg.keep_checkpoints, device=rank.learner_device(cfg.device))
    runner.after_iteration = after_iteration
    runner.milestone_interval = cfg.milestone_interval
    if teacher is not None:
        assert isinstance(runner.alg, TeacherPPO)
        runner.alg.teacher = teacher
    if resume:
        runner.load_run(latest)
        if amend and "assist.fraction" in amend:  # the amendment outranks the saved state
            env.assist.load_state_dict({"fraction": float(amend["assist.fraction"])})
        print(f"[hybrid-recovery] resumed {run_dir} at iteration "
              f"{runner.current_learning_iteration}, curriculum stage "
              f"{env.curriculum.stage} level {env.curriculum.level:.2f}", flush=True)
    if cfg.iterations > runner.current_learning_iteration:
        with stop_on_signals(runner.stop):
            runner.learn(cfg.iterations - runner.current_learning_iteration)
    return runner
