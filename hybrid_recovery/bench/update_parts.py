"""Where the PPO update's time goes: its parts timed one by one on a real mini-batch."""

from __future__ import annotations

import copy
import time
from collections.abc import Callable

import torch
from torch import nn

from hybrid_recovery.bench.timing import best_seconds

UPDATE_PARTS = ("minibatch_shuffling", "actor_forward", "actor_backward", "critic_forward",
                "critic_backward", "optimiser", "normalisers", "symmetry_augmentation")
"""The parts of :func:`time_update_parts`, in the order of one mini-batch step."""


def fill_storage(runner) -> None:
    """One rollout of ``num_steps_per_env`` steps into ``runner.alg.storage``, then the
    returns and advantages: what ``OnPolicyRunner.learn`` does before each update."""
    alg, env, device = runner.alg, runner.env, runner.device
    obs = env.get_observations().to(device)
    with torch.inference_mode():
        for _ in range(runner.cfg["num_steps_per_env"]):
            actions = alg.act(obs)
            obs, rewards, dones, extras = env.step(actions.to(env.device))
            obs, rewards, dones = obs.to(device), rewards.to(device), dones.to(device)
            alg.process_env_step(obs, rewards, dones, extras)
        alg.compute_returns(obs)


def time_update_parts(alg, repeat: int = 3) -> dict[str, float]:
    """Seconds per PPO update spent in each of :data:`UPDATE_PARTS` [s per iteration].

    Each part is timed on the first mini-batch of the filled rollout storage, best of
    ``repeat`` runs, and scaled by the update's ``num_learning_epochs × num_mini_batches``
    mini-batch steps; the normalisers and the mini-batch generator (one whole pass over
    the epochs) are timed per update. The losses are the update's own
    (:class:`~hybrid_recovery.training.split_update.SplitUpdatePPO`'s ``actor_loss`` and
    ``value_loss``, in its precision); the actor's includes the log-probability, entropy
    and KL, the critic's the clipped value loss. The augmentation counts only when the symmetry
    extension is on, whose mirrored batch the other parts then see. Weights, optimiser
    state and normalisers are restored afterwards, so the storage and the networks are
    as they were.
    """
    steps = alg.num_learning_epochs * alg.num_mini_batches
    saved = _snapshot(alg)
    try:
        shuffle = best_seconds(lambda: _pass_over(alg), repeat)
        batch = next(alg.storage.mini_batch_generator(alg.num_mini_batches, 1))
        size = batch.observations.batch_size[0]
        augment = 0.0
        if alg.symmetry:
            augment = best_seconds(
                lambda: alg.symmetry.augment_batch(copy.copy(batch), size), repeat)
            alg.symmetry.augment_batch(batch, size)
        actor_fwd, actor_bwd = _forward_backward(alg, lambda: _actor_loss(alg, batch, size),
                                                 repeat)
        critic_fwd, critic_bwd = _forward_backward(alg, lambda: _critic_loss(alg, batch),
                                                   repeat)
        _actor_loss(alg, batch, size).backward()
        _critic_loss(alg, batch).backward()
        optimiser = best_seconds(lambda: _optimiser_step(alg), repeat)
        _restore(alg, saved)
        obs = alg.storage.observations.flatten(0, 1)
        normalisers = best_seconds(lambda: (alg.actor.update_normalization(obs),
                                     alg.critic.update_normalization(obs)), repeat)
    finally:
        _restore(alg, saved)
    per_step = {"actor_forward": actor_fwd,
                "actor_backward": actor_bwd, "critic_forward": critic_fwd,
                "critic_backward": critic_bwd, "optimiser": optimiser,
                "symmetry_augmentation": augment}
    per_update = {"normalisers": normalisers, "minibatch_shuffling": shuffle}
    return {k: per_update[k] if k in per_update else per_step[k] * steps for k in UPDATE_PARTS}


def ratio_noise(alg) -> float:
    """Mean |r − 1| of PPO's ratio r = π_θ(a|s) / π_θold(a|s) on the first mini-batch of the
    filled storage, before any step: θ = θold, so r = 1 up to the rounding of the update's
    forward pass (float32: ~1e-3 from other matmul blocking than the rollout's; bf16: the
    rounding of the action mean, whose log-probability error grows as 1/σ). Compare
    with the clip range ε = 0.2.
    """
    batch = next(alg.storage.mini_batch_generator(alg.num_mini_batches, 1))
    with torch.no_grad(), alg.autocast():
        alg.actor(batch.observations, stochastic_output=True)
        log_prob = alg.actor.get_output_log_prob(batch.actions).float()
    ratio = torch.exp(log_prob - batch.old_actions_log_prob.squeeze())
    return float((ratio - 1.0).abs().mean())


def _actor_loss(alg, batch, size: int) -> torch.Tensor:
    """The update's actor loss, with its KL estimate but no step-size adaptation."""
    return alg.actor_loss(batch, size, adapt_step_size=False)[0]


def _critic_loss(alg, batch) -> torch.Tensor:
    """The update's weighted value loss c_V · L_V."""
    return alg.value_loss(batch) * alg.value_loss_coef


def _forward_backward(alg, loss_fn: Callable[[], torch.Tensor],
                      repeat: int) -> tuple[float, float]:
    """Best forward and best backward time of ``loss_fn`` [s]."""
    forward, backward = float("inf"), float("inf")
    for _ in range(repeat + 1):  # the first is a warm-up
        alg.optimizer.zero_grad()
        t = time.perf_counter()
        loss = loss_fn()
        t1 = time.perf_counter()
        loss.backward()
        t2 = time.perf_counter()
        forward, backward = min(forward, t1 - t), min(backward, t2 - t1)
    return forward, backward


def _optimiser_step(alg) -> None:
    nn.utils.clip_grad_norm_(alg.actor.parameters(), alg.max_grad_norm)
    nn.utils.clip_grad_norm_(alg.critic.parameters(), alg.max_grad_norm)
    alg.optimizer.step()


def _pass_over(alg) -> None:
    for _ in alg.storage.mini_batch_generator(alg.num_mini_batches, alg.num_learning_epochs):
        pass


def _snapshot(alg) -> tuple[dict, dict, dict]:
    return (copy.deepcopy(alg.actor.state_dict()), copy.deepcopy(alg.critic.state_dict()),
            copy.deepcopy(alg.optimizer.state_dict()))


def _restore(alg, saved: tuple[dict, dict, dict]) -> None:
    alg.actor.load_state_dict(saved[0])
    alg.critic.load_state_dict(saved[1])
    alg.optimizer.load_state_dict(saved[2])
    alg.optimizer.zero_grad()
