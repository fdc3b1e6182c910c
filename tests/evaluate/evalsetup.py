"""Helper of the evaluation tests: an untrained tiny model saved the way `train` saves one."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import torch

ENCODER = {"num_frames": 4, "image_size": [32, 32], "patch_size": 8, "hidden_size": 32, "num_layers": 1,
           "num_heads": 2, "temporal_hidden_size": 32, "temporal_tokens": 2, "fusion_heads": 2, "tokens_per_video": 3}


def save_untrained_model(texts: Sequence[str], root: Path, vocab_size: int = 500) -> Path:
    """A 2-layer Qwen2 with a BPE tokenizer of ``texts`` behind a random tiny encoder, saved under ``root/model``:
    its answers are noise, what is tested is the path a saved model takes."""
    from transformers import Qwen2Config, Qwen2ForCausalLM

    from tacreasoner.model.build import build_model, save_model
    from tacreasoner.model.tokenizer import train_tokenizer

    tokenizer = train_tokenizer(list(texts), vocab_size=vocab_size)
    config = Qwen2Config(vocab_size=len(tokenizer), hidden_size=64, num_hidden_layers=2, num_attention_heads=4,
                         num_key_value_heads=2, intermediate_size=128, max_position_embeddings=1024,
                         tie_word_embeddings=True, eos_token_id=tokenizer.eos_token_id,
                         pad_token_id=tokenizer.pad_token_id)
    torch.manual_seed(0)
    Qwen2ForCausalLM(config).save_pretrained(root / "llm")
    tokenizer.save_pretrained(root / "llm")
    model, processor = build_model(root / "llm", encoder=ENCODER)
    return save_model(model, processor, root / "model")

