"""A staged recipe from its first iteration: train, probe the run's own rises, record
them, train on them (:mod:`hybrid_recovery.training.stages`); or, with
``StageConfig.recorder = "model"``, record the model-based half's rises after the first
``probe_interval`` iterations, without a probe.

Nothing of a shipped policy is read: probes and recordings run the hybrid with the
run's newest checkpoint after the hand-over, or the model-based half with no policy.
Each stage change is written to
``<run>/stages.json`` before the next stage's work begins, printed, and logged to
TensorBoard (``stage/index``, ``stage/probe_<pose>``), so ``--resume`` continues in the
stage a kill left.
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable, Collection
from pathlib import Path

from hybrid_recovery.evaluation.getup_record import NoRiseKept, record_rises
from hybrid_recovery.files import exclusive_lock
from hybrid_recovery.training import RecoveryRunner, TrainConfig, train
from hybrid_recovery.training.checkpoint import LATEST, RUN_CONFIG, load_latest, read_run_config
from hybrid_recovery.training.config import StageConfig, train_config_from_dict
from hybrid_recovery.training.distributed import process_rank
from hybrid_recovery.training.runner import RUN_LOCK_HINT
from hybrid_recovery.training.stages import STAGES, STATE_FILE, StageState, rise_files

Recorder = Callable[..., dict]
"""``record_rises``' signature: (pose, episodes, out, duration=, seed=, policy=,
controller=, force=)."""

PROBE_SEED = 1_000_000
"""First seed of the probes' trials (a probe at iteration i uses PROBE_SEED + i × 100 on);
the recordings' seeds start at 0 + i × 100, so probes and recordings never share a start."""


class StageEnded(Exception):
    """The ``recovery`` stage ended at a passed probe (the checkpoint of its iteration
    saved, ``stages.json`` at ``record``)."""


def _log(text: str) -> None:
    print(f"[recipe] {text}", flush=True)


def _env_steps(runner: RecoveryRunner, it: int) -> int:
    return (it + 1) * runner.cfg["num_steps_per_env"] * runner.env.num_envs


def _rates(kept: dict[str, list[int]]) -> str:
    return ", ".join(f"{pose} {k}/{n}" for pose, (k, n) in kept.items())


def probe_rises(run_dir: Path, stages: StageConfig, iteration: int,
                recorder: Recorder = record_rises) -> dict[str, list[int]]:
    """Hybrid trials with the run's newest checkpoint after the hand-over:
    ``{pose: [stood up, trials]}`` over :attr:`StageConfig.poses`."""
    kept: dict[str, list[int]] = {}
    with tempfile.TemporaryDirectory(prefix="probe-") as tmp:
        for pose in stages.poses:
            try:
                out = recorder(pose, stages.probe_episodes, Path(tmp) / f"{pose}.npz",
                               duration=stages.probe_duration,
                               seed=PROBE_SEED + 100 * iteration, policy=run_dir)
                kept[pose] = [int(out["kept"]), int(out["attempted"])]
            except NoRiseKept:
                kept[pose] = [0, stages.probe_episodes]
    return kept


def _probe_hook(run_dir: Path, stages: StageConfig, state: StageState,
                recorder: Recorder) -> Callable[[RecoveryRunner, int], None]:
    """The ``recovery`` stage's end-of-iteration call: every ``probe_interval`` iterations
    save, probe, record the probe; at a passed probe move to ``record`` and end."""

    def after_iteration(runner: RecoveryRunner, it: int) -> None:
        if (it + 1) % stages.probe_interval:
            return
        runner.save(str(run_dir / f"model_{it}.pt"))
        if stages.recorder == "model":  # its rises need no policy: nothing to probe
            state.move("record", it, _env_steps(runner, it),
                       "the model-based half's rises are recorded without a probe")
            state.save(run_dir)
            _log(f"stage recovery -> record at iteration {it}: the model-based half's rises")
            raise StageEnded
        kept = probe_rises(run_dir, stages, it, recorder)
        passed = all(k >= stages.rise_rate * n for k, n in kept.values())
        steps = _env_steps(runner, it)
        state.probes.append({"iteration": it, "env_steps": steps, "stood_up": kept,
                             "passed": passed})
        writer = runner.logger.writer
        if writer is not None:
            for pose, (k, n) in kept.items():
                writer.add_scalar(f"stage/probe_{pose}", k / n, it)
        need = f"needs >= {stages.rise_rate:.0%} each"
        if not passed:
            state.save(run_dir)
            _log(f"stage recovery, iteration {it}: the run's own rises after the hand-over "
                 f"{_rates(kept)} ({need}); next probe at iteration "
                 f"{it + stages.probe_interval}")
            return
        state.move("record", it, steps, f"probe at iteration {it}: {_rates(kept)} ({need})")
        state.save(run_dir)
        if writer is not None:
            writer.add_scalar("stage/index", STAGES.index("record"), it)
        _log(f"stage recovery -> record at iteration {it}: {_rates(kept)}")
        raise StageEnded

    return after_iteration


def record_stage(run_dir: Path, stages: StageConfig, state: StageState,
                 recorder: Recorder = record_rises) -> None:
    """Records the rises of ``stages.recorder`` (the hybrid with the run's newest
    checkpoint, or the model-based half) into ``<run>/rises/<pose>.npz``, then moves to
    ``rises`` (every pose kept ≥ ``min_kept``) or back to ``recovery``."""
    it = int(load_latest(run_dir)[0]["iter"])
    files = rise_files(run_dir, stages)
    hybrid = stages.recorder == "hybrid"
    whose = f"with the run's policy of iteration {it}" if hybrid else "(no policy)"
    kept: dict[str, list[int]] = {}
    for pose, out in zip(stages.poses, files, strict=True):
        _log(f"stage record: {stages.record_episodes} {stages.recorder} rises from {pose} "
             f"{whose}")
        Path(out).parent.mkdir(parents=True, exist_ok=True)
        try:
            got = recorder(pose, stages.record_episodes, out, duration=stages.probe_duration,
                           seed=100 * it, policy=run_dir if hybrid else None,
                           controller=stages.recorder, force=True)
            kept[pose] = [int(got["kept"]), int(got["attempted"])]
        except NoRiseKept:
            kept[pose] = [0, stages.record_episodes]
    state.recordings.append({"iteration": it, "kept": kept, "files": files})
    enough = all(k >= stages.min_kept for k, _ in kept.values())
    to = "rises" if enough else "recovery"
    state.move(to, it, -1, f"recorded {_rates(kept)} (needs >= {stages.min_kept} each)")
    state.save(run_dir)
    _log(f"stage record -> {to}: kept {_rates(kept)}")


def train_staged(run_dir: str | Path, cfg: TrainConfig, resume: bool = False,
                 amend: dict | None = None, force: bool = False,
                 given: Collection[str] | None = None,
                 recorder: Recorder = record_rises) -> StageState:
    """Trains a staged recipe (``cfg.stages``) in ``run_dir`` to ``cfg.iterations``,
    through every stage its measured conditions allow; with ``resume``, the run's own
    saved settings (as :func:`~hybrid_recovery.training.train`) in the stage
    ``stages.json`` names.

    Args:
        recorder: the recording (``record_rises``; tests replace it).

    Returns:
        The run's stage state at the end.

    Raises:
        ValueError: ``cfg`` is not staged; the errors of :func:`~hybrid_recovery.training.train`.
    """
    if process_rank().world_size > 1:
        raise ValueError("a staged recipe trains in one process (its probes and recordings "
                         "run beside the learner); start it without torchrun")
    run_dir = Path(run_dir)
    stages = cfg.stages
    if resume and (run_dir / RUN_CONFIG).is_file():
        stages = train_config_from_dict(read_run_config(run_dir)["train_config"]).stages
    if stages is None:
        raise ValueError(f"{'the run in ' + str(run_dir) if resume else 'variant ' + cfg.variant}"
                         f" has no stages: train it with train()")
    with exclusive_lock(run_dir, RUN_LOCK_HINT):  # held through the stages' recordings
        return _stages(run_dir, cfg, stages, resume, amend, force, given, recorder)


def _stages(run_dir: Path, cfg: TrainConfig, stages: StageConfig, resume: bool,
            amend: dict | None, force: bool, given: Collection[str] | None,
            recorder: Recorder) -> StageState:
    """:func:`train_staged`'s loop over the stages, the run directory's lock held."""
    while True:
        state = StageState.load(run_dir) if resume else None
        if state is not None and state.stage == "record":
            record_stage(run_dir, stages, state, recorder)
            continue
        stage = state.stage if state is not None else STAGES[0]
        _log(f"stage {stage}" + (" (resumed)" if resume else " (new run)"))
        hook = None
        if stage == "recovery":
            state = state or StageState()
            hook = _probe_hook(run_dir, stages, state, recorder)
        try:
            train(run_dir, cfg, resume=resume, amend=amend, force=force, given=given,
                  after_iteration=hook)
        except StageEnded:
            resume, amend, force = True, None, False
            continue
        done = StageState.load(run_dir)
        assert done is not None
        last = int(load_latest(run_dir)[0]["iter"])
        _log(f"stage {done.stage}: the run's target reached, its last iteration {last}")
        return done


def is_staged_run(run_dir: str | Path) -> bool:
    """Whether ``run_dir`` holds a staged run (its state file beside a checkpoint)."""
    return (Path(run_dir) / STATE_FILE).is_file() and (Path(run_dir) / LATEST).exists()
