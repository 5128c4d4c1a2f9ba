"""A teacher for the learned stand-up: imitation of the recorded ground moves (beyond the
paper; off by default).

The hybrid's recorded rises (``hybrid-recovery getup record``) hold, along each
model-based ground move, the states (q, q̇), the PD targets q_ref the moves commanded
(the servos the policy drives) and the keyframe q_g each phase of a move drives them to
and then holds. The teacher's action is a* = (q_g − q*) / s, "go to where this phase
goes", on the states where the phase is still moving (q_ref ≠ q_g), not while it holds.
Why, measured: a memoryless policy cannot know the time. Imitating q_ref(t), which
smoothsteps from the phase's start, says "stay" at a phase's start (q_ref ≈ q); a hold's
quasi-static states labelled with the phase's own keyframe say "stay" where the next
phase must begin. Fitted offline to the same actor (600 Adam steps) and run closed-loop
from the moves' first states on the env's model: q_ref(t) turned over 0 of 8 moves,
q_g with the holds 4 of 8 (1 of 8 with one control step of delay), q_g without the holds
7 of 8 (7 of 8 with the delay); docs/experiments.md §11. After every PPO update
:class:`TeacherPPO` takes a few Adam steps on

    L_T = mean ‖μ_θ(o) − a*‖²

over the recorded move states o (the actor observation of each state, with the training
observation noise), μ_θ the actor's mean; the Adam step size is annealed linearly to zero
(Adam is invariant to the loss's scale, so the step size, not a loss weight, is what
anneals). The actor still sees proprioception only and the rewards are the paper's: the
teacher adds a gradient toward the moves' actions on their states, the "kickstarting"
of Schmitt et al. (arXiv 1803.03835) with recorded states in place of a teacher network.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import mujoco
import numpy as np
import torch
from rsl_rl.utils.utils import reduce_gradients_in_buckets
from tensordict import TensorDict

from hybrid_recovery.envs import RecoveryEnv
from hybrid_recovery.envs.rise_starts import move_progress
from hybrid_recovery.observation.actor import actor_observation
from hybrid_recovery.observation.mujoco_source import ProprioceptionMap, read_proprioception
from hybrid_recovery.robot.action import clip_action
from hybrid_recovery.robot.constants import DEFAULT_JOINT_POS
from hybrid_recovery.training.config import TeacherConfig
from hybrid_recovery.training.split_update import SplitUpdatePPO

_HOW = ("re-record it with `hybrid-recovery getup record --pose POSE --episodes N "
        "--policy P --out FILE`, which writes them")


def teacher_samples(paths: Sequence[str | Path], model: mujoco.MjModel, action_scale: float
                    ) -> tuple[np.ndarray, np.ndarray]:
    """The actor observations and the moves' actions of every recorded move state.

    A move state is a sample after the settle and before the hand-over to the policy
    (:func:`hybrid_recovery.envs.rise_starts.move_progress`) whose phase is still moving
    toward its keyframe: ``target`` (q_ref) recorded and not yet equal to ``goal`` (q_g).
    Its observation is :func:`~hybrid_recovery.observation.actor.actor_observation` of
    the state read through the torso IMU of ``model``, without noise, with a_{t−1} the
    previous move sample's action, a held one included (its own at a move's first
    sample).

    Args:
        paths: recordings (``.npz``) with ``target`` and ``goal`` arrays.
        model: the robot model the states belong to (its kinematics give the IMU).
        action_scale: s [rad], q_ref = q* + s · a.

    Returns:
        (obs (M, 87) float32, a* (M, 27) float32), a* clipped to ±ACTION_CLIP.

    A recording without joint-PD ground moves (no ``<move>/<keyframe>`` phase: the model
    controller's rise from the kneel, on torques throughout) gives no samples.

    Raises:
        ValueError: no recordings, a file without ``target`` or ``goal``, one with ground
            moves but no moving move sample (the message names the file), or no sample
            in any file.
    """
    if not paths:
        raise ValueError("the teacher needs recorded rises: set rises.files")
    where = ProprioceptionMap.of(model)
    data = mujoco.MjData(model)
    obs, actions = [], []
    for path in paths:
        with np.load(path, allow_pickle=False) as rec:
            missing = [k for k in ("target", "goal") if k not in rec.files]
            if missing:
                raise ValueError(f"rise recording {path} has no {missing} (the moves' "
                                 f"targets and keyframes); {_HOW}")
            qpos, qvel, target, goal = rec["qpos"], rec["qvel"], rec["target"], rec["goal"]
            phase = rec["phase"].astype(str)
            on_move, _ = move_progress(rec["time"], rec["episode"], phase)
            episode = rec["episode"]
        if not any("/" in p for p in np.unique(phase)):
            continue  # no joint-PD ground move to imitate
        known = on_move & np.isfinite(goal).all(axis=1) & np.isfinite(target).all(axis=1)
        every = clip_action((np.nan_to_num(goal) - DEFAULT_JOINT_POS) / action_scale)
        # a_{t−1}: the previous sample's keyframe action, held ones included
        follows = np.r_[False, known[:-1] & (np.diff(episode) == 0)]
        last_every = np.where(follows[:, None], np.roll(every, 1, axis=0), every)
        rows = np.flatnonzero(known)
        rows = rows[np.abs(target[rows] - goal[rows]).max(axis=1) > 1e-9]
        if not len(rows):
            raise ValueError(f"rise recording {path}: no move sample whose targets move; "
                             f"{_HOW}")
        act, last = every[rows], last_every[rows]
        for k, row in enumerate(rows):
            data.qpos[:], data.qvel[:] = qpos[row], qvel[row]
            mujoco.mj_forward(model, data)
            gyro, quat, q, dq = read_proprioception(model, data, where)
            obs.append(actor_observation(gyro[None], quat[None], q[None], dq[None],
                                         last[k][None])[0])
        actions.append(act)
    if not obs:
        raise ValueError(f"no rise recording of {[str(p) for p in paths]} holds a joint-PD "
                         f"ground move for the teacher")
    return np.stack(obs).astype(np.float32), np.concatenate(actions).astype(np.float32)


class Teacher:
    """Annealed Adam steps of the imitation loss L_T on the actor.

    Args:
        obs: (M, 87) recorded move observations, without noise.
        actions: (M, 27) their actions a*.
        noise: (87,) half-widths of the uniform noise added to each drawn observation
            (the training's actor noise).
        cfg: the settings (``learning_rate`` > 0).
        seed: of the draws.
    """

    def __init__(self, obs: np.ndarray, actions: np.ndarray, noise: np.ndarray,
                 cfg: TeacherConfig, seed: int = 0) -> None:
        if not cfg.learning_rate > 0.0 or cfg.steps < 1 or cfg.batch_size < 1 \
                or cfg.anneal_iterations < 1:
            raise ValueError(f"the teacher needs learning_rate > 0, steps >= 1, batch_size "
                             f">= 1 and anneal_iterations >= 1; got {cfg}")
        if len(obs) != len(actions) or not len(obs):
            raise ValueError(f"teacher data: {len(obs)} observations, {len(actions)} actions")
        self.cfg = cfg
        self.obs, self.actions = torch.as_tensor(obs), torch.as_tensor(actions)
        self.noise = torch.as_tensor(noise, dtype=torch.float32)
        self.updates = 0
        """PPO updates the teacher has followed (its anneal's clock)."""
        self._generator = torch.Generator().manual_seed(seed)
        self._optimizer: torch.optim.Adam | None = None
        self._saved_optimizer: dict | None = None
        self._reference: dict[str, torch.Tensor] | None = None
        self._saved_reference: dict | None = None

    def learning_rate(self) -> float:
        """Step size now: lr₀ · max(0, 1 − updates / anneal_iterations)."""
        return self.cfg.learning_rate * max(0.0, 1.0 - self.updates / self.cfg.anneal_iterations)

    def step(self, actor: torch.nn.Module, anchor: torch.Tensor | None = None,
             reduce: Callable[[list[torch.nn.Parameter]], None] | None = None
             ) -> dict[str, float]:
        """``steps`` Adam steps of L_T (+ ``cfg.anchor`` · L_A) on ``actor`` (mean output).

        Args:
            anchor: o (R, 87), the rollout's actor observations; L_A = mean
                ‖μ_θ(o) − μ_ref(o)‖² over a batch of them, μ_ref the actor frozen at the
                teacher's first step, keeps the actor where it was on its own states.
            reduce: averages the gradients of these parameters over the training's
                processes (``torchrun``) before each step, so that every rank's actor
                takes the same step; None: one process.

        Returns:
            the mean L_T before each step (``teacher``), the mean L_A (``anchor``, when
            given) and the step size (``teacher_lr``); once annealed to zero, nothing is
            stepped and only ``teacher_lr`` is returned.
        """
        lr = self.learning_rate()
        self.updates += 1
        if lr <= 0.0:
            return {"teacher_lr": 0.0}
        if self._optimizer is None:
            params = [p for p in actor.parameters() if p.requires_grad]
            self._optimizer = torch.optim.Adam(params, lr=lr)
            if self._saved_optimizer is not None:
                self._optimizer.load_state_dict(self._saved_optimizer)
        for group in self._optimizer.param_groups:
            group["lr"] = lr
        total, held = 0.0, 0.0
        n = self.cfg.batch_size
        for _ in range(self.cfg.steps):
            idx = torch.randint(len(self.obs), (n,), generator=self._generator)
            noise = (2.0 * torch.rand(n, self.obs.shape[1], generator=self._generator)
                     - 1.0) * self.noise
            obs = TensorDict({"policy": self.obs[idx] + noise}, batch_size=[n])
            loss = (actor(obs) - self.actions[idx]).pow(2).sum(-1).mean()
            total += loss.item()
            if anchor is not None and self.cfg.anchor > 0.0:
                pick = torch.randint(len(anchor), (n,), generator=self._generator)
                own = TensorDict({"policy": anchor[pick]}, batch_size=[n])
                with torch.no_grad():
                    ref = torch.func.functional_call(actor, self._reference_of(actor), (own,))
                kept = (actor(own) - ref).pow(2).sum(-1).mean()
                held += kept.item()
                loss = loss + self.cfg.anchor * kept
            self._optimizer.zero_grad()
            loss.backward()
            params = self._optimizer.param_groups[0]["params"]
            if reduce is not None:
                reduce(params)
            torch.nn.utils.clip_grad_norm_(params, 1.0)
            self._optimizer.step()
        out = {"teacher": total / self.cfg.steps, "teacher_lr": lr}
        if anchor is not None and self.cfg.anchor > 0.0:
            out["anchor"] = held / self.cfg.steps
        return out

    def _reference_of(self, actor: torch.nn.Module) -> dict[str, torch.Tensor]:
        """The actor's parameters and buffers as they were at the teacher's first step
        (frozen), for the anchor."""
        if self._reference is None:
            self._reference = self._saved_reference or {
                k: v.detach().clone() for k, v in actor.state_dict().items()}
        return self._reference

    def state_dict(self) -> dict:
        return {"updates": self.updates,
                "optimizer": None if self._optimizer is None else self._optimizer.state_dict(),
                "reference": self._reference}

    def load_state_dict(self, state: dict) -> None:
        self.updates = int(state["updates"])
        self._saved_optimizer = state.get("optimizer")
        self._saved_reference = state.get("reference")


class TeacherPPO(SplitUpdatePPO):
    """The training's PPO followed, after every update, by the :class:`Teacher`'s steps
    (when one is attached); the PPO update itself is untouched."""

    teacher: Teacher | None = None

    def update(self) -> dict[str, float]:
        anchor = None
        if self.teacher is not None:  # the rollout, before the update clears it
            assert self.storage.observations is not None
            anchor = self.storage.observations["policy"].flatten(0, 1).clone()
        losses = super().update()
        if self.teacher is not None:
            losses.update(self.teacher.step(self._raw_actor, anchor,
                                            self._reduce if self.is_multi_gpu else None))
        return losses

    def _reduce(self, params: list[torch.nn.Parameter]) -> None:
        """The teacher's gradients averaged over the processes, as rsl-rl's PPO's."""
        reduce_gradients_in_buckets(params, self.gpu_world_size, self.grad_reduce_bucket_mb)


def make_teacher(cfg: TeacherConfig, env: RecoveryEnv, seed: int = 0) -> Teacher:
    """The teacher of a run: the move states and actions of ``env``'s ``rises.files`` on
    its model, with its actor observation noise.

    Raises:
        ValueError: bad settings or recordings (:func:`teacher_samples`, :class:`Teacher`).
    """
    obs, actions = teacher_samples(env.cfg.rises.files, env.model, env.cfg.action_scale)
    teacher = Teacher(obs, actions, env.noise, cfg, seed=seed)
    print(f"[hybrid-recovery] teacher: {len(obs)} recorded move states, lr0 "
          f"{cfg.learning_rate:g} annealed over {cfg.anneal_iterations} updates", flush=True)
    return teacher

