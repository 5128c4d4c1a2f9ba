"""PPO's mini-batches gathered once per update: the same batches as rsl-rl's."""

from __future__ import annotations

import pytest
import torch
from rsl_rl.storage import RolloutStorage
from tensordict import TensorDict

from hybrid_recovery.training.minibatches import GatheredOnceStorage, gathered_once

FIELDS = ("actions", "values", "advantages", "returns", "old_actions_log_prob")


def _filled(steps: int = 6, envs: int = 7) -> RolloutStorage:
    """A rollout of random transitions (two observation groups, two distribution
    parameters); 42 samples, so M = 4 leaves 2 out."""
    gen = torch.Generator().manual_seed(0)
    obs = TensorDict({"policy": torch.zeros(envs, 5), "critic": torch.zeros(envs, 9)},
                     batch_size=[envs])
    storage = RolloutStorage("rl", envs, steps, obs, [3], "cpu")
    for _ in range(steps):
        t = RolloutStorage.Transition()
        t.observations = TensorDict({"policy": torch.randn(envs, 5, generator=gen),
                                     "critic": torch.randn(envs, 9, generator=gen)},
                                    batch_size=[envs])
        t.actions = torch.randn(envs, 3, generator=gen)
        t.rewards, t.dones = torch.randn(envs, generator=gen), torch.zeros(envs)
        t.values = torch.randn(envs, 1, generator=gen)
        t.actions_log_prob = torch.randn(envs, generator=gen)
        t.distribution_params = (torch.randn(envs, 3, generator=gen),
                                 torch.rand(envs, 3, generator=gen))
        storage.add_transition(t)
    storage.returns = torch.randn(steps, envs, 1, generator=gen)
    storage.advantages = torch.randn(steps, envs, 1, generator=gen)
    return storage


@pytest.mark.parametrize("mini_batches, epochs", [(4, 5), (1, 2), (3, 1)])
def test_the_same_mini_batches_as_rsl_rl_in_the_same_order(mini_batches, epochs):
    storage = _filled()
    torch.manual_seed(11)
    theirs = list(storage.mini_batch_generator(mini_batches, epochs))
    torch.manual_seed(11)
    ours = list(gathered_once(storage, mini_batches, epochs))
    assert len(ours) == len(theirs) == mini_batches * epochs
    for a, b in zip(ours, theirs, strict=True):
        for name in FIELDS:
            assert torch.equal(getattr(a, name), getattr(b, name)), name
        for key in ("policy", "critic"):
            assert torch.equal(a.observations[key], b.observations[key])
        for p, q in zip(a.old_distribution_params, b.old_distribution_params, strict=True):
            assert torch.equal(p, q)
    # the permutation is drawn per update: another seed, other batches
    torch.manual_seed(12)
    other = next(gathered_once(storage, mini_batches, 1))
    assert mini_batches == 1 or not torch.equal(other.actions, ours[0].actions)


def test_replacing_a_batch_field_leaves_the_next_epoch_unchanged():
    storage = _filled()
    torch.manual_seed(3)
    batches = gathered_once(storage, 2, 2)
    first = next(batches)
    kept = first.advantages.clone()
    first.advantages = (first.advantages - first.advantages.mean()) / first.advantages.std()
    next(batches)
    assert torch.equal(next(batches).advantages, kept)  # epoch 2, mini-batch 1


@pytest.mark.parametrize("algorithm", ["minibatches:GatheredOncePPO", "teacher:TeacherPPO"])
def test_the_training_algorithms_gather_once(algorithm):
    import importlib

    module, name = algorithm.split(":")
    cls = getattr(importlib.import_module(f"hybrid_recovery.training.{module}"), name)
    storage = _filled()
    alg = cls(torch.nn.Linear(1, 1), torch.nn.Linear(1, 1), storage)  # stand-in networks
    assert alg.storage is storage and type(storage) is GatheredOnceStorage
    torch.manual_seed(5)
    a = next(storage.mini_batch_generator(4, 1))
    torch.manual_seed(5)
    b = next(RolloutStorage.mini_batch_generator(storage, 4, 1))
    assert torch.equal(a.actions, b.actions)


def test_other_training_types_are_refused():
    obs = TensorDict({"policy": torch.zeros(2, 1)}, batch_size=[2])
    storage = RolloutStorage("distillation", 2, 3, obs, [1], "cpu")
    with pytest.raises(ValueError, match="only available for reinforcement learning"):
        next(gathered_once(storage, 1, 1))
