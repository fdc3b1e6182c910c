"""The tiny Qwen2 config: the documented defaults, overrides, and a model that runs and round-trips on disk."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch

from tacreasoner.model.tiny import TINY_DEFAULTS, tiny_qwen2_config


def test_defaults() -> None:
    config = tiny_qwen2_config(4096)
    assert config.model_type == "qwen2"
    assert (config.hidden_size, config.num_hidden_layers, config.num_attention_heads,
            config.num_key_value_heads) == (256, 4, 4, 2)
    assert config.intermediate_size == TINY_DEFAULTS["intermediate_size"]
    assert config.tie_word_embeddings and config.max_position_embeddings == 2048
    assert config._attn_implementation == "eager"


def test_overrides_and_checks() -> None:
    config = tiny_qwen2_config(500, hidden_size=64, num_hidden_layers=1, eos_token_id=3, attn_implementation="sdpa")
    assert (config.vocab_size, config.hidden_size, config.num_hidden_layers, config.eos_token_id) == (500, 64, 1, 3)
    assert config._attn_implementation == "sdpa"
    with pytest.raises(ValueError, match="divisible by num_attention_heads"):
        tiny_qwen2_config(500, hidden_size=66)
    with pytest.raises(ValueError, match="divisible by num_key_value_heads"):
        tiny_qwen2_config(500, num_key_value_heads=3)
    with pytest.raises(ValueError, match="vocab_size"):
        tiny_qwen2_config(0)


def test_model_runs_and_round_trips(tmp_path: Path) -> None:
    from transformers import AutoModelForCausalLM, Qwen2ForCausalLM

    torch.manual_seed(0)
    model = Qwen2ForCausalLM(tiny_qwen2_config(300, hidden_size=32, num_hidden_layers=1, num_attention_heads=2,
                                               num_key_value_heads=1, intermediate_size=64))
    ids = torch.randint(0, 300, (2, 12))
    loss = model(input_ids=ids, labels=ids).loss
    assert torch.isfinite(loss)
    model.save_pretrained(tmp_path)
    loaded = AutoModelForCausalLM.from_pretrained(tmp_path)
    with torch.no_grad():
        # the reload attends with the library default (sdpa), the new model with eager: the same up to rounding
        assert torch.allclose(model(input_ids=ids).logits, loaded(input_ids=ids).logits, atol=1e-6)
    assert loaded.lm_head.weight.data_ptr() == loaded.model.embed_tokens.weight.data_ptr()
