"""Training runs: rsl-rl's OnPolicyRunner with atomic checkpoints, resume and provenance."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import time
from pathlib import Path

import torch
from rsl_rl.runners import OnPolicyRunner

from hybrid_recovery.envs import RecoveryEnv, apply_overrides, default_config
from hybrid_recovery.envs.config import EnvConfig
from hybrid_recovery.observation import ACTOR_OBS_DIM, ACTOR_TERMS
from hybrid_recovery.robot.constants import JOINT_NAMES
from hybrid_recovery.training.checkpoint import LATEST, atomic_save, load_checkpoint
from hybrid_recovery.training.config import (
    TrainConfig,
    amend_train_config,
    runner_dict,
    train_config_from_dict,
)
from hybrid_recovery.training.record import hardware
from hybrid_recovery.training.variants import variant_overrides


class RecoveryRunner(OnPolicyRunner):
    """OnPolicyRunner whose checkpoints are atomic and carry the env's curriculum state."""

    env: RecoveryEnv

    def __init__(self, env: RecoveryEnv, train_cfg: dict, log_dir: str | None,
                 meta: dict, keep: int = 3) -> None:
        super().__init__(env, train_cfg, log_dir=log_dir, device="cpu")
        self.meta, self.keep = meta, keep
        self.compute_s: float | None = 0.0  # None: a resumed run whose earlier time is unknown
        self.segments = [{"iteration": 0, "hardware": hardware()}]
        self._clock = time.time()

    def save(self, path: str, infos: dict | None = None) -> None:
        saved = self.alg.save()
        saved["iter"] = self.current_learning_iteration
        env_steps = (self.current_learning_iteration + 1) * self.cfg["num_steps_per_env"] \
            * self.env.num_envs
        now = time.time()
        if self.compute_s is not None:
            self.compute_s += now - self._clock
        self._clock = now
        saved["infos"] = {**(infos or {}), "meta": self.meta,
                          "curriculum": self.env.curriculum.state_dict(),
                          "assist": self.env.assist.state_dict(),
                          "bridge": self.env.bridge.state_dict(),
                          "env_steps": env_steps, "compute_time_s": self.compute_s,
                          "segments": self.segments}
        atomic_save(saved, path)
        run = Path(path).parent
        atomic_save(saved, run / LATEST)
        numbered = sorted(run.glob("model_*.pt"), key=lambda p: int(p.stem.split("_")[1]))
        for old in numbered[:-self.keep]:
            old.unlink(missing_ok=True)

    def load_run(self, path: Path) -> None:
        """Resumes from a checkpoint: weights, optimiser, normalisers, curriculum, iteration."""
        data = load_checkpoint(path)
        self.alg.load(data, None, True)
        self.current_learning_iteration = int(data["iter"]) + 1
        self.env.curriculum.load_state_dict(data["infos"]["curriculum"])
        if "assist" in data["infos"]:
            self.env.assist.load_state_dict(data["infos"]["assist"])
        if "bridge" in data["infos"]:
            self.env.bridge.load_state_dict(data["infos"]["bridge"])
        self.compute_s = data["infos"].get("compute_time_s")
        self.segments = [*data["infos"].get("segments", []),
                         {"iteration": self.current_learning_iteration, "hardware": hardware()}]
        self._clock = time.time()


def make_env_config(cfg: TrainConfig) -> EnvConfig:
    """The EnvConfig of a run: defaults, then the variant's overrides, then the run's."""
    env_cfg = default_config()
    apply_overrides(env_cfg, variant_overrides(cfg.variant))
    apply_overrides(env_cfg, cfg.env_overrides)
    env_cfg.num_envs, env_cfg.seed, env_cfg.num_threads = cfg.num_envs, cfg.seed, cfg.num_threads
    return env_cfg


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


def _resumed_config(run_dir: Path, cfg: TrainConfig) -> TrainConfig:
    """The run's own saved TrainConfig (a resume continues the same run), keeping only
    ``iterations`` and ``num_threads`` from ``cfg``."""
    path = run_dir / "config.json"
    if not path.is_file():
        return cfg
    saved = train_config_from_dict(json.loads(path.read_text())["train_config"])
    saved.iterations, saved.num_threads = cfg.iterations, cfg.num_threads
    if dataclasses.replace(saved, iterations=0, num_threads=0) != \
            dataclasses.replace(cfg, iterations=0, num_threads=0):
        print(f"[hybrid-recovery] resuming with the run's saved settings ({path}); "
              "options given now other than iterations and threads are ignored", flush=True)
    return saved


def train(run_dir: str | Path, cfg: TrainConfig, resume: bool = False,
          amend: dict | None = None) -> RecoveryRunner:
    """Trains (or resumes) a run in ``run_dir`` up to ``cfg.iterations`` iterations.

    The run directory holds ``config.json`` (resolved train and env configs, git commit,
    amendments), TensorBoard logs, ``model_<it>.pt`` checkpoints and ``latest.pt``.

    Args:
        amend: changes to a resumed run's saved settings (``ppo.<field>`` or dotted
            EnvConfig keys, see :func:`amend_train_config`). Each amendment is kept in
            ``config.json`` and the checkpoints' metadata with the iteration it starts at,
            so a run's history stays readable.

    Raises:
        FileNotFoundError: resuming a directory without ``latest.pt``.
        ValueError: ``amend`` without ``resume``.
    """
    run_dir = Path(run_dir)
    latest = run_dir / LATEST
    if amend and not resume:
        raise ValueError("amendments change a resumed run; give a new run its settings "
                         "as options instead")
    if resume and not latest.is_file():
        raise FileNotFoundError(f"cannot resume: no {LATEST} in {run_dir}")
    amendments: list[dict] = []
    saved_meta = json.loads((run_dir / "config.json").read_text()) \
        if resume and (run_dir / "config.json").is_file() else {}
    start = int(load_checkpoint(latest)["iter"]) + 1 if resume else 0
    if resume:
        cfg = _resumed_config(run_dir, cfg)
        amendments = saved_meta.get("amendments", [])
        if amend:
            cfg = amend_train_config(cfg, amend)
            amendments.append({"iteration": start, "changes": dict(amend),
                               "git_commit": _git_commit()})
            print(f"[hybrid-recovery] amending the run's settings: {amend}", flush=True)
    run_dir.mkdir(parents=True, exist_ok=True)
    torch.manual_seed(cfg.seed)
    torch.set_num_threads(cfg.num_threads)
    env_cfg = make_env_config(cfg)
    env = RecoveryEnv(env_cfg)
    critic_dim = int(env.get_observations()["critic"].shape[1])
    meta = {**policy_meta(cfg, env_cfg, critic_dim), "amendments": amendments}
    (run_dir / "config.json").write_text(json.dumps(meta, indent=2, default=str))
    runner = RecoveryRunner(env, runner_dict(cfg), str(run_dir), meta, cfg.keep_checkpoints)
    if resume:
        runner.load_run(latest)
        if amend and "assist.fraction" in amend:  # the amendment outranks the saved state
            env.assist.load_state_dict({"fraction": float(amend["assist.fraction"])})
        print(f"[hybrid-recovery] resumed {run_dir} at iteration "
              f"{runner.current_learning_iteration}, curriculum stage "
              f"{env.curriculum.stage} level {env.curriculum.level:.2f}", flush=True)
    if cfg.iterations > runner.current_learning_iteration:
        runner.learn(cfg.iterations - runner.current_learning_iteration)
    return runner
