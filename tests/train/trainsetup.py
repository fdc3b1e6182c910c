"""A tiny but real training setup, built once per test run: benchmark, TouchCoT, and a tiny LLM on disk.

The LLM is a 2-layer Qwen2 with a BPE tokenizer trained on the TouchCoT texts, saved the way
``pretrain-llm`` saves one, so the trainer takes exactly the path it takes with the real tiny LLM or a
Qwen2.5 checkpoint. The appearance ViT is randomly initialised (no ``pretrain-encoder`` run needed).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import torch

from tacreasoner.train.config import TrainConfig
from tests.shared import built_once

ENCODER = {"num_frames": 4, "image_size": [32, 32], "patch_size": 8, "hidden_size": 32, "num_layers": 1,
           "num_heads": 2, "temporal_hidden_size": 32, "temporal_tokens": 2, "fusion_heads": 2, "tokens_per_video": 3}


def training_inputs(dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """{bench, touchcot, llm} built from the run's small simulated dataset ``dataset`` (once per test run, shared
    by the pytest-xdist workers: read-only)."""
    workdir = built_once(tmp_path_factory, "train_inputs", lambda folder: _build_training_inputs(dataset, folder))
    return {"bench": workdir / "bench", "touchcot": workdir / "cot" / "touchcot" / "touchcot_train.jsonl",
            "llm": workdir / "llm"}


def _build_training_inputs(dataset: Path, workdir: Path) -> None:
    from transformers import Qwen2Config, Qwen2ForCausalLM

    from tacreasoner.cot.backends import TeacherConfig
    from tacreasoner.cot.build import build_cot
    from tacreasoner.model.tokenizer import train_tokenizer
    from tacreasoner.tasks.bench import build_bench

    bench = workdir / "bench"
    build_bench("sim", dataset, bench, seed=0, heldout_sensor="digit")
    build_cot(bench, workdir / "cot", TeacherConfig(backend="rules", model="rules-v1"), workers=1)
    touchcot = workdir / "cot" / "touchcot" / "touchcot_train.jsonl"
    texts = [json.loads(line)["question"] + " " + json.loads(line)["output"]
             for line in touchcot.read_text(encoding="utf-8").splitlines()]
    tokenizer = train_tokenizer(texts * 2, vocab_size=700)
    llm = workdir / "llm"
    config = Qwen2Config(vocab_size=len(tokenizer), hidden_size=64, num_hidden_layers=2, num_attention_heads=4,
                         num_key_value_heads=2, intermediate_size=128, max_position_embeddings=1024,
                         tie_word_embeddings=True, eos_token_id=tokenizer.eos_token_id,
                         pad_token_id=tokenizer.pad_token_id)
    import torch

    torch.manual_seed(0)
    Qwen2ForCausalLM(config).save_pretrained(llm)
    tokenizer.save_pretrained(llm)


def tiny_config(inputs: dict[str, Path], output_dir: Path, **sections: Any) -> TrainConfig:
    """A few-step config over ``inputs``; ``sections`` update sections (``stage2={"steps": 6}``) or top-level keys."""
    data: dict[str, Any] = {
        "output_dir": str(output_dir), "seed": 0,
        "model": {"llm": str(inputs["llm"]), "appearance": None, "encoder": dict(ENCODER)},
        "data": {"bench": str(inputs["bench"]), "touchcot": str(inputs["touchcot"]), "max_length": 1024},
        "stage1": {"steps": 3, "batch_size": 4, "lr": 1e-3},
        "stage2": {"steps": 3, "batch_size": 4, "lr": 1e-3, "projector_lr": 1e-3},
        "lora": {"r": 8, "alpha": 16, "dropout": 0.0},
        "runtime": {"log_with": "none", "progress": False, "threads": 1, "log_every": 1, "checkpoint_every": 2,
                    "mixed_precision": "no"},
    }
    for key, value in sections.items():
        if isinstance(value, dict):
            data[key] = {**data.get(key, {}), **value}
        else:
            data[key] = value
    return TrainConfig.from_dict(data)


COMPARATOR_FIT_STEPS = 100
"""AdamW steps of each comparator fit in tests that check where and when the comparator is fitted, not how well it
picks (``cross_video.FIT_STEPS``, 1500 by default; Stage II fits one copy per set of held-out folds, 23 on the tiny
setup, and the kept one; tests/model/test_modeling.py checks the quality of a fit)."""


def fewer_comparator_fit_steps(steps: int = COMPARATOR_FIT_STEPS) -> Callable[[], None]:
    """Make every comparator fit take ``steps`` AdamW steps unless its caller says otherwise; returns the undo."""
    from tacreasoner.model.heads import cross_video

    before = cross_video.FIT_STEPS
    cross_video.FIT_STEPS = steps

    def undo() -> None:
        cross_video.FIT_STEPS = before

    return undo


def llm_with_new_rows(inputs: dict[str, Path], directory: Path, *, untie: bool) -> Path:
    """A tiny LLM whose tokenizer lacks the project's tokens, as a pretrained one (SmolLM2, Qwen2.5) does: building
    the model adds the tactile token and the reasoning tags as new rows, so both stages also train them. ``untie``:
    its output layer a copy of the input embeddings, as Qwen2.5-7B/14B have it; tied (SmolLM2, Qwen2.5 up to 3B),
    one row table serves input and output and must be checkpointed once."""
    import torch
    from tokenizers import Tokenizer, decoders, models, pre_tokenizers, trainers
    from transformers import PreTrainedTokenizerFast, Qwen2Config, Qwen2ForCausalLM

    if not (directory / "config.json").is_file():
        texts = [json.loads(line)["question"] + " " + json.loads(line)["output"]
                 for line in inputs["touchcot"].read_text(encoding="utf-8").splitlines()]
        bpe = Tokenizer(models.BPE())
        bpe.pre_tokenizer = pre_tokenizers.ByteLevel(add_prefix_space=False)
        bpe.decoder = decoders.ByteLevel()
        bpe.train_from_iterator(texts * 2, trainers.BpeTrainer(
            vocab_size=600, special_tokens=["<|endoftext|>", "<|im_start|>", "<|im_end|>"], show_progress=False,
            initial_alphabet=pre_tokenizers.ByteLevel.alphabet()))
        tokenizer = PreTrainedTokenizerFast(tokenizer_object=bpe, eos_token="<|im_end|>", pad_token="<|endoftext|>")
        config = Qwen2Config(vocab_size=len(tokenizer), hidden_size=64, num_hidden_layers=2, num_attention_heads=4,
                             num_key_value_heads=2, intermediate_size=128, max_position_embeddings=1024,
                             tie_word_embeddings=not untie, eos_token_id=tokenizer.eos_token_id,
                             pad_token_id=tokenizer.pad_token_id)
        torch.manual_seed(0)
        Qwen2ForCausalLM(config).save_pretrained(directory)
        tokenizer.save_pretrained(directory)
    return directory


def training_prompt_logits(model: Any, processor: Any, inputs: dict[str, Path]) -> torch.Tensor:
    """A model's logits on the first training prompts (with their videos)."""
    from tacreasoner.train.data import VideoBank, collate, load_examples, tokenize_examples

    examples = load_examples(2, inputs["bench"], stage2_data="plain")[:3]
    tokenized, _ = tokenize_examples(processor, examples, 1024)
    bank = VideoBank(processor.video_config, processor.sensor_types)
    bank.build([k for e in tokenized for k in e.videos])
    batch = collate(processor, tokenized, bank, None)
    batch.pop("labels", None)
    with torch.no_grad():
        return model.eval()(**batch).logits
