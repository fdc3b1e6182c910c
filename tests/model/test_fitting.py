"""The closed-form ridge fit behind the read-out heads (tacreasoner.model.fitting)."""

from __future__ import annotations

import torch

from tacreasoner.model.fitting import ridge_solve


def test_ridge_recovers_a_linear_map_on_raw_inputs() -> None:
    g = torch.Generator().manual_seed(0)
    x = torch.randn(200, 4, generator=g) * torch.tensor([1.0, 10.0, 0.1, 3.0]) + 5.0
    true_w, true_b = torch.randn(2, 4, generator=g), torch.randn(2, generator=g)
    weight, bias = ridge_solve(x, x @ true_w.T + true_b, penalty=1e-6)
    assert torch.allclose(weight.float(), true_w, atol=1e-3) and torch.allclose(bias.float(), true_b, atol=1e-2)


def test_one_row_fits_the_mean_instead_of_nan() -> None:
    x, y = torch.tensor([[1.0, 2.0, 3.0]]), torch.tensor([[0.5, -1.0]])
    weight, bias = ridge_solve(x, y, penalty=1.0)
    assert torch.isfinite(weight).all() and torch.isfinite(bias).all()
    assert torch.equal(weight, torch.zeros_like(weight)) and torch.allclose(bias, y[0].double())
