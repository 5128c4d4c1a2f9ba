"""``eval`` and ``sim2sim`` load another model file the same way: the same policy from the
same start state has the same outcome through both paths (the evaluation once scored 0 %
on the manufacturer's model, where sim-to-sim stood: Euler integration and a start 10 cm
in the air)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import REFERENCE_MJCF

from hybrid_recovery.controllers import OnnxPolicyController
from hybrid_recovery.deploy.sim2sim import Sim2SimConfig, run_sim2sim, start_state
from hybrid_recovery.evaluation.scenario import Scenario
from hybrid_recovery.evaluation.trial import run_trial
from hybrid_recovery.policy import SHIPPED, resolve_policy

SECONDS = 3.0
DELAY = 0.02
"""The evaluation's actuation delay [s]; sim-to-sim is given the same."""


def _outcomes(model_path: str | None, pose: str, tmp_path) -> tuple[dict, dict]:
    try:
        policy = resolve_policy(SHIPPED)
    except FileNotFoundError as err:
        pytest.skip(str(err))
    qpos, _ = start_state(model_path, pose, 0.001)
    summary = run_sim2sim(f"onnx:{policy}", tmp_path, Sim2SimConfig(
        model_path=model_path, start_qpos=qpos, seconds=SECONDS, delay_s=DELAY, video=False))
    trial = run_trial(OnnxPolicyController(policy, delay=DELAY),
                      Scenario(pose, duration=SECONDS, noise=0.0), model_path,
                      record=True, start_qpos=qpos)
    return summary, trial


def _assert_same_outcome(summary: dict, trial: dict) -> None:
    com_z = trial["trace"]["com"][:, 2]
    assert summary["upright_at_end"] and trial["standing_at_end"]
    assert summary["fault"] is None and not trial["fell"]
    assert abs(summary["final_com_height"] - com_z[-1]) < 0.02
    assert abs(summary["min_com_height"] - com_z.min()) < 0.02


def test_same_outcome_through_eval_and_sim2sim_on_the_own_model(tmp_path):
    _assert_same_outcome(*_outcomes(None, "standing", tmp_path))


def test_same_outcome_through_eval_and_sim2sim_on_the_reference(tmp_path):
    if not REFERENCE_MJCF.is_file():
        pytest.skip(f"reference model not found at {REFERENCE_MJCF} (../shared absent)")
    summary, trial = _outcomes(str(REFERENCE_MJCF), "standing", tmp_path)
    _assert_same_outcome(summary, trial)
    # the eval path starts on the floor, not in the air
    assert trial["trace"]["com"][0, 2] == pytest.approx(summary["final_com_height"], abs=0.03)
    assert np.isfinite(trial["peak_torque"])
