"""PPO's update with the critic's half on a second thread: the same steps, sooner.

rsl-rl's ``PPO.update`` minimises, per mini-batch, one loss

    L = L_clip(θ) + c_V · L_V(φ) − c_H · H(θ)

(clipped surrogate and entropy of the actor θ, clipped value loss of the critic φ) with
one backward pass and one Adam step over θ and φ. θ and φ share no parameter, so
∇_θ L = ∇_θ (L_clip − c_H · H) and ∇_φ L = c_V · ∇_φ L_V: the two halves' forward and
backward passes are independent. Here the critic's half runs on a worker thread while
the actor's runs on the caller's; then, as in rsl-rl, both gradients are clipped per
network (and averaged across GPUs under ``torchrun``) and one Adam step is taken. The
gradients, the KL-adapted learning rate and the step are rsl-rl's (the critic's half
does not read the learning rate, which the actor's half adapts before the step).

Why: on 2 CPU cores the update leaves about a third of a core idle (Python dispatch and
small single-threaded operations between the matrix products); the critic's work fills
it (``hybrid-recovery bench train``). Each half runs on half of torch's intra-op threads
(one each on 2 cores): two teams of two on two cores lost 5 % of the update to sharing.

Its networks' ELUs take a table for bf16 inputs (:mod:`~hybrid_recovery.training.table_elu`:
the same bits, a fifth of the time). Recurrent networks and RND keep rsl-rl's update.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager

import torch
from torch import nn

from hybrid_recovery.training.minibatches import GatheredOncePPO
from hybrid_recovery.training.table_elu import use_table_elu


class SplitUpdatePPO(GatheredOncePPO):
    """rsl-rl's PPO (mini-batches gathered once) whose update runs the critic's forward and
    backward passes beside the actor's."""

    learning_rate: float  # rsl-rl's, adapted by the KL schedule

    def __init__(self, actor, critic, *args, **kwargs) -> None:
        super().__init__(actor, critic, *args, **kwargs)
        use_table_elu(self.actor)
        use_table_elu(self.critic)

    def update(self) -> dict[str, float]:
        if self.rnd or self.actor.is_recurrent or self.critic.is_recurrent:
            return super().update()
        sums: dict[str, float] = defaultdict(float)
        generator = self.storage.mini_batch_generator(self.num_mini_batches,
                                                      self.num_learning_epochs)
        half = max(1, torch.get_num_threads() // 2)  # per half: the cores split, not shared
        with ThreadPoolExecutor(1, thread_name_prefix="critic-update",
                                initializer=torch.set_num_threads, initargs=(half,)) as pool:
            for batch in generator:
                size = batch.observations.batch_size[0]
                if self.normalize_advantage_per_mini_batch:
                    with torch.no_grad():
                        batch.advantages = (batch.advantages - batch.advantages.mean()) \
                            / (batch.advantages.std() + 1e-8)
                if self.symmetry:
                    self.symmetry.augment_batch(batch, size)
                self.optimizer.zero_grad()
                with _intra_op_threads(half):
                    critic = pool.submit(self._critic_half, batch)
                    try:
                        actor_losses = self._actor_half(batch, size)
                    finally:
                        value_loss = critic.result()  # joins (and re-raises) before any step
                if self.is_multi_gpu:
                    self.reduce_parameters()
                nn.utils.clip_grad_norm_(self.actor.parameters(), self.max_grad_norm)
                nn.utils.clip_grad_norm_(self.critic.parameters(), self.max_grad_norm)
                self.optimizer.step()
                sums["value"] += value_loss
                for name, value in actor_losses.items():
                    sums[name] += value
        obs = self.storage.observations.flatten(0, 1)
        self.actor.update_normalization(obs)
        self.critic.update_normalization(obs)
        updates = self.num_learning_epochs * self.num_mini_batches
        losses = {name: sums[name] / updates for name in ("value", "surrogate", "entropy")}
        if self.symmetry:
            losses["symmetry"] = sums["symmetry"] / updates
        self.storage.clear()
        return losses

    def autocast(self) -> torch.autocast:
        """The update's precision; autocast is thread-local, so each half enters its own."""
        return torch.autocast(torch.device(self.device).type, dtype=torch.bfloat16,
                              enabled=self.use_mixed_precision)

    def value_loss(self, batch) -> torch.Tensor:
        """L_V, rsl-rl's (clipped) value loss of the critic on ``batch``, in the update's
        precision."""
        with self.autocast():
            values = self.critic(batch.observations, masks=batch.masks,
                                 hidden_state=batch.hidden_states[1])
            if not self.use_clipped_value_loss:
                return (batch.returns - values).pow(2).mean()
            clipped = batch.values + (values - batch.values).clamp(-self.clip_param,
                                                                   self.clip_param)
            return torch.max((values - batch.returns).pow(2),
                             (clipped - batch.returns).pow(2)).mean()

    def actor_loss(self, batch, size: int, adapt_step_size: bool = True
                   ) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
        """L_clip − c_H · H [+ the mirror loss] of the actor on ``batch`` (its first ``size``
        samples the rollout's, the rest mirrored), in the update's precision, and its
        terms; the KL to the rollout's policy adapts the step size first (with
        ``adapt_step_size``; else it is only computed)."""
        with self.autocast():
            self.actor(batch.observations, masks=batch.masks,
                       hidden_state=batch.hidden_states[0], stochastic_output=True)
            log_prob = self.actor.get_output_log_prob(batch.actions)
            params = tuple(p[:size] for p in self.actor.output_distribution_params)
            entropy = self.actor.output_entropy[:size]
            if self.desired_kl is not None and self.schedule == "adaptive":
                with torch.inference_mode():
                    kl = torch.mean(self.actor.get_kl_divergence(
                        batch.old_distribution_params, params))
                if adapt_step_size:
                    self._adapt_learning_rate(kl)
            ratio = torch.exp(log_prob - torch.squeeze(batch.old_actions_log_prob))
            advantages = torch.squeeze(batch.advantages)
            clipped = torch.clamp(ratio, 1.0 - self.clip_param, 1.0 + self.clip_param)
            surrogate = torch.max(-advantages * ratio, -advantages * clipped).mean()
            terms = {"surrogate": surrogate, "entropy": entropy.mean()}
            loss = surrogate - self.entropy_coef * terms["entropy"]
            if self.symmetry:
                terms["symmetry"] = self.symmetry.compute_loss(self.actor, batch, size)
                if self.symmetry.use_mirror_loss:
                    loss = loss + self.symmetry.mirror_loss_coeff * terms["symmetry"]
        return loss, terms

    def _critic_half(self, batch) -> float:
        """c_V · L_V backward; returns L_V."""
        value_loss = self.value_loss(batch)
        (self.value_loss_coef * value_loss).backward()
        return value_loss.item()

    def _actor_half(self, batch, size: int) -> dict[str, float]:
        """The actor's loss backward; returns its terms."""
        loss, terms = self.actor_loss(batch, size)
        loss.backward()
        return {name: term.item() for name, term in terms.items()}

    def _adapt_learning_rate(self, kl: torch.Tensor) -> None:
        """rsl-rl's adaptive schedule: the step size ÷ 1.5 when the mean KL to the rollout's
        policy exceeds 2 · KL*, × 1.5 below KL* / 2 (within [1e-5, 1e-2]); under
        ``torchrun`` the mean over GPUs, decided on rank 0."""
        with torch.inference_mode():
            if self.is_multi_gpu:
                torch.distributed.all_reduce(kl, op=torch.distributed.ReduceOp.SUM)
                kl /= self.gpu_world_size
            rate = self.learning_rate
            if self.gpu_global_rank == 0:
                if kl > self.desired_kl * 2.0:
                    rate = max(1e-5, rate / 1.5)
                elif self.desired_kl / 2.0 > kl > 0.0:
                    rate = min(1e-2, rate * 1.5)
            if self.is_multi_gpu:
                shared = torch.tensor(rate, device=self.device)
                torch.distributed.broadcast(shared, src=0)
                rate = shared.item()
            self.learning_rate = rate
            for group in self.optimizer.param_groups:
                group["lr"] = rate


@contextmanager
def _intra_op_threads(threads: int) -> Iterator[None]:
    """torch's intra-op threads of the calling thread set to ``threads`` inside, then back
    (also the count that threads started later begin with)."""
    before = torch.get_num_threads()
    torch.set_num_threads(threads)
    try:
        yield
    finally:
        torch.set_num_threads(before)
