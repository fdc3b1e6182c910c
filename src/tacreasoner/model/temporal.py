"""Temporal branch: what changes between frames, pooled over time in a way the question can steer.

Frame differences ΔI_t = I_t − I_{t−1} carry the dynamics (how fast the imprint grows, creeps,
shears, recovers) that a single appearance token averages away. A small conv stem turns each ΔI_t
into a token, one transformer layer lets tokens see their neighbours in time, and attention pooling
with ``temporal_tokens`` queries keeps a short sequence F̄_temp. With question conditioning on, the
pooled question embedding is added to every query, so "which is more elastic?" can look at the
release while "is it rough?" looks at the slide.
"""

from __future__ import annotations

import torch
from torch import nn

from tacreasoner.model.encoder_config import TactileEncoderConfig

__all__ = ["QuestionConditionedPooling", "TemporalBranch"]


class DifferenceStem(nn.Module):
    """ΔI (N×3×H×W) → one C-dim token per difference: three strided convs and a global average."""

    def __init__(self, channels: int) -> None:
        super().__init__()
        mid = max(8, channels // 4)
        self.convs = nn.Sequential(
            nn.Conv2d(3, mid, kernel_size=4, stride=4), nn.GELU(),
            nn.Conv2d(mid, channels // 2, kernel_size=3, stride=2, padding=1), nn.GELU(),
            nn.Conv2d(channels // 2, channels, kernel_size=3, stride=2, padding=1),
        )

    def forward(self, diffs: torch.Tensor) -> torch.Tensor:
        return self.convs(diffs).mean(dim=(-2, -1))


class QuestionConditionedPooling(nn.Module):
    """Attention pooling over time with K learned queries, shifted by the projected question vector."""

    def __init__(self, channels: int, num_queries: int, num_heads: int, question_dim: int, conditioned: bool) -> None:
        super().__init__()
        self.conditioned = conditioned
        self.queries = nn.Parameter(torch.randn(num_queries, channels) * 0.02)
        self.question_proj = nn.Sequential(nn.LayerNorm(question_dim), nn.Linear(question_dim, channels)) \
            if conditioned else None
        self.norm = nn.LayerNorm(channels)
        self.attn = nn.MultiheadAttention(channels, num_heads, batch_first=True)

    def forward(self, tokens: torch.Tensor, question: torch.Tensor | None) -> torch.Tensor:
        queries = self.queries.unsqueeze(0).expand(tokens.shape[0], -1, -1)
        if self.question_proj is not None:
            if question is None:
                raise ValueError("question conditioning is on but no question embedding was given "
                                 "(pass question_embeds, or build the encoder with question_conditioning=False)")
            queries = queries + self.question_proj(question.to(queries.dtype)).unsqueeze(1)
        keys = self.norm(tokens)
        pooled, _ = self.attn(queries, keys, keys, need_weights=False)
        return pooled


class TemporalBranch(nn.Module):
    """pixel_values V×T×3×H×W (+ question V×Dq) → F̄_temp V×temporal_tokens×hidden_size (appearance width)."""

    def __init__(self, config: TactileEncoderConfig, question_dim: int) -> None:
        super().__init__()
        c = config.temporal_hidden_size
        heads = _heads_for(c, config.fusion_heads)
        self.stem = DifferenceStem(c)
        self.normalise = config.temporal_norm
        self.time_embed = nn.Parameter(torch.zeros(config.num_frames - 1, c))
        nn.init.normal_(self.time_embed, std=0.02)
        self.context = nn.TransformerEncoderLayer(c, heads, dim_feedforward=2 * c, dropout=0.0, activation="gelu",
                                                  batch_first=True, norm_first=True)
        self.pool = QuestionConditionedPooling(c, config.temporal_tokens, heads, question_dim,
                                               config.question_conditioning)
        self.out = nn.Linear(c, config.hidden_size)

    def forward(self, pixel_values: torch.Tensor, question: torch.Tensor | None = None) -> torch.Tensor:
        v, t = pixel_values.shape[:2]
        diffs = (pixel_values[:, 1:] - pixel_values[:, :-1]).flatten(0, 1)
        tokens = self.stem(diffs).view(v, t - 1, -1)
        if self.normalise:  # what the change adds to no change, at unit RMS per clip (encoder_config.temporal_norm)
            tokens = tokens - self.stem(torch.zeros_like(diffs[:1]))
            tokens = tokens * torch.rsqrt(tokens.pow(2).mean(dim=(1, 2), keepdim=True) + 1e-12)
        if t - 1 > self.time_embed.shape[0]:
            raise ValueError(f"temporal branch: got {t} frames but was built for at most "
                             f"{self.time_embed.shape[0] + 1}")
        tokens = self.context(tokens + self.time_embed[: t - 1])
        return self.out(self.pool(tokens, question))


def _heads_for(width: int, wanted: int) -> int:
    """The largest head count ≤ wanted that divides width (temporal width may differ from fusion width)."""
    for heads in range(min(wanted, width), 0, -1):
        if width % heads == 0:
            return heads
    return 1
