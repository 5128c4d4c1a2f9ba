"""Export a trained actor to ONNX with a ``policy.json`` describing everything a runner needs."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import torch
from rsl_rl.models import MLPModel
from tensordict import TensorDict

from hybrid_recovery.files import refuse_existing, staged_directory
from hybrid_recovery.observation import ACTOR_OBS_DIM, ACTOR_TERMS
from hybrid_recovery.policy.description import POLICY_FORMAT, load_policy_description
from hybrid_recovery.robot import constants
from hybrid_recovery.training.checkpoint import load_checkpoint, load_latest
from hybrid_recovery.training.record import FINAL_KEY, plot_curves, training_record

__all__ = ["EXPORTED_FILES", "POLICY_FORMAT", "actor_from_checkpoint", "export_policy",
           "load_policy_description", "policy_description"]

EXPORTED_FILES = ("policy.onnx", "policy.onnx.data", "policy.json", "training_record.json",
                  "curves.png")
"""Every file an export may write (``policy.onnx.data`` when torch splits the weights,
``curves.png`` when the run's logs reach the checkpoint)."""


def actor_from_checkpoint(data: dict) -> MLPModel:
    """Rebuilds the actor network (with its observation normaliser) from a checkpoint."""
    train = data["infos"]["meta"]["train_config"]
    obs = TensorDict({"policy": torch.zeros(1, ACTOR_OBS_DIM)}, batch_size=[1])
    actor = MLPModel(obs, {"actor": ["policy"]}, "actor", constants.NUM_JOINTS,
                     hidden_dims=list(train["hidden_dims"]), activation=train["activation"],
                     obs_normalization=train["obs_normalization"],
                     distribution_cfg={"class_name": "GaussianDistribution",
                                       "init_std": train["init_std"]})
    actor.load_state_dict(data["actor_state_dict"])
    actor.eval()
    return actor


def policy_description(meta: dict, env_steps: int | None, iteration: int | None) -> dict:
    """The ``policy.json`` content: observation layout, robot constants, PD law, provenance."""
    env = meta["env_config"]
    return {
        "format": POLICY_FORMAT,
        "observation": {"dim": ACTOR_OBS_DIM, "terms": [list(t) for t in ACTOR_TERMS],
                        "frame": "torso IMU (angular velocity and projected gravity)",
                        "joint_pos": "q - default_joint_pos", "scaling": "none (the "
                        "normaliser is inside the ONNX graph)"},
        "action": {"dim": constants.NUM_JOINTS, "scale": env["action_scale"],
                   "target_range_factor": env["curriculum"]["position_limit_final"],
                   "target": "q_ref = default_joint_pos + scale * action, clamped to the "
                             "joint ranges scaled about their middle by target_range_factor"},
        "joint_names": list(constants.JOINT_NAMES),
        "default_joint_pos": constants.DEFAULT_JOINT_POS.tolist(),
        "kp": constants.KP.tolist(),
        "kd": constants.KD.tolist(),
        "effort_limits": constants.EFFORT_LIMITS.tolist(),
        "pd_law": "tau = kp * (q_ref - q) - kd * qdot, clipped to effort_limits",
        "control_period_s": env["physics_dt"] * env["decimation"],
        "delay_model_s": list(env["delay_range"]),
        "provenance": {"variant": meta["variant"], "git_commit": meta["git_commit"],
                       "iteration": iteration, "env_steps": env_steps},
    }


def export_policy(run_dir: str | Path, out_dir: str | Path | None = None,
                  checkpoint: str | Path | None = None,
                  history: Sequence[str | Path] = (), force: bool = False,
                  record: bool = True) -> Path:
    """Writes ``policy.onnx`` (+ ``policy.onnx.data`` if torch splits the weights),
    ``policy.json`` and the training record (``training_record.json``, ``curves.png``)
    for the newest checkpoint of ``run_dir`` (``latest.pt``, else the newest intact
    ``model_<it>.pt``, with a warning) or ``checkpoint``. ``history``: the runs
    ``run_dir`` was forked from, oldest first; the record's curves then start at the
    lineage's root.

    The files are written into a staging directory beside the output and moved there
    only once all of them are complete (:func:`~hybrid_recovery.files.staged_directory`):
    a failed export writes nothing, an interrupted one leaves the old files or the new.

    Args:
        record: Write the training record and curves (off: the policy files alone, as a
            staged recipe's probes need them).
        force: Replace an exported policy already in the output directory (its files of
            :data:`EXPORTED_FILES` that this export does not write are removed).

    Returns:
        The output directory.

    Raises:
        FileExistsError: the output directory already holds an exported policy and
            ``force`` is not set: ``<dir> already holds an exported policy
            (policy.onnx); pass --force to overwrite it``.
        NotADirectoryError: the output is a file.
    """
    run_dir = Path(run_dir)
    out = Path(out_dir) if out_dir else run_dir / "export"
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(f"export output {out} is a file, not a directory")
    held = [name for name in EXPORTED_FILES if (out / name).exists()]
    if held:
        refuse_existing(out, force, f"an exported policy ({', '.join(held)})")
    data = load_checkpoint(checkpoint) if checkpoint else load_latest(run_dir)[0]
    actor = actor_from_checkpoint(data)
    meta = data["infos"]["meta"]
    desc = policy_description(meta, data["infos"].get("env_steps"), data.get("iter"))
    with staged_directory(out, stale=EXPORTED_FILES) as staging:
        onnx_model = actor.as_onnx(verbose=False)
        onnx_model.eval()
        torch.onnx.export(onnx_model, onnx_model.get_dummy_inputs(),
                          str(staging / "policy.onnx"), export_params=True, opset_version=18,
                          input_names=["obs"], output_names=["actions"], dynamo=False)
        (staging / "policy.json").write_text(json.dumps(desc, indent=2))
        if not record:
            return out
        lineage = training_record(run_dir, data, history)
        (staging / "training_record.json").write_text(
            json.dumps(lineage, indent=2, default=str))
        if lineage[FINAL_KEY]:
            plot_curves({run_dir.name: [*history, run_dir]}, staging / "curves.png",
                        upto=int(data["iter"]))
        else:
            print(f"[hybrid-recovery] no training logs up to iteration {data['iter']} in "
                  f"{run_dir}: no curves.png (add the runs that logged them with --history)",
                  flush=True)
    return out
