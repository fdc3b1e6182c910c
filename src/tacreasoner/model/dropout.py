"""LoRA's input dropout, cheaper on the CPU.

``nn.Dropout`` on the CPU draws its mask with ``bernoulli_``, one slow draw per element: in the tiny
default's Stage II it cost more than a tenth of every step (16 adapted projections, 2 CPU cores). Drawing
31-bit integers with ``random_`` and comparing them to a threshold gives the same Bernoulli mask about twice
as fast (benchmarks/results/train_speed.md), but still one draw per element on one thread: 9% of a quickstart
Stage II step (experiments/2026-11-28_quickstart_b4). At LoRA's usual small rates the mask is drawn sparsely
instead: the gaps between dropped elements of a Bernoulli(p) sequence are geometric, so about p·n draws (each a
31-bit integer turned into a gap by the inverse CDF) place the same drops. Elsewhere (CUDA) the usual kernel is
already fast and is used.
"""

from __future__ import annotations

import math

import torch
from torch import nn

__all__ = ["CpuDropout", "use_cpu_dropout"]

_RANGE = 2**31
"""``random_`` on int32 draws uniformly from [0, 2^31)."""
SPARSE_BELOW = 0.2
"""Rates below this draw the dropped positions (about p·n draws); higher rates a threshold per element."""


def dropped_positions(n: int, p: float) -> torch.Tensor:
    """The positions in ``range(n)`` that i.i.d. Bernoulli(``p``) draws drop, in order, from about ``p·n`` draws:
    each gap to the next drop is geometric, ``floor(log(u) / log(1 - p)) + 1`` for ``u`` uniform on (0, 1] in
    steps of 2^-31 (so each gap's law is exact to within 2^-31)."""
    if not 0 < p < 1:
        raise ValueError(f"dropout probability must be in (0, 1) to place drops, got {p}")
    log_keep = math.log1p(-p)
    found, last = [torch.empty(0, dtype=torch.long)], -1
    while last < n - 1:
        left = n - 1 - last
        count = int(left * p + 6 * math.sqrt(left * p) + 16)  # enough to pass the end but for ~1e-9 of calls
        uniform = (torch.empty(count, dtype=torch.int32).random_().double() + 1) / _RANGE
        gaps = torch.floor(torch.log(uniform) / log_keep).long() + 1
        positions = last + gaps.cumsum(0)
        found.append(positions[positions < n])
        last = int(positions[-1])
    return torch.cat(found)


class CpuDropout(nn.Module):
    """Dropout with probability ``p`` to within 5e-10; kept values are scaled so the expectation is unchanged.
    Draws from torch's default generator, so ``torch.manual_seed`` reproduces it."""

    def __init__(self, p: float) -> None:
        super().__init__()
        if not 0 <= p < 1:
            raise ValueError(f"dropout probability must be in [0, 1), got {p}")
        self.p = p
        self.threshold = round(p * _RANGE)
        self.scale = _RANGE / (_RANGE - self.threshold)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if not self.training or self.threshold == 0:
            return x
        if x.device.type != "cpu":
            return nn.functional.dropout(x, self.p, training=True)
        if self.p < SPARSE_BELOW:
            out = (x * self.scale).contiguous()  # a flat view of it below: the drops land in it
            out.view(-1).index_fill_(0, dropped_positions(x.numel(), self.p), 0)
            return out
        draws = torch.empty(x.shape, dtype=torch.int32).random_()
        return x * ((draws >= self.threshold).to(x.dtype) * self.scale)

    def extra_repr(self) -> str:
        return f"p={self.p}"


def use_cpu_dropout(model: nn.Module) -> int:
    """Replace the ``nn.Dropout`` of every PEFT LoRA layer in ``model`` by :class:`CpuDropout`; returns how many."""
    replaced = 0
    for module in model.modules():
        drops = getattr(module, "lora_dropout", None)
        if not isinstance(drops, nn.ModuleDict):
            continue
        for name, drop in drops.items():
            if isinstance(drop, nn.Dropout):
                drops[name] = CpuDropout(drop.p)
                replaced += 1
    return replaced
