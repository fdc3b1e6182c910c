"""The tiny default LLM: a Qwen2-architecture causal LM small enough to train from scratch on 2 CPU cores.

Defaults: hidden 256, 4 layers, 4 query heads of 64 with 2 KV heads (grouped-query attention as in
Qwen2), SwiGLU MLP of 704, tied input/output embeddings; about 3.6 M parameters with the corpus
vocabulary (~2,400 tokens). Why this size (2-core AMD EPYC, measured in this project):

- speed: with bf16 autocast it trains at about 6-7 k tokens/s on one contended core (11-12 k on two
  idle ones), so the default pre-training (320 steps × 16 × 256 tokens, about 1 M real tokens) fits the
  quickstart's three-minute budget. Halving the depth or narrowing to 192 roughly doubles fp32
  throughput; those smaller variants were not tried for quality. This size reaches the knowledge
  target in that budget (``benchmarks/results/llm_knowledge.md``: held-out comparisons and scenario
  choices above chance with the Wilson lower bound);
- fidelity: it is the real Qwen2 architecture, so every code path (chat template, LoRA targets
  ``q_proj``/``k_proj``/``v_proj``/``o_proj``, save/load) is the one a real Qwen2.5 checkpoint takes.
"""

from __future__ import annotations

from typing import Any

__all__ = ["TINY_DEFAULTS", "tiny_qwen2_config"]

TINY_DEFAULTS: dict[str, Any] = {
    "hidden_size": 256,
    "num_hidden_layers": 4,
    "num_attention_heads": 4,
    "num_key_value_heads": 2,
    "intermediate_size": 704,
    "max_position_embeddings": 2048,
    "rope_theta": 10000.0,
    "rms_norm_eps": 1e-6,
    "tie_word_embeddings": True,
    "attention_dropout": 0.0,
    "hidden_act": "silu",
    "initializer_range": 0.02,
    "use_cache": True,
}


def tiny_qwen2_config(vocab_size: int, **overrides: Any) -> Any:
    """A ``transformers.Qwen2Config`` for the tiny LLM; any field can be overridden (e.g. ``eos_token_id``)."""
    from transformers import Qwen2Config

    if vocab_size < 1:
        raise ValueError(f"vocab_size must be >= 1, got {vocab_size}")
    settings = {**TINY_DEFAULTS, **overrides}
    heads, kv = settings["num_attention_heads"], settings["num_key_value_heads"]
    if settings["hidden_size"] % heads:
        raise ValueError(f"hidden_size {settings['hidden_size']} must be divisible by num_attention_heads {heads}")
    if heads % kv:
        raise ValueError(f"num_attention_heads {heads} must be divisible by num_key_value_heads {kv}")
    # plain matmul attention: at this size it pre-trains ~10% faster on the CPU than sdpa
    # (benchmarks/results/train_speed.md); a saved model loads with the library default again
    attn = settings.pop("attn_implementation", "eager")
    config = Qwen2Config(vocab_size=vocab_size, **settings)
    config._attn_implementation = attn
    return config
