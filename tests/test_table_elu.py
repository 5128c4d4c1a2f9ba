"""The bf16 ELU by table lookup: aten's ELU bit for bit, forward and backward."""

from __future__ import annotations

import threading

import torch
from rsl_rl.modules import MLP
from torch import nn
from torch.nn import functional as F

from hybrid_recovery.training.table_elu import BITS, TableELU, table_elu, use_table_elu


def _bits(t: torch.Tensor) -> torch.Tensor:
    return t.view(torch.int16) if t.dtype == torch.bfloat16 else t.view(torch.int32)


def test_every_bfloat16_value_maps_as_aten_elu():
    patterns = torch.arange(BITS, dtype=torch.int32).to(torch.int16).view(torch.bfloat16)
    assert torch.equal(_bits(table_elu(patterns)), _bits(F.elu(patterns)))  # NaNs, ±inf, ±0 too


def test_the_gradient_is_autograds_for_elu():
    gen = torch.Generator().manual_seed(0)
    x = (4 * torch.randn(257, 33, generator=gen)).to(torch.bfloat16)
    x[0, :4] = torch.tensor([0.0, -0.0, 1e-30, -1e-30])
    grad = torch.randn(257, 33, generator=gen).to(torch.bfloat16)
    theirs, ours = x.clone().requires_grad_(), x.clone().requires_grad_()
    y_theirs, y_ours = F.elu(theirs), TableELU()(ours)
    y_theirs.backward(grad)
    y_ours.backward(grad)
    assert torch.equal(_bits(y_ours), _bits(y_theirs))
    assert torch.equal(_bits(ours.grad), _bits(theirs.grad))


def test_other_dtypes_and_views_take_the_same_values():
    x = torch.randn(16, 8, dtype=torch.float32)
    assert torch.equal(_bits(TableELU()(x)), _bits(F.elu(x)))
    strided = torch.randn(8, 16).to(torch.bfloat16).t()  # not contiguous
    assert torch.equal(_bits(table_elu(strided)), _bits(F.elu(strided)))


def test_two_threads_at_once_get_their_own_results():
    inputs = [torch.randn(512, 256).to(torch.bfloat16) for _ in range(2)]
    outputs: list[torch.Tensor | None] = [None, None]

    def run(k: int) -> None:
        for _ in range(20):
            outputs[k] = table_elu(inputs[k])

    threads = [threading.Thread(target=run, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for x, y in zip(inputs, outputs, strict=True):
        assert y is not None and torch.equal(_bits(y), _bits(F.elu(x)))


def test_every_elu_of_rsl_rls_mlp_is_replaced_and_nothing_else_changes():
    torch.manual_seed(0)
    mlp = MLP(10, 3, (32, 16, 8), "elu")  # one ELU module, reused after each hidden layer
    keys = list(mlp.state_dict())
    x = torch.randn(64, 10)
    with torch.autocast("cpu", dtype=torch.bfloat16):
        before = mlp(x)
    assert use_table_elu(mlp) == 3
    assert sum(isinstance(m, TableELU) for m in mlp) == 3
    assert not any(type(m) is nn.ELU for m in mlp)
    assert list(mlp.state_dict()) == keys
    with torch.autocast("cpu", dtype=torch.bfloat16):
        assert torch.equal(_bits(mlp(x)), _bits(before))
    other = nn.Sequential(nn.ELU(alpha=0.5), nn.ELU(inplace=True))
    assert use_table_elu(other) == 0
