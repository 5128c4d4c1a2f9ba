"""A checkpoint whose networks do not fit the model (another variant's widths) is refused
in one line naming the file, the variant and the part, before torch's many-line size
mismatch."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch
from rsl_rl.models import MLPModel
from tensordict import TensorDict

from hybrid_recovery.observation import ACTOR_OBS_DIM
from hybrid_recovery.robot import constants
from hybrid_recovery.training.checkpoint import check_state_shapes, load_checkpoint

CHECKPOINT = Path(__file__).resolve().parents[1] / "training" / "checkpoints" / \
    "recovery_model_rises_s0" / "latest.pt"


def _actor(hidden_dims: list[int]) -> MLPModel:
    obs = TensorDict({"policy": torch.zeros(1, ACTOR_OBS_DIM)}, batch_size=[1])
    return MLPModel(obs, {"actor": ["policy"]}, "actor", constants.NUM_JOINTS,
                    hidden_dims=hidden_dims, activation="elu", obs_normalization=True,
                    distribution_cfg={"class_name": "GaussianDistribution", "init_std": 1.0})


def test_a_checkpoint_of_other_widths_is_named_in_one_line():
    if not CHECKPOINT.is_file():
        pytest.skip(f"no checkpoint at {CHECKPOINT}")
    data = load_checkpoint(CHECKPOINT)
    variant = data["infos"]["meta"]["variant"]
    saved = data["actor_state_dict"]
    check_state_shapes(saved, _actor([512, 256, 128]).state_dict(), "actor", CHECKPOINT,
                       variant)  # the checkpoint's own widths: fits
    narrow = _actor([256, 128, 64]).state_dict()
    with pytest.raises(ValueError) as info:
        check_state_shapes(saved, narrow, "actor", CHECKPOINT, variant)
    assert str(info.value) == (
        f"checkpoint {CHECKPOINT} (variant '{variant}') does not fit this model's actor: "
        "mlp.0.bias is [512] there, [256] here (7 tensors differ)")
    with pytest.raises(RuntimeError, match="size mismatch"):  # what it spares the user
        _actor([256, 128, 64]).load_state_dict(saved)


def test_missing_and_extra_tensors_are_named():
    model = {"a": torch.zeros(2), "b": torch.zeros(3)}
    with pytest.raises(ValueError) as info:
        check_state_shapes({"a": torch.zeros(2), "c": torch.zeros(1)}, model, "critic",
                           "run/latest.pt")
    assert str(info.value) == ("checkpoint run/latest.pt does not fit this model's critic: "
                               "b is here, not there (2 tensors differ)")
    check_state_shapes({"a": torch.ones(2), "b": torch.ones(3)}, model, "critic", "x.pt")
