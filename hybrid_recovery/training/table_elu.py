"""ELU of bfloat16 tensors by table lookup: aten's own ELU, exactly, for a fraction of its
time.

In the bf16 update the networks' ELU, y = x for x > 0 and y = exp(x) − 1 otherwise, took
about a fifth of the PPO update's CPU time: aten evaluates ``expm1`` in float32 for every
element. A bfloat16 has only 2¹⁶ values, so y is a function of the input's 16 bits: a
table of aten's ELU at every one of them, read by one gather, gives the same bits
(``tests/test_table_elu.py`` checks all 65,536). The backward pass is autograd's own for
ELU (aten's ``elu_backward`` of the input). Other dtypes and devices take ``F.elu``.

The gather is a single-threaded compiled loop (numba) that releases the GIL: the update's
actor and critic halves (:mod:`~hybrid_recovery.training.split_update`) each run it on
their own thread.
"""

from __future__ import annotations

import functools

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from hybrid_recovery.dynamics.compiled import compiled

BITS = 1 << 16
"""Number of bfloat16 bit patterns, the table's length."""


@functools.cache
def _table() -> np.ndarray:
    """aten's ELU (α = 1) at every bfloat16 bit pattern; shape (2¹⁶,), uint16 bits."""
    patterns = torch.arange(BITS, dtype=torch.int32).to(torch.int16).view(torch.bfloat16)
    return F.elu(patterns).view(torch.int16).numpy().view(np.uint16).copy()


@compiled
def _gather(x: np.ndarray, out: np.ndarray, table: np.ndarray) -> None:
    """``out[i] = table[x[i]]``."""
    for i in range(x.size):
        out[i] = table[x[i]]


def _tabled(x: torch.Tensor) -> bool:
    """Whether ``x`` takes the table: bf16 on the CPU."""
    return x.dtype == torch.bfloat16 and x.device.type == "cpu"


def _bits(t: torch.Tensor) -> np.ndarray:
    """A contiguous bf16 tensor's bits as a flat uint16 array (a view, no copy)."""
    return t.view(torch.int16).numpy().view(np.uint16).reshape(-1)


def table_elu(x: torch.Tensor) -> torch.Tensor:
    """ELU(x), α = 1, without autograd; bit for bit ``F.elu(x)``.

    Args:
        x: any shape; bf16 on the CPU takes the table, anything else ``F.elu``.
    """
    if not _tabled(x):
        return F.elu(x)
    x = x.contiguous()
    out = torch.empty_like(x)
    _gather(_bits(x), _bits(out), _table())
    return out


class _TableELU(torch.autograd.Function):
    """The table's forward, autograd's backward for ELU (``elu_backward`` of the input)."""

    @staticmethod
    def forward(ctx, x: torch.Tensor) -> torch.Tensor:
        ctx.save_for_backward(x)
        return table_elu(x)

    @staticmethod
    def backward(ctx, grad: torch.Tensor) -> torch.Tensor:
        (x,) = ctx.saved_tensors
        return torch.ops.aten.elu_backward(grad, 1.0, 1.0, 1.0, False, x)


class TableELU(nn.Module):
    """``nn.ELU()`` whose bf16 forward on the CPU is a table lookup (same output, same
    gradients); parameter-free, so state dicts and exports are unchanged."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return _TableELU.apply(x) if _tabled(x) else F.elu(x)


def use_table_elu(model: nn.Module) -> int:
    """Replaces every default ``nn.ELU`` (α = 1, not in place) in ``model`` by
    :class:`TableELU`; returns how many."""
    swapped = 0
    for module in list(model.modules()):
        # not named_children(): it yields a module once, and rsl-rl's MLP reuses one ELU
        for name, child in list(module._modules.items()):
            if type(child) is nn.ELU and child.alpha == 1.0 and not child.inplace:
                setattr(module, name, TableELU())
                swapped += 1
    return swapped
