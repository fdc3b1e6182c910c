"""The dynamic-aware tactile encoder: frozen appearance ViT + temporal branch, fused by cross-attention.

    F_app  = tokens_per_video tokens of the appearance ViT (CLS, then patch tokens pooled in t-h-w order)
    F̄_temp = TemporalBranch(ΔI, question)
    F_attn = CrossAttn(Q = F_app, K = V = F̄_temp)
    F_enh  = FFN(F_attn) + F_app

The FFN's last layer starts at zero, so an untrained fusion hands the appearance tokens through
unchanged and Stage I starts from what the appearance branch already knows.
"""

from __future__ import annotations

import torch
from torch import nn
from torch.nn import functional as F

from tacreasoner.model.appearance import build_appearance
from tacreasoner.model.encoder_config import TactileEncoderConfig
from tacreasoner.model.heads.hook import HeadModules, ReadoutHeads
from tacreasoner.model.temporal import TemporalBranch

__all__ = ["CrossAttentionFusion", "DynamicTactileEncoder", "TactileProjector", "VideoSlots"]


class CrossAttentionFusion(nn.Module):
    def __init__(self, hidden: int, heads: int, mlp_ratio: float) -> None:
        super().__init__()
        self.norm_q = nn.LayerNorm(hidden)
        self.norm_kv = nn.LayerNorm(hidden)
        self.attn = nn.MultiheadAttention(hidden, heads, batch_first=True)
        inner = int(hidden * mlp_ratio)
        self.ffn = nn.Sequential(nn.LayerNorm(hidden), nn.Linear(hidden, inner), nn.GELU(), nn.Linear(inner, hidden))
        self.ffn[-1].zero_init = True  # read by the model's _init_weights too
        self.reset_output()

    def reset_output(self) -> None:
        nn.init.zeros_(self.ffn[-1].weight)
        nn.init.zeros_(self.ffn[-1].bias)

    def forward(self, appearance: torch.Tensor, temporal: torch.Tensor) -> torch.Tensor:
        kv = self.norm_kv(temporal)
        attended, _ = self.attn(self.norm_q(appearance), kv, kv, need_weights=False)
        return self.ffn(attended) + appearance


class VideoSlots(nn.Module):
    """Which video of the prompt (first, second, …) a token belongs to, written into the token itself.

    Video k's tokens become ``x + x·M_k + s_k``. The shift ``s_k`` is a segment embedding (as in BERT). The map
    ``M_k`` lets the average over several videos' tokens keep each video's features apart: a small LLM reads a
    single video by attending to all tactile tokens at once, and with one shared projector that average blurs
    two videos into one middle reading. Both start at zero, so a projector's output is unchanged until they are
    trained. Measured on the quickstart: more sensitive to the videos' order, comparisons still not read
    (docs/training.md, "Where the tiny model stands"); off by default.
    """

    def __init__(self, slots: int, dim: int) -> None:
        super().__init__()
        self.shift = nn.Parameter(torch.zeros(slots, dim))
        self.mix = nn.Parameter(torch.zeros(slots, dim, dim))
        self.zero_init = True  # read by the model's _init_weights too

    @property
    def slots(self) -> int:
        return len(self.shift)

    def forward(self, tokens: torch.Tensor, slots: torch.Tensor) -> torch.Tensor:
        most = int(slots.max()) + 1 if len(slots) else 0
        if most > self.slots:
            raise ValueError(f"a prompt holds {most} videos but this model tells at most "
                             f"{self.slots} apart (encoder.video_slots={self.slots}); ask about fewer videos at once "
                             f"or train with more slots")
        mixed = torch.zeros_like(tokens)
        for k in slots.unique().tolist():
            at = slots == k
            mixed[at] = tokens[at] @ self.mix[k].to(tokens.dtype)
        return tokens + mixed + self.shift[slots].unsqueeze(1).to(tokens.dtype)


class TactileProjector(nn.Module):
    """E_V = W2·GELU(W1·F_enh + b1) + b2, into the LLM's embedding size (+ :class:`VideoSlots` when asked).

    It also holds the optional read-out heads' parts (``heads``, from :func:`tacreasoner.model.heads.build_heads`),
    which train with it; the model calls them through :attr:`heads`, never through the projection."""

    def __init__(self, in_dim: int, out_dim: int, video_slots: int = 0, heads: HeadModules | None = None) -> None:
        super().__init__()
        heads = heads or HeadModules()
        self.cross_video = heads.cross_video
        self.clip_reader = heads.clip_reader
        self.linear_1 = nn.Linear(in_dim, out_dim)
        self.act = nn.GELU()
        self.linear_2 = nn.Linear(out_dim, out_dim)
        self.video_slot = VideoSlots(video_slots, out_dim) if video_slots else None
        self.option_marks = heads.option_marks

    @property
    def heads(self) -> ReadoutHeads:
        """The hook the model calls before (``write``) and after (``mark``) the projection."""
        return ReadoutHeads(self.cross_video, self.clip_reader, self.option_marks)

    def forward(self, features: torch.Tensor, slots: torch.Tensor | None = None) -> torch.Tensor:
        """``slots``: each video's place in its own prompt (V; 0 = first), read when the projector has slots."""
        out = self.linear_2(self.act(self.linear_1(features)))
        if self.video_slot is None:
            return out
        if slots is None:
            slots = torch.zeros(len(features), dtype=torch.long, device=features.device)
        return self.video_slot(out, slots)


class DynamicTactileEncoder(nn.Module):
    """pixel_values V×T×3×H×W → V×tokens_per_video×hidden_size; see the module docstring."""

    def __init__(self, config: TactileEncoderConfig, question_dim: int) -> None:
        super().__init__()
        self.config = config
        self.appearance = build_appearance(config)
        if config.use_temporal:
            self.temporal = TemporalBranch(config, question_dim)
            self.fusion = CrossAttentionFusion(config.hidden_size, config.fusion_heads, config.mlp_ratio)
        else:
            self.temporal = None
            self.fusion = None
        self.sensor_embed = nn.Embedding(len(config.sensor_types), config.hidden_size) \
            if config.sensor_embedding else None
        # per-channel statistics of the training clips' appearance tokens (identity until measured; saved)
        self.register_buffer("appearance_mean", torch.zeros(config.hidden_size))
        self.register_buffer("appearance_std", torch.ones(config.hidden_size))

    @property
    def hidden_size(self) -> int:
        return self.config.hidden_size

    def appearance_tokens(self, pixel_values: torch.Tensor, standardized: bool = True) -> torch.Tensor:
        """F_app: CLS plus ``tokens_per_video − 1`` patch tokens average-pooled in t-h-w order (standardised when
        ``config.standardize_appearance``, unless ``standardized=False``)."""
        trainable = any(p.requires_grad for p in self.appearance.parameters())
        with torch.set_grad_enabled(trainable and torch.is_grad_enabled()):
            tokens = self.appearance(pixel_values)
        n = self.config.tokens_per_video
        if n == 1:
            pooled = tokens[:, :1]
        else:
            patches = F.adaptive_avg_pool1d(tokens[:, 1:].transpose(1, 2), n - 1).transpose(1, 2)
            pooled = torch.cat([tokens[:, :1], patches], dim=1)
        return self.standardize(pooled) if standardized else pooled

    def standardize(self, tokens: torch.Tensor) -> torch.Tensor:
        """``(tokens − mean) / std`` per channel with the measured training statistics (identity before)."""
        if not self.config.standardize_appearance:
            return tokens
        return (tokens - self.appearance_mean.to(tokens.dtype)) / self.appearance_std.to(tokens.dtype)

    @property
    def appearance_measured(self) -> bool:
        """The training statistics were measured (the buffers are no longer the identity they start as)."""
        return bool((self.appearance_mean != 0).any() or (self.appearance_std != 1).any())

    @torch.no_grad()
    def set_appearance_statistics(self, raw_tokens: torch.Tensor) -> None:
        """Measure the per-channel mean and standard deviation of un-standardised appearance tokens (V×N×H)."""
        flat = raw_tokens.reshape(-1, raw_tokens.shape[-1]).double()
        self.appearance_mean.copy_(flat.mean(dim=0).to(self.appearance_mean.dtype))
        self.appearance_std.copy_(flat.std(dim=0).clamp_min(1e-6).to(self.appearance_std.dtype))

    def forward(self, pixel_values: torch.Tensor, question: torch.Tensor | None = None,
                sensor_ids: torch.Tensor | None = None, appearance: torch.Tensor | None = None) -> torch.Tensor:
        """``appearance``: F_app computed earlier by :meth:`appearance_tokens` (the branch is frozen, so a
        trainer may cache it per clip and skip the ViT; the temporal branch still reads ``pixel_values``)."""
        self._check_input(pixel_values)
        if appearance is None:
            features = self.appearance_tokens(pixel_values)
        else:
            expected = (len(pixel_values), self.config.tokens_per_video, self.config.hidden_size)
            if tuple(appearance.shape) != expected:
                raise ValueError(f"appearance tokens must be {'×'.join(map(str, expected))} "
                                 f"(videos×tokens_per_video×hidden), got {tuple(appearance.shape)}")
            features = appearance.to(pixel_values.dtype)
        if self.temporal is not None:
            features = self.fusion(features, self.temporal(pixel_values, question))
        if self.sensor_embed is not None:
            if sensor_ids is None:
                sensor_ids = torch.zeros(len(pixel_values), dtype=torch.long, device=pixel_values.device)
            features = features + self.sensor_embed(sensor_ids).unsqueeze(1)
        return features

    def _check_input(self, pixel_values: torch.Tensor) -> None:
        c = self.config
        expected = (c.num_frames, 3, *c.image_size)
        if pixel_values.ndim != 5 or tuple(pixel_values.shape[1:]) != expected:
            raise ValueError(f"pixel_values must be videos×{'×'.join(map(str, expected))} "
                             f"(frames×channels×height×width from the processor), got {tuple(pixel_values.shape)}")
