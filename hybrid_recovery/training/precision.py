"""The PPO update's precision, chosen by what this CPU does fast.

The bf16 update (``PPOConfig.mixed_precision``) halves the update on a CPU with native
bfloat16 arithmetic (AVX-512 BF16, AMX) and is several times slower than float32 on one
without it, where every bf16 product is emulated. :func:`choose_precision` times one
mini-batch's forward and backward pass of networks of the run's shape in both precisions,
alternating, and takes the faster: the choice follows the machine, never one machine's
tuning. ``PPOConfig.mixed_precision = None`` asks for it at every start and resume.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import torch
from torch import nn

from hybrid_recovery.training.table_elu import use_table_elu

NATIVE_BF16_FLAGS = ("avx512_bf16", "amx_bf16")
"""x86 CPU flags of native bfloat16 arithmetic (``/proc/cpuinfo``)."""


@dataclass(frozen=True)
class PrecisionChoice:
    """The update precision chosen for a run and why."""

    mixed_precision: bool
    """True: the bf16 update; False: float32."""
    reason: str
    """One line: the measured times or the setting that decided."""
    fp32_s: float | None = None
    """Best measured time of one mini-batch's forward and backward pass in float32 [s]."""
    bf16_s: float | None = None
    """The same under bf16 autocast [s]."""
    native_bf16: bool | None = None
    """Whether the CPU lists a native bf16 flag (:data:`NATIVE_BF16_FLAGS`)."""

    def as_dict(self) -> dict:
        return asdict(self)


def cpu_flags(cpuinfo: str | Path = "/proc/cpuinfo") -> frozenset[str]:
    """The first processor's flags in ``cpuinfo``; empty where the file cannot be read."""
    try:
        for line in Path(cpuinfo).read_text().splitlines():
            if line.startswith(("flags", "Features")):
                return frozenset(line.split(":", 1)[1].split())
    except OSError:
        pass
    return frozenset()


def _networks(obs_dims: Sequence[int], hidden_dims: Sequence[int], num_actions: int
              ) -> list[nn.Sequential]:
    """MLPs of the actor's and critic's shape (rsl-rl's MLP: Linear + ELU per hidden layer)."""
    nets: list[nn.Sequential] = []
    for obs_dim, out in zip(obs_dims, (num_actions, 1), strict=True):
        layers: list[nn.Module] = []
        width = obs_dim
        for hidden in hidden_dims:
            layers += [nn.Linear(width, hidden), nn.ELU()]
            width = hidden
        layers.append(nn.Linear(width, out))
        net = nn.Sequential(*layers)
        use_table_elu(net)
        nets.append(net)
    return nets


def _in_features(net: nn.Sequential) -> int:
    first = net[0]
    assert isinstance(first, nn.Linear)
    return first.in_features


def time_update_pass(mixed_precision: bool, nets: Sequence[nn.Sequential], batch: int,
                     generator: torch.Generator) -> float:
    """Seconds of one forward and backward pass of ``nets`` on ``batch`` random samples,
    under bf16 autocast when ``mixed_precision`` (weights float32, as in the update)."""
    inputs = [torch.randn(batch, _in_features(net), generator=generator) for net in nets]
    start = time.perf_counter()
    with torch.autocast("cpu", dtype=torch.bfloat16, enabled=mixed_precision):
        loss = sum(net(x).float().square().mean() for net, x in zip(nets, inputs, strict=True))
    loss.backward()  # type: ignore[union-attr]
    return time.perf_counter() - start


Timer = Callable[[bool], float]
"""One timed pass in the given precision (True: bf16) → seconds."""


def choose_precision(obs_dims: Sequence[int], hidden_dims: Sequence[int], num_actions: int,
                     batch: int, pairs: int = 3, timer: Timer | None = None,
                     flags: frozenset[str] | None = None) -> PrecisionChoice:
    """The faster update precision on this CPU.

    Times ``pairs`` alternating float32/bf16 passes (after one warm-up pass of each) of
    networks of the run's shape on one mini-batch and takes the precision whose best
    time is lower.

    Args:
        obs_dims: (actor, critic) observation sizes.
        hidden_dims: hidden layer widths of both networks.
        num_actions: actor outputs.
        batch: samples per mini-batch (num_envs × steps / mini-batches; capped at 8192,
            which ranks the two as the full batch does).
        timer: replaces the measurement (tests).
        flags: CPU flags (default: :func:`cpu_flags`).
    """
    flags = cpu_flags() if flags is None else flags
    native = any(f in flags for f in NATIVE_BF16_FLAGS)
    if timer is None:
        generator = torch.Generator().manual_seed(0)
        nets = _networks(obs_dims, hidden_dims, num_actions)
        size = min(int(batch), 8192)

        def timer(mixed: bool) -> float:
            return time_update_pass(mixed, nets, size, generator)

        timer(False), timer(True)  # warm-up: allocation, the ELU table
    fp32, bf16 = float("inf"), float("inf")
    for _ in range(pairs):
        fp32 = min(fp32, timer(False))
        bf16 = min(bf16, timer(True))
    mixed = bf16 < fp32
    reason = (f"{'bf16' if mixed else 'fp32'}: measured {bf16 * 1e3:.1f} ms bf16 vs "
              f"{fp32 * 1e3:.1f} ms fp32 per mini-batch pass; native bf16 "
              f"{'yes' if native else 'no'}")
    return PrecisionChoice(mixed, reason, fp32, bf16, native)


def fixed_precision(mixed_precision: bool) -> PrecisionChoice:
    """The choice of a run whose settings fix the precision."""
    return PrecisionChoice(mixed_precision, f"{'bf16' if mixed_precision else 'fp32'}: set "
                           f"by the run's settings (ppo.mixed_precision)")
