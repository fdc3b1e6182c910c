"""LoRA's input dropout, cheaper on the CPU.

``nn.Dropout`` on the CPU draws its mask with ``bernoulli_``, one slow draw per element: in the tiny
default's Stage II it cost more than a tenth of every step (16 adapted projections, 2 CPU cores). Drawing
31-bit integers with ``random_`` and comparing them to a threshold gives the same Bernoulli mask about twice
as fast (benchmarks/results/train_speed.md). Elsewhere (CUDA) the usual kernel is already fast and is used.
"""

from __future__ import annotations

import torch
from torch import nn

__all__ = ["CpuDropout", "use_cpu_dropout"]

_RANGE = 2**31
"""``random_`` on int32 draws uniformly from [0, 2^31)."""


class CpuDropout(nn.Module):
    """Dropout with probability ``round(p·2^31)/2^31`` (``p`` to within 5e-10); kept values are scaled so the
    expectation is unchanged. Draws from torch's default generator, so ``torch.manual_seed`` reproduces it."""

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
