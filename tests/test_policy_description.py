"""``policy.json``: every field a runner reads is checked at load, one message naming it,
for evaluation and ``play`` (:class:`OnnxPolicy`) and the deploy runner alike."""

from __future__ import annotations

import json
import math
import shutil

import pytest

from hybrid_recovery.controllers import make
from hybrid_recovery.deploy.policy_runner import PolicyMismatchError, PolicyRunner
from hybrid_recovery.policy import OnnxPolicy, load_policy_description
from hybrid_recovery.training.stand_in import write_stand_in_policy


@pytest.fixture(scope="module")
def export(tmp_path_factory):
    return write_stand_in_policy(tmp_path_factory.mktemp("zero"), "zero")


def _with(export, tmp_path, change) -> tuple:
    out = tmp_path / "policy"
    shutil.copytree(export, out)
    desc = json.loads((out / "policy.json").read_text())
    change(desc)
    (out / "policy.json").write_text(json.dumps(desc))
    return out, out / "policy.json"


def _set(key, value):
    def change(desc):
        *parents, last = key.split(".")
        target = desc
        for part in parents:
            target = target[part]
        target[last] = value
    return change


BAD = [
    ("action.scale", -0.3, "a finite number > 0", "-0.3"),
    ("action.scale", math.nan, "a finite number > 0", "nan"),
    ("action.scale", "0.3", "a finite number > 0", "'0.3'"),
    ("action.scale", True, "a finite number > 0", "True"),
    ("action.target_range_factor", 1.5, "a finite number > 0 and <= 1", "1.5"),
    ("action.dim", 12, "an integer equal to 27", "12"),
    ("control_period_s", 0, "a finite number > 0", "0"),
    ("control_period_s", math.inf, "a finite number > 0", "inf"),
    ("effort_limits", [200.0] * 26, "a list of 27 finite numbers > 0", None),
    ("kp", [math.nan] * 27, "a list of 27 finite numbers", None),
    ("delay_model_s", [0.01, -0.04], "a list of 2 finite numbers >= 0", "[0.01, -0.04]"),
    ("observation.dim", "87", "an integer", "'87'"),
    ("provenance", [1], "an object", "[1]"),
]


@pytest.mark.parametrize(("key", "value", "what", "shown"), BAD)
def test_each_bad_field_is_named(export, tmp_path, key, value, what, shown):
    _, path = _with(export, tmp_path, _set(key, value))
    with pytest.raises(ValueError) as info:
        load_policy_description(path)
    shown = repr(value) if shown is None else shown
    assert str(info.value) == f"{path} field '{key}' must be {what}, got {shown}"


def test_missing_fields_and_a_non_object_are_named(export, tmp_path):
    out, path = _with(export, tmp_path, lambda d: d["action"].pop("scale"))
    with pytest.raises(ValueError) as info:
        load_policy_description(path)
    assert str(info.value) == f"{path} has no field 'action.scale'"
    path.write_text("[1, 2]")
    with pytest.raises(ValueError) as info:
        load_policy_description(path)
    assert str(info.value) == f"{path} is not a JSON object"


def test_a_nan_action_scale_is_refused_by_eval_play_and_deploy(export, tmp_path):
    out, path = _with(export, tmp_path, _set("action.scale", math.nan))
    message = f"{path} field 'action.scale' must be a finite number > 0, got nan"
    with pytest.raises(ValueError) as info:
        make(f"onnx:{out}")  # eval and compare
    assert str(info.value) == message
    with pytest.raises(ValueError) as info:
        OnnxPolicy(out)  # play, sim2sim
    assert str(info.value) == message
    with pytest.raises(PolicyMismatchError) as info:
        PolicyRunner(out)  # the robot
    assert str(info.value) == f"refusing policy {out}: {message}"


def test_the_written_descriptions_pass(export):
    from hybrid_recovery.policy import SHIPPED_POLICY, is_shipped

    assert load_policy_description(export / "policy.json")["action"]["scale"] == 0.3
    if is_shipped():
        load_policy_description(SHIPPED_POLICY / "policy.json")
