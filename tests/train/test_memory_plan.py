"""`tacreasoner memory-plan`: counts from the meta-device model, sharding per engine, activations, the CLI."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
import torch
import yaml
from typer.testing import CliRunner

from tacreasoner.cli import app
from tacreasoner.model.stages import LoraSettings
from tacreasoner.train.config import StageSettings, TrainConfig
from tacreasoner.train.memory_plan import (
    GB,
    ModelShapes,
    count_model,
    layer_bytes_per_token,
    plan_for_config,
    plan_memory,
    render_plans,
    resolve_llm,
)

CONFIGS = Path(__file__).resolve().parents[2] / "configs"
runner = CliRunner()
TINY = {"hidden_size": 64, "intermediate_size": 160, "num_hidden_layers": 2, "num_attention_heads": 4,
        "num_key_value_heads": 2, "vocab_size": 512}


@pytest.fixture(scope="module")
def qwen7b() -> ModelShapes:
    name, config = resolve_llm("Qwen/Qwen2.5-7B-Instruct")
    return count_model(config, stage=2, lora=LoraSettings(), name=name)


@pytest.fixture
def tiny_llm(tmp_path: Path) -> Path:
    """A local model directory holding only config.json (a Llama, to show the count is not Qwen-specific)."""
    from transformers import LlamaConfig

    LlamaConfig(**TINY).save_pretrained(tmp_path / "llm")
    return tmp_path / "llm"


def test_qwen25_7b_shapes_count_the_published_size(qwen7b: ModelShapes) -> None:
    assert qwen7b.name == "Qwen2.5-7B"
    assert qwen7b.llm_parameters == pytest.approx(7.61e9, rel=0.01)  # the model card: 7.61 B
    assert qwen7b.vocab_rows == 152064 and not qwen7b.tied_embeddings
    parts = dict(qwen7b.trainable_parts)
    # LoRA r 128 on q/k/v/o: r·(in + out) per projection, 28 layers (k and v map 3584 → 4 KV heads × 128)
    assert parts["LoRA r 128 on q_proj/k_proj/v_proj/o_proj"] == 28 * 128 * (2 * (3584 + 3584) + 2 * (3584 + 512))
    assert parts["new token rows"] == 2 * 5 * 3584  # untied: input and output rows, as in Stage I (since 2026-11-28)
    assert qwen7b.weight_dtype == "bfloat16"
    assert qwen7b.frozen_bytes == pytest.approx(2 * (qwen7b.parameters - qwen7b.trainable), rel=1e-3)


def test_stage_one_trains_the_new_token_rows_not_the_embedding_matrices() -> None:
    from transformers import Qwen2Config

    shapes = count_model(Qwen2Config(**TINY), stage=1, dtype="float32")
    parts = dict(shapes.trainable_parts)
    assert parts["new token rows"] == 2 * 5 * 64  # untied: input and output rows of the 5 added tokens
    assert "embeddings" not in parts
    assert "projector" in parts and "tactile encoder" in parts
    assert not any(part.startswith("LoRA") for part in parts)
    assert shapes.optimizer_bytes == 8 * shapes.trainable  # fp32 weights: two moments, no master copy


def test_sharding_divides_the_right_terms(qwen7b: ModelShapes) -> None:
    one = plan_memory(qwen7b, engine="ddp", world_size=1)
    ddp = plan_memory(qwen7b, engine="ddp", world_size=8)
    zero2 = plan_memory(qwen7b, engine="deepspeed-zero2", world_size=8)
    zero3 = plan_memory(qwen7b, engine="deepspeed-zero3", world_size=8)
    fsdp = plan_memory(qwen7b, engine="fsdp", world_size=8)
    weights = ("frozen_weights", "trainable_weights")
    states = ("gradients", "optimizer")
    for term in (*weights, *states, "activations"):
        assert getattr(ddp, term) == getattr(one, term), term  # DDP replicates everything
    for term in states:
        assert getattr(zero2, term) == pytest.approx(getattr(one, term) / 8), term
        assert getattr(zero3, term) == pytest.approx(getattr(one, term) / 8), term
    for term in weights:
        assert getattr(zero2, term) == getattr(one, term), term  # ZeRO-2 keeps whole weights
        assert getattr(zero3, term) == pytest.approx(getattr(one, term) / 8), term
    for term in (*weights, *states, "gathered"):
        assert getattr(fsdp, term) == getattr(zero3, term), term
    assert zero3.gathered > 0 and zero2.gathered == ddp.gathered == 0
    assert plan_memory(qwen7b, engine="fsdp", world_size=1).gathered == 0  # one GPU: nothing is sharded
    assert zero3.activations == zero2.activations == one.activations  # per GPU, never sharded
    assert zero3.total < zero2.total < ddp.total


def test_activations_follow_the_batch_length_and_checkpointing(qwen7b: ModelShapes) -> None:
    base = plan_memory(qwen7b, batch_size=4, max_length=512)
    assert plan_memory(qwen7b, batch_size=8, max_length=512).activations == pytest.approx(2 * base.activations)
    off = plan_memory(qwen7b, batch_size=4, max_length=512, gradient_checkpointing=False)
    assert off.layer_activations > 10 * base.layer_activations
    assert off.loss_activations == base.loss_activations
    half = plan_memory(qwen7b, batch_size=4, max_length=512, answer_fraction=0.5)
    assert half.loss_activations == pytest.approx(base.loss_activations / 2)
    with pytest.raises(ValueError, match="engine 'zero9' is not one of"):
        plan_memory(qwen7b, engine="zero9")
    with pytest.raises(ValueError, match="world size must be"):
        plan_memory(qwen7b, world_size=0)


def _saved_bytes_per_token(checkpointing: bool, attention: str) -> float:
    """What autograd keeps from a forward of a small bf16 Qwen2 decoder (weights aside), per token."""
    from transformers import AutoModelForCausalLM, Qwen2Config

    torch.manual_seed(0)
    config = Qwen2Config(**{**TINY, "hidden_size": 256, "intermediate_size": 704, "num_attention_heads": 8},
                         attn_implementation=attention)
    model = AutoModelForCausalLM.from_config(config).to(torch.bfloat16).requires_grad_(False).train()
    if checkpointing:  # as the trainer does, under transformers' new name where it has one
        enable = getattr(model, "activation_checkpointing_enable", None)
        if enable is not None:
            enable(activation_checkpointing_kwargs={"use_reentrant": False})
        else:
            model.gradient_checkpointing_enable(gradient_checkpointing_kwargs={"use_reentrant": False})
    weights = {p.data_ptr() for p in model.parameters()}
    saved: dict[int, int] = {}

    def pack(t: torch.Tensor) -> torch.Tensor:
        if t.data_ptr() not in weights:
            saved[t.untyped_storage().data_ptr()] = t.untyped_storage().nbytes()
        return t

    embeds = torch.randn(2, 128, 256, dtype=torch.bfloat16, requires_grad=True)
    with torch.autograd.graph.saved_tensors_hooks(pack, lambda t: t), torch.autocast("cpu", dtype=torch.bfloat16):
        model.get_decoder()(inputs_embeds=embeds, use_cache=False)
    return sum(saved.values()) / embeds.shape[:2].numel()


@pytest.mark.parametrize("attention", ["sdpa", "eager"])
def test_the_activation_formula_bounds_what_autograd_saves(attention: str) -> None:
    from transformers import Qwen2Config

    shapes = count_model(Qwen2Config(**{**TINY, "hidden_size": 256, "intermediate_size": 704,
                                        "num_attention_heads": 8}), stage=1)
    per_layer = layer_bytes_per_token(shapes, attention=attention, max_length=128)
    formula = shapes.layers * per_layer + 4 * shapes.hidden_size  # checkpointing off, per token
    assert 0.85 <= _saved_bytes_per_token(False, attention) / formula <= 1.0
    # checkpointing on: the layers' inputs and the final norm's fp32 input (the re-run layer comes in backward)
    kept = 2 * shapes.hidden_size * shapes.layers + 4 * shapes.hidden_size
    assert _saved_bytes_per_token(True, attention) == pytest.approx(kept, rel=0.05)


def _config(llm: Path, **stage2: int) -> TrainConfig:
    if "global_batch" in {f.name for f in dataclasses.fields(StageSettings)}:
        stage2 = {"global_batch": 8, "grad_accum": 1, **stage2}
    return TrainConfig.from_dict({"model": {"llm": str(llm), "gradient_checkpointing": True},
                                  "data": {"max_length": 256}, "stage2": {"batch_size": 8, **stage2},
                                  "lora": {"r": 8, "target_modules": ["q_proj", "v_proj"]}})


def test_a_local_config_json_directory_plans_with_the_configs_settings(tiny_llm: Path) -> None:
    from transformers import AutoModelForCausalLM, LlamaConfig

    plans = plan_for_config(_config(tiny_llm), stage=2, engine="deepspeed-zero3", world_sizes=[1, 2])
    shapes = plans[0].shapes
    assert shapes.name == "llm"
    assert shapes.llm_parameters == sum(p.numel() for p in AutoModelForCausalLM.from_config(LlamaConfig(**TINY))
                                        .parameters())
    assert dict(shapes.trainable_parts)["LoRA r 8 on q_proj/v_proj"] == 2 * 8 * ((64 + 64) + (64 + 32))
    assert [p.world_size for p in plans] == [1, 2]
    assert plans[0].max_length == 256 and plans[0].gradient_checkpointing
    assert plans[1].frozen_weights == pytest.approx(plans[0].frozen_weights / 2)
    assert plans[0].fits
    text = render_plans(plans)
    assert "deepspeed-zero3 × 2" in text and "fits 80 GB?" in text and "**total**" in text


def test_what_the_trainer_refuses_is_noted(tmp_path: Path) -> None:
    from transformers import Qwen2Config

    Qwen2Config(**TINY, tie_word_embeddings=True).save_pretrained(tmp_path / "tied")
    config = _config(tmp_path / "tied")
    (stage2,) = plan_for_config(config, stage=2, engine="fsdp", world_sizes=[2])
    assert stage2.shapes.tied_embeddings
    assert any("refuses FSDP in Stage II of a tied-embedding LLM" in note for note in stage2.notes)
    (stage1,) = plan_for_config(config, stage=1, engine="fsdp", world_sizes=[1])
    assert not any("refuses" in note for note in stage1.notes)  # Stage I's rows are plain parameters
    (zero3,) = plan_for_config(config, stage=2, engine="deepspeed-zero3", world_sizes=[2])
    assert any("refuses DeepSpeed ZeRO-3" in note for note in zero3.notes)


def test_an_unknown_llm_asks_for_llm() -> None:
    with pytest.raises(ValueError, match="pass --llm"):
        resolve_llm("someone/Unknown-70B")


def test_a_plan_over_the_gpu_says_no(qwen7b: ModelShapes) -> None:
    plan = plan_memory(qwen7b, gpu_gb=16)
    assert not plan.fits and plan.total > 16 * GB
    assert "| no (" in render_plans([plan])


def _write_config(tmp_path: Path, llm: Path) -> Path:
    data = _config(llm).to_dict()
    path = tmp_path / "plan.yaml"
    path.write_text(yaml.safe_dump({k: data[k] for k in ("model", "data", "stage2", "lora")}), encoding="utf-8")
    return path


def test_the_cli_prints_a_plan_per_world_size(tmp_path: Path, tiny_llm: Path) -> None:
    result = runner.invoke(app, ["memory-plan", "--config", str(_write_config(tmp_path, tiny_llm)), "--world-size",
                                 "1", "--world-size", "2", "--engine", "fsdp", "--gpu-gb", "40"])
    assert result.exit_code == 0, result.output
    assert "llm, Stage II" in result.output
    assert "fsdp × 1" in result.output and "fsdp × 2" in result.output and "fits 40 GB?" in result.output


@pytest.mark.parametrize(("args", "needle"), [
    (["--engine", "zero9"], "--engine 'zero9' is not one of ddp, fsdp, deepspeed-zero2, deepspeed-zero3"),
    (["--world-size", "0"], "--world-size must be at least 1, got 0"),
    (["--stage", "3"], "--stage must be 1 or 2"),
])
def test_the_cli_rejects_bad_input_in_one_line(args: list[str], needle: str) -> None:
    result = runner.invoke(app, ["memory-plan", "--config", str(CONFIGS / "qwen2.5-7b.yaml"), *args])
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and needle in lines[0], result.stderr
    assert "Traceback" not in result.output
