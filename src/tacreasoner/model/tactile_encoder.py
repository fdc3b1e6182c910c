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

from tacreasoner.model.appearance import AppearanceEncoder
from tacreasoner.model.encoder_config import TactileEncoderConfig
from tacreasoner.model.temporal import TemporalBranch

__all__ = ["CrossAttentionFusion", "CrossVideoFusion", "DynamicTactileEncoder", "TactileProjector", "VideoSlots"]


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


class CrossVideoFusion(nn.Module):
    """One attention layer over all the videos of one prompt, plus a comparator that says which video the question
    picks, written into every token of the prompt's videos.

    Each video is otherwise encoded alone, and a small LLM reads several videos' tokens as one blurred average
    (``VideoSlots``); yet a linear read-out of the tokens orders two objects far better than the LLM does
    (benchmarks/results/tactile_readout.md). Here the tokens of a prompt's 2..``max_videos`` videos, each with its
    place embedding, and the question vector as one more token, pass one transformer layer. A score per video (its
    tokens along a direction the question picks) gives a distribution over the videos ("which is softer?"),
    trained against the gold pick when the batch has one (``winner``); its expectation over learned per-place
    vectors is added to every token, so the LLM reads the verdict the way it reads one video's feel, by attending
    to all tactile tokens. What the layer adds goes through zero-initialised maps, so single-video prompts and an
    untrained layer leave tokens unchanged. It sits in the projector, so it trains in both stages.
    """

    def __init__(self, hidden: int, heads: int, mlp_ratio: float, max_videos: int, question_dim: int,
                 tokens_per_video: int) -> None:
        super().__init__()
        self.place = nn.Parameter(torch.randn(max_videos, hidden) * 0.02)
        self.verdict = nn.Parameter(torch.zeros(max_videos, hidden))
        self.question = nn.Sequential(nn.LayerNorm(question_dim), nn.Linear(question_dim, hidden))
        self.layer = nn.TransformerEncoderLayer(hidden, heads, dim_feedforward=int(hidden * mlp_ratio), dropout=0.0,
                                                activation="gelu", batch_first=True, norm_first=True)
        self.direction = nn.Sequential(nn.LayerNorm(question_dim), nn.Linear(question_dim, tokens_per_video * hidden))
        self.score_norm = nn.LayerNorm(tokens_per_video * hidden)
        self.out = nn.Linear(hidden, hidden)
        self.out.zero_init = True  # read by the model's _init_weights too
        nn.init.zeros_(self.out.weight)
        nn.init.zeros_(self.out.bias)

    @property
    def max_videos(self) -> int:
        return len(self.place)

    @property
    def question_dim(self) -> int:
        return self.direction[0].normalized_shape[0]

    def forward(self, tokens: torch.Tensor, per_sample: torch.Tensor, question: torch.Tensor | None,
                winner: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor | None]:
        """tokens V×N×H (all prompts' videos in order), per_sample B (videos per prompt), question B×Dq or None,
        winner B (the gold pick's place, −100 where none). Returns the tokens and the comparator's mean
        cross-entropy over the prompts with a pick (None when there is none)."""
        counts = per_sample.tolist()
        if max(counts, default=0) > self.max_videos:
            raise ValueError(f"a prompt holds {max(counts)} videos but the cross-video layer was built for at most "
                             f"{self.max_videos} (encoder.cross_video={self.max_videos})")
        starts = [sum(counts[:i]) for i in range(len(counts))]
        out = tokens.clone()
        n, hidden = tokens.shape[1], tokens.shape[2]
        loss_sum, picks = tokens.new_zeros(()), 0
        for k in sorted({c for c in counts if c >= 2}):  # prompts with the same number of videos go together
            samples = [i for i, c in enumerate(counts) if c == k]
            index = torch.tensor([starts[i] + j for i in samples for j in range(k)], device=tokens.device)
            group = tokens[index].view(len(samples), k, n, hidden) + self.place[:k, None].to(tokens.dtype)
            seq = group.flatten(1, 2)
            asked = question[samples] if question is not None else tokens.new_zeros(len(samples), self.question_dim)
            q = self.question(asked.to(tokens.dtype))  # S×H: what the question asks about, and which way
            seq = torch.cat([q.unsqueeze(1), seq], dim=1)
            mixed = self.layer(seq)[:, -k * n:]
            # each video's score: its tokens along the question's direction (a read-out per attribute and
            # comparative, as the linear read-out in tactile_readout.md, but chosen by the question)
            videos = self.score_norm(tokens[index].view(len(samples), k, n * hidden))
            scores = (videos @ self.direction(asked.to(tokens.dtype)).unsqueeze(-1)).squeeze(-1) / (n * hidden) ** 0.5
            verdict = scores.softmax(-1) @ self.verdict[:k].to(tokens.dtype)  # S×H
            delta = self.out(mixed - seq[:, -k * n:]) + verdict.unsqueeze(1)
            out[index] = tokens[index] + delta.reshape(len(samples) * k, n, hidden)
            if winner is not None:
                gold = winner[samples]
                valid = gold >= 0
                if bool(valid.any()):
                    loss_sum = loss_sum + F.cross_entropy(scores[valid].float(), gold[valid], reduction="sum")
                    picks += int(valid.sum())
        return out, (loss_sum / picks if picks else None)


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
    """E_V = W2·GELU(W1·F_enh + b1) + b2, into the LLM's embedding size (+ :class:`VideoSlots` and
    :class:`CrossVideoFusion` when asked; both train with the projector in Stages I and II)."""

    def __init__(self, in_dim: int, out_dim: int, video_slots: int = 0, cross_video: int = 0,
                 heads: int = 4, mlp_ratio: float = 4.0, question_dim: int = 0, tokens_per_video: int = 1) -> None:
        super().__init__()
        self.cross_video = CrossVideoFusion(in_dim, heads, mlp_ratio, cross_video, question_dim or in_dim,
                                            tokens_per_video) if cross_video else None
        self.linear_1 = nn.Linear(in_dim, out_dim)
        self.act = nn.GELU()
        self.linear_2 = nn.Linear(out_dim, out_dim)
        self.video_slot = VideoSlots(video_slots, out_dim) if video_slots else None

    def forward(self, features: torch.Tensor, slots: torch.Tensor | None = None, per_sample: torch.Tensor | None = None,
                question: torch.Tensor | None = None) -> torch.Tensor:
        """``slots``: each video's place in its own prompt (V; 0 = first), read when the projector has slots;
        ``per_sample`` (videos per prompt, B) and ``question`` (B×Dq), read by the cross-video layer."""
        return self.project(features, slots, per_sample, question)[0]

    def project(self, features: torch.Tensor, slots: torch.Tensor | None = None,
                per_sample: torch.Tensor | None = None, question: torch.Tensor | None = None,
                winner: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor | None]:
        """:meth:`forward` plus the cross-video comparator's loss against ``winner`` (B; None without one)."""
        comparison_loss = None
        if self.cross_video is not None:
            if per_sample is None:
                per_sample = torch.ones(len(features), dtype=torch.long, device=features.device)
            features, comparison_loss = self.cross_video(features, per_sample, question, winner)
        out = self.linear_2(self.act(self.linear_1(features)))
        if self.video_slot is None:
            return out, comparison_loss
        if slots is None:
            slots = torch.zeros(len(features), dtype=torch.long, device=features.device)
        return self.video_slot(out, slots), comparison_loss


class DynamicTactileEncoder(nn.Module):
    """pixel_values V×T×3×H×W → V×tokens_per_video×hidden_size; see the module docstring."""

    def __init__(self, config: TactileEncoderConfig, question_dim: int) -> None:
        super().__init__()
        self.config = config
        self.appearance = AppearanceEncoder(config)
        if config.use_temporal:
            self.temporal = TemporalBranch(config, question_dim)
            self.fusion = CrossAttentionFusion(config.hidden_size, config.fusion_heads, config.mlp_ratio)
        else:
            self.temporal = None
            self.fusion = None
        self.sensor_embed = nn.Embedding(len(config.sensor_types), config.hidden_size) \
            if config.sensor_embedding else None

    @property
    def hidden_size(self) -> int:
        return self.config.hidden_size

    def appearance_tokens(self, pixel_values: torch.Tensor) -> torch.Tensor:
        """F_app: CLS plus ``tokens_per_video − 1`` patch tokens average-pooled in t-h-w order."""
        trainable = any(p.requires_grad for p in self.appearance.parameters())
        with torch.set_grad_enabled(trainable and torch.is_grad_enabled()):
            tokens = self.appearance(pixel_values)
        n = self.config.tokens_per_video
        if n == 1:
            return tokens[:, :1]
        patches = F.adaptive_avg_pool1d(tokens[:, 1:].transpose(1, 2), n - 1).transpose(1, 2)
        return torch.cat([tokens[:, :1], patches], dim=1)

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
