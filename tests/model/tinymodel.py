"""Tiny TacReasoner models for tests: a 2-layer Qwen2 and a 2-layer appearance ViT, built in milliseconds."""

from __future__ import annotations

from typing import Any

import torch

from tacreasoner.model.configuration import TacReasonerConfig
from tacreasoner.model.modeling import TacReasonerForCausalLM

VOCAB = 300
TACTILE_ID = 299
TEXT_CONFIG = dict(model_type="qwen2", hidden_size=64, num_hidden_layers=2, num_attention_heads=4,
                   num_key_value_heads=2, intermediate_size=128, vocab_size=VOCAB, tie_word_embeddings=True,
                   max_position_embeddings=512)
ENCODER = dict(num_frames=4, image_size=[32, 32], patch_size=8, hidden_size=32, num_layers=2, num_heads=2,
               temporal_hidden_size=32, temporal_tokens=2, fusion_heads=2, tokens_per_video=3)


def tiny_model(seed: int = 0, text: dict[str, Any] | None = None, **encoder: Any) -> TacReasonerForCausalLM:
    from tacreasoner.train.head_settings import with_head_settings

    torch.manual_seed(seed)
    encoder = with_head_settings({**ENCODER, **encoder})
    config = TacReasonerConfig(text_config={**TEXT_CONFIG, **(text or {})}, encoder=encoder,
                               tactile_token_id=TACTILE_ID)
    return TacReasonerForCausalLM(config).eval()


def videos(n: int, seed: int = 0, **encoder: Any) -> torch.Tensor:
    cfg = {**ENCODER, **encoder}
    g = torch.Generator().manual_seed(seed)
    return torch.randn(n, cfg["num_frames"], 3, *cfg["image_size"], generator=g)


def prompt(n_videos: int, tokens_per_video: int = ENCODER["tokens_per_video"], question: list[int] | None = None,
           ) -> list[int]:
    """[question tokens] then one placeholder run per video, then a few answer tokens."""
    ids = list(question or [11, 12, 13])
    for i in range(n_videos):
        ids += [TACTILE_ID] * tokens_per_video + [20 + i]
    return [*ids, 30, 31]


def batch(prompts: list[list[int]]) -> dict[str, torch.Tensor]:
    width = max(len(p) for p in prompts)
    ids = torch.zeros(len(prompts), width, dtype=torch.long)
    mask = torch.zeros_like(ids)
    for i, p in enumerate(prompts):
        ids[i, : len(p)] = torch.tensor(p)
        mask[i, : len(p)] = 1
    return {"input_ids": ids, "attention_mask": mask}
