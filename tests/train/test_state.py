"""Checkpoints are atomic, restore optimizer/scheduler/RNG, and keep only the newest few."""

from __future__ import annotations

import itertools
import random

import numpy as np
import pytest
import torch

from tacreasoner.train.state import (
    cosine_with_warmup,
    latest_checkpoint,
    load_checkpoint,
    save_checkpoint,
    seed_everything,
)


def _setup() -> tuple[torch.nn.Module, torch.optim.Optimizer, torch.optim.lr_scheduler.LambdaLR]:
    seed_everything(0)
    model = torch.nn.Linear(4, 2)
    opt = torch.optim.AdamW(model.parameters(), lr=1e-2)
    return model, opt, cosine_with_warmup(opt, warmup_steps=2, total_steps=10)


def _step(model, opt, sched) -> None:
    model(torch.randn(3, 4)).pow(2).sum().backward()
    opt.step()
    opt.zero_grad()
    sched.step()


def test_resuming_from_a_checkpoint_continues_exactly(tmp_path) -> None:
    model, opt, sched = _setup()
    for _ in range(3):
        _step(model, opt, sched)
    save_checkpoint(tmp_path, 3, model.state_dict(), opt, sched, extra={"seen": 9})
    for _ in range(2):
        _step(model, opt, sched)
    expected = {k: v.clone() for k, v in model.state_dict().items()}
    after = (random.random(), float(np.random.rand()))

    model2, opt2, sched2 = _setup()
    weights, state = load_checkpoint(latest_checkpoint(tmp_path), opt2, sched2)
    model2.load_state_dict(weights)
    assert state.step == 3 and state.extra == {"seen": 9}
    for _ in range(2):
        _step(model2, opt2, sched2)
    for k, v in model2.state_dict().items():
        assert torch.equal(v, expected[k])
    assert (random.random(), float(np.random.rand())) == after


def test_half_written_checkpoints_are_ignored_and_old_ones_pruned(tmp_path) -> None:
    model, opt, sched = _setup()
    for step in (1, 2, 3):
        save_checkpoint(tmp_path, step, model.state_dict(), opt, sched, keep=2)
    assert sorted(p.name for p in tmp_path.glob("step-*")) == ["step-00000002", "step-00000003"]
    (tmp_path / "step-00000009").mkdir()  # no state.json: a crash mid-write
    assert latest_checkpoint(tmp_path).name == "step-00000003"
    (tmp_path / "step-00000003" / "model.safetensors").write_bytes(b"garbage")
    with pytest.raises(ValueError, match="cannot be read"):
        load_checkpoint(tmp_path / "step-00000003")


def test_warmup_then_cosine() -> None:
    _, opt, sched = _setup()
    lrs = []
    for _ in range(12):
        lrs.append(opt.param_groups[0]["lr"])
        opt.step()
        sched.step()
    assert lrs[0] == pytest.approx(5e-3) and lrs[1] == pytest.approx(1e-2)
    assert all(a >= b for a, b in itertools.pairwise(lrs[1:]))
    assert lrs[-1] == pytest.approx(1e-3)
