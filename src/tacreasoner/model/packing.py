"""Pack a right-padded training batch into few rows, with the prompt prefix every sample shares computed once.

A training batch of chat prompts is mostly the same system prompt and padding: in the SmolLM2 quickstart a batch
of 8 holds 648 positions for 484 real tokens, 8 × 18 of them the identical "<|im_start|>system … <|im_start|>user"
prefix. On a CPU the step costs what its positions cost, so the LM runs instead on packed rows: one copy of the
shared prefix, then each sample's own tokens, with a block mask (each token sees the prefix and the earlier tokens
of its own sample) and each sample's own position ids. Attention, RoPE and the loss see exactly what they saw in
the padded batch, so the loss and gradients are the same up to float summation order (tests/model/test_packing.py);
358 positions instead of 648 there. Not for generation (no cache) and only for attention that takes a 4D mask
(eager, sdpa).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch.nn.utils.rnn import pad_sequence

__all__ = ["PACKABLE_ATTENTION", "PackedRows", "pack_rows", "shared_prefix_length"]

PACKABLE_ATTENTION = ("eager", "sdpa")
"""Attention implementations that read a custom 4D mask (FlashAttention does not)."""
ROW_TOKENS = 512
"""Tokens per packed row (a longer sample gets a row of its own): attention grows with the square of a row's
length, so rows stay short where padded samples would have been short too."""


@dataclass
class PackedRows:
    """The LM's input for packed rows: R×N embeddings, R×N position ids, an R×1×N×N additive mask, R×N targets
    (−100 where no loss is taken, including the padding of short rows)."""

    inputs_embeds: torch.Tensor
    position_ids: torch.Tensor
    attention_mask: torch.Tensor
    targets: torch.Tensor


def shared_prefix_length(inputs_embeds: torch.Tensor, attention_mask: torch.Tensor, targets: torch.Tensor,
                         shareable: torch.Tensor | None = None) -> int:
    """How many leading positions are real, target-free and identical in every sample (and ``shareable``: e.g.
    not tactile, whose embeddings come from each sample's own clip even where two happen to be equal)."""
    same = (inputs_embeds == inputs_embeds[:1]).all(-1).all(0)
    same &= attention_mask.bool().all(0) & (targets == -100).all(0)
    if shareable is not None:
        same &= shareable.bool().all(0)
    return int(same.long().cumprod(0).sum())


def _segments(lengths: list[int], prefix: int, row_tokens: int) -> list[list[int]]:
    """Samples (by index, in order) per packed row: each row holds the prefix and as many samples' own tokens as
    fit ``row_tokens``."""
    rows: list[list[int]] = []
    used = 0
    for b, n in enumerate(lengths):
        own = n - prefix
        if not rows or used + own > row_tokens:
            rows.append([])
            used = prefix
        rows[-1].append(b)
        used += own
    return rows


def pack_rows(inputs_embeds: torch.Tensor, attention_mask: torch.Tensor, targets: torch.Tensor,
              shareable: torch.Tensor | None = None, row_tokens: int = ROW_TOKENS) -> PackedRows | None:
    """``inputs_embeds`` (B×T×H), its 2D ``attention_mask`` and next-token ``targets`` (B×T, −100 for none) as
    packed rows; None when the batch is not right-padded (each sample's real tokens first), which packing assumes."""
    batch, length = attention_mask.shape
    mask = attention_mask.bool()
    lengths = mask.sum(1)
    right_padded = torch.arange(length, device=mask.device)[None, :] < lengths[:, None]
    if not bool((right_padded == mask).all()):
        return None
    prefix = shared_prefix_length(inputs_embeds, mask, targets, shareable)
    sizes = [int(n) for n in lengths]
    rows = _segments(sizes, prefix, max(row_tokens, max(sizes)))
    flat, positions, segment = [], [], []
    for members in rows:
        index = [torch.arange(prefix)] if prefix else []  # the prefix, from sample 0 (every sample holds it)
        pos, seg = [torch.arange(prefix)], [torch.full((prefix,), -1)]
        for b in members:
            index.append(b * length + torch.arange(prefix, sizes[b]))
            pos.append(torch.arange(prefix, sizes[b]))
            seg.append(torch.full((sizes[b] - prefix,), b))
        flat.append(torch.cat(index))
        positions.append(torch.cat(pos))
        segment.append(torch.cat(seg))
    gather = pad_sequence(flat, batch_first=True)
    pos_ids = pad_sequence(positions, batch_first=True)
    seg_ids = pad_sequence(segment, batch_first=True, padding_value=-2)  # −2: a short row's padding
    real = pad_sequence([torch.ones(len(f), dtype=torch.bool) for f in flat], batch_first=True)
    width = gather.shape[1]
    device = inputs_embeds.device
    gather, pos_ids, seg_ids, real = (t.to(device) for t in (gather, pos_ids, seg_ids, real))
    hidden = inputs_embeds.reshape(batch * length, -1)[gather.reshape(-1)].reshape(len(rows), width, -1)
    packed_targets = targets.reshape(-1)[gather].masked_fill(~real, -100)
    causal = torch.ones(width, width, dtype=torch.bool, device=device).tril()
    sees = (seg_ids[:, None, :] == seg_ids[:, :, None]) | ((seg_ids[:, None, :] == -1) & (seg_ids[:, :, None] != -2))
    allowed = causal & sees
    additive = torch.zeros(allowed.shape, dtype=inputs_embeds.dtype, device=device)
    additive.masked_fill_(~allowed, torch.finfo(inputs_embeds.dtype).min)
    return PackedRows(hidden, pos_ids, additive.unsqueeze(1), packed_targets)
