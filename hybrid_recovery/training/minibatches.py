"""PPO's mini-batches gathered once per update instead of once per mini-batch.

rsl-rl's ``RolloutStorage.mini_batch_generator`` draws one permutation of the rollout's
T · N samples per update and, for every epoch and mini-batch, gathers the mini-batch's
rows of every rollout tensor by index: E · M gathers of B = T · N / M rows. The same
permutation serves every epoch, so gathering the whole rollout in permuted order once and
yielding contiguous slices of it (views, no copy) gives the same mini-batches, in the same
order, for one gather of T · N rows: on the paper's E = 5, M = 4 and T · N = 24,576, a
twentieth of the indexing.
"""

from __future__ import annotations

from collections.abc import Generator

import torch
from rsl_rl.algorithms import PPO
from rsl_rl.storage import RolloutStorage


def gathered_once(storage: RolloutStorage, num_mini_batches: int,
                  num_epochs: int = 8) -> Generator[RolloutStorage.Batch, None, None]:
    """``storage.mini_batch_generator``'s mini-batches (feedforward RL), gathered once.

    Args:
        storage: A filled rollout storage (``training_type == "rl"``).
        num_mini_batches: M; the mini-batch size is B = ⌊T · N / M⌋ and the T · N mod M
            samples the permutation leaves out are left out, as rsl-rl does.
        num_epochs: E passes over the same M mini-batches.

    Yields:
        E · M batches whose tensors are views of one permuted copy of the rollout; the
        update replaces a batch's fields (advantage normalisation, symmetry augmentation)
        but never writes into them.

    Raises:
        ValueError: a storage of another training type (as rsl-rl).
    """
    if storage.training_type != "rl":
        raise ValueError("This function is only available for reinforcement learning training.")
    size = storage.num_envs * storage.num_transitions_per_env // num_mini_batches
    order = torch.randperm(num_mini_batches * size, device=storage.device)
    assert storage.observations is not None and storage.distribution_params is not None

    def permuted(x: torch.Tensor) -> torch.Tensor:
        return x.flatten(0, 1)[order]

    observations = storage.observations.flatten(0, 1)[order]
    actions, values, returns = (permuted(x) for x in (storage.actions, storage.values,
                                                      storage.returns))
    log_prob, advantages = permuted(storage.actions_log_prob), permuted(storage.advantages)
    params = tuple(permuted(p) for p in storage.distribution_params)
    for _ in range(num_epochs):
        for i in range(num_mini_batches):
            rows = slice(i * size, (i + 1) * size)
            yield RolloutStorage.Batch(
                observations=observations[rows], actions=actions[rows], values=values[rows],
                advantages=advantages[rows], returns=returns[rows],
                old_actions_log_prob=log_prob[rows],
                old_distribution_params=tuple(p[rows] for p in params))


class GatheredOnceStorage(RolloutStorage):
    """rsl-rl's rollout storage with :func:`gathered_once` as its feedforward mini-batch
    generator (no state is added)."""

    def mini_batch_generator(self, num_mini_batches: int,
                             num_epochs: int = 8) -> Generator[RolloutStorage.Batch, None, None]:
        return gathered_once(self, num_mini_batches, num_epochs)


class GatheredOncePPO(PPO):
    """rsl-rl's PPO, its update untouched, on a :class:`GatheredOnceStorage` (the training's
    algorithm's base; :class:`hybrid_recovery.training.split_update.SplitUpdatePPO` extends it)."""

    def __init__(self, actor, critic, storage: RolloutStorage, *args, **kwargs) -> None:
        if type(storage) is RolloutStorage:  # the class only: no state to convert
            storage.__class__ = GatheredOnceStorage
        super().__init__(actor, critic, storage, *args, **kwargs)
