"""The PPO update with the critic's half on a second thread: rsl-rl's update, bit for bit."""

from __future__ import annotations

import pytest
import torch
from rsl_rl.algorithms import PPO
from rsl_rl.models import MLPModel
from rsl_rl.storage import RolloutStorage
from tensordict import TensorDict

from hybrid_recovery.training.split_update import SplitUpdatePPO
from hybrid_recovery.training.table_elu import TableELU

ENVS, STEPS, ACTIONS = 16, 6, 3
GROUPS = {"actor": ["policy"], "critic": ["critic"]}


def _obs(gen: torch.Generator) -> TensorDict:
    return TensorDict({"policy": torch.randn(ENVS, 5, generator=gen),
                       "critic": torch.randn(ENVS, 9, generator=gen)}, batch_size=[ENVS])


def negated(env=None, obs=None, actions=None):
    """A stand-in mirror: the batch followed by its negation."""
    del env
    obs_out = None if obs is None else TensorDict(
        {k: torch.cat([obs[k], -obs[k]]) for k in ("policy", "critic")},
        batch_size=[2 * obs.batch_size[0]])
    return obs_out, None if actions is None else torch.cat([actions, -actions])


def _algorithm(cls: type[PPO], **settings) -> PPO:
    """``cls`` with small ELU networks (normalised observations, Gaussian actions) and one
    rollout of random observations and rewards, every draw from seed 0."""
    torch.manual_seed(0)
    gen = torch.Generator().manual_seed(0)
    obs = _obs(gen)
    actor = MLPModel(obs, GROUPS, "actor", ACTIONS, (32, 16), "elu", True,
                     {"class_name": "GaussianDistribution", "init_std": 0.8})
    critic = MLPModel(obs, GROUPS, "critic", 1, (32, 16), "elu", True)
    storage = RolloutStorage("rl", ENVS, STEPS, obs, [ACTIONS], "cpu")
    alg = cls(actor, critic, storage, num_learning_epochs=3, num_mini_batches=2,
              learning_rate=3e-3, **settings)
    with torch.inference_mode():
        for step in range(STEPS):
            alg.act(obs)
            obs = _obs(gen)
            rewards = torch.randn(ENVS, generator=gen)
            dones = (torch.arange(ENVS) == step).float()
            alg.process_env_step(obs, rewards, dones, {"time_outs": dones.clone()})
        alg.compute_returns(obs)
    return alg


def _weights(alg: PPO) -> list[torch.Tensor]:
    return [p.detach().clone() for p in (*alg.actor.parameters(), *alg.critic.parameters())]


@pytest.mark.parametrize("settings", [
    {},
    {"use_mixed_precision": True},
    {"normalize_advantage_per_mini_batch": True, "use_clipped_value_loss": False},
    {"desired_kl": 1e-4},  # the step size adapts at every mini-batch
    {"symmetry_cfg": {"env": None, "data_augmentation_func": negated,
                      "use_data_augmentation": True, "use_mirror_loss": True,
                      "mirror_loss_coeff": 0.3}},
], ids=["fp32", "bf16", "per-batch-advantages", "kl-adapts", "symmetry"])
def test_the_same_update_as_rsl_rl(settings):
    theirs, ours = _algorithm(PPO, **settings), _algorithm(SplitUpdatePPO, **settings)
    assert all(torch.equal(a, b) for a, b in zip(_weights(theirs), _weights(ours), strict=True))
    for net in (ours.actor, ours.critic):  # theirs keeps nn.ELU
        assert sum(isinstance(m, TableELU) for m in net.mlp) == 2
    threads = torch.get_num_threads()
    for _ in range(2):  # the second update (same rollout) starts from the first's Adam state
        torch.manual_seed(7)
        their_losses = theirs.update()
        torch.manual_seed(7)
        our_losses = ours.update()
        assert torch.get_num_threads() == threads  # each half ran on half, then restored
        assert our_losses == their_losses
        assert ours.learning_rate == theirs.learning_rate
        for a, b in zip(_weights(theirs), _weights(ours), strict=True):
            assert torch.equal(a, b)
    moved = _weights(_algorithm(PPO, **settings))
    assert not all(torch.equal(a, b) for a, b in zip(moved, _weights(ours), strict=True))
    assert {group["lr"] for group in ours.optimizer.param_groups} == {ours.learning_rate}


def test_an_error_in_the_critic_half_is_raised_and_nothing_steps():
    alg = _algorithm(SplitUpdatePPO)
    before = _weights(alg)

    def broken(*args, **kwargs):
        raise RuntimeError("critic failed")

    alg.critic.forward = broken
    with pytest.raises(RuntimeError, match="critic failed"):
        alg.update()
    assert all(torch.equal(a, b) for a, b in zip(before, _weights(alg), strict=True))


def test_the_training_algorithms_split_the_update():
    from hybrid_recovery.training.config import TeacherConfig, TrainConfig, runner_dict
    from hybrid_recovery.training.teacher import TeacherPPO

    assert issubclass(TeacherPPO, SplitUpdatePPO)
    for teacher in (TeacherConfig(), TeacherConfig(learning_rate=1e-4)):
        cfg = TrainConfig(teacher=teacher)
        cfg.ppo.mixed_precision = False
        path = runner_dict(cfg)["algorithm"]["class_name"]
        module, name = path.split(":")
        cls = getattr(__import__(module, fromlist=[name]), name)
        assert issubclass(cls, SplitUpdatePPO)
