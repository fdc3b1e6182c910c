"""CpuDropout: the Bernoulli dropout LoRA asks for, at its rate and scale, reproducible; installed in Stage II."""

from __future__ import annotations

import pytest
import torch
from torch import nn

from tacreasoner.model.dropout import CpuDropout, dropped_positions, use_cpu_dropout
from tacreasoner.model.stages import LoraSettings, configure_stage
from tests.model.test_stages import _model


def test_drops_at_the_stated_rate_and_keeps_the_expectation() -> None:
    drop = CpuDropout(0.05).train()
    x = torch.ones(400, 1000)
    y = drop(x)
    dropped = (y == 0).float().mean().item()
    assert abs(dropped - 0.05) < 0.002  # 400k draws: 4 standard errors ≈ 0.0014
    kept = y[y != 0]
    assert torch.allclose(kept, torch.full_like(kept, 1 / (1 - 0.05)), rtol=1e-6)
    assert abs(y.mean().item() - 1.0) < 0.003


def test_sparse_draws_drop_each_position_independently_at_the_rate_up_to_the_last() -> None:
    """LoRA's small rates place the drops by geometric gaps: every position, the last ones included, is dropped with
    probability p, independently of its neighbour (a gap law that is off shows in the rate or in the pairs)."""
    torch.manual_seed(0)
    n, p = 1_000_000, 0.05
    positions = dropped_positions(n, p)
    assert bool((positions[1:] > positions[:-1]).all()) and int(positions[0]) >= 0 and int(positions[-1]) < n
    mask = torch.zeros(n, dtype=torch.bool)
    mask[positions] = True
    assert abs(mask.float().mean().item() - p) < 0.0009  # 4 standard errors
    assert abs((mask[1:] & mask[:-1]).float().mean().item() - p * p) < 0.0003
    assert abs(mask[-n // 10:].float().mean().item() - p) < 0.0028
    hits = torch.zeros(3)
    for _ in range(4000):  # short rows: each of 3 positions at the rate, the end as often as the start
        hits[dropped_positions(3, p)] += 1
    assert torch.allclose(hits / 4000, torch.full((3,), p), atol=0.014)
    assert dropped_positions(0, p).numel() == 0
    x = torch.ones(30, 40).t()  # not contiguous: the drops still land in what is returned
    torch.manual_seed(1)
    y = CpuDropout(0.1).train()(x)
    assert y.shape == x.shape and 60 < int((y == 0).sum()) < 180  # 1200 elements at 0.1: 120 expected


def test_masks_differ_per_call_and_repeat_under_the_same_seed() -> None:
    for rate in (0.05, 0.5):  # the sparse and the per-element draws
        drop = CpuDropout(rate).train()
        x = torch.ones(64, 64)
        torch.manual_seed(3)
        first, second = drop(x), drop(x)
        torch.manual_seed(3)
        assert not torch.equal(first, second)
        assert torch.equal(drop(x), first)


def test_eval_mode_and_zero_rate_pass_the_input_through_and_gradients_follow_the_mask() -> None:
    x = torch.randn(8, 16, requires_grad=True)
    assert CpuDropout(0.3).eval()(x) is x
    assert CpuDropout(0.0).train()(x) is x
    for rate in (0.05, 0.3):
        x.grad = None
        y = CpuDropout(rate).train()(x)
        y.sum().backward()
        assert torch.allclose(x.grad, (y != 0).float() / (1 - rate))
    with pytest.raises(ValueError, match=r"\[0, 1\)"):
        CpuDropout(1.0)


def test_stage_two_gives_every_lora_layer_the_cpu_dropout_at_the_configured_rate() -> None:
    peft_model = configure_stage(_model(), 2, LoraSettings(r=4, alpha=8, dropout=0.1))
    drops = [d for m in peft_model.modules() if isinstance(getattr(m, "lora_dropout", None), nn.ModuleDict)
             for d in m.lora_dropout.values()]
    assert len(drops) == 4 * 2  # q, k, v, o in each of the tiny LLM's 2 layers
    assert all(isinstance(d, CpuDropout) and d.p == 0.1 for d in drops)
    assert use_cpu_dropout(peft_model) == 0  # nothing left to replace
