"""Closed-form fits shared by the fitted read-outs (comparator, name matcher, clip reader)."""

from __future__ import annotations

import torch

__all__ = ["as_loud_as_a_token", "ridge_solve"]


def as_loud_as_a_token(flat: torch.Tensor, shape: torch.Size, generator: torch.Generator) -> torch.Tensor:
    """Random verdict vectors whose norm is a token's mean norm in ``flat`` (videos × tokens·hidden)."""
    hidden = shape[-1]
    scale = flat.reshape(-1, hidden).pow(2).sum(-1).mean().sqrt() / hidden ** 0.5
    return torch.randn(shape, generator=generator) * scale


def ridge_solve(x: torch.Tensor, y: torch.Tensor, penalty: float) -> tuple[torch.Tensor, torch.Tensor]:
    """Ridge regression of ``y`` on per-dimension standardised ``x`` with the standardisation folded in: the weight
    (out×in) and bias of a Linear applied to raw ``x``. One row has no spread to standardise by: the fit is then the
    mean of ``y`` (zero weight), not the NaN an unbiased std of one value gives (a fold of a small dataset)."""
    x = x.double()
    mean = x.mean(0)
    std = (x.std(0) if x.shape[0] > 1 else torch.ones_like(mean)) + 1e-6
    z = (x - mean) / std
    y = y.double()
    w = torch.linalg.solve(z.T @ z + penalty * torch.eye(z.shape[1], dtype=z.dtype), z.T @ (y - y.mean(0)))
    return (w / std[:, None]).T, y.mean(0) - (mean / std) @ w
