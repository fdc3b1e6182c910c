"""Each training stage reaches exactly the parameters it should; adapters save apart and merge back."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path
from types import SimpleNamespace

import pytest
import torch

from tacreasoner.model.modeling import TacReasonerForCausalLM
from tacreasoner.model.stages import (
    LoraSettings,
    configure_stage,
    load_adapter,
    merge_adapter,
    no_decay_parameter_names,
    trainable_parameter_names,
)
from tests.model.tinymodel import TACTILE_ID, batch, prompt, tiny_model, videos

NEW_IDS = [296, 297, 298, TACTILE_ID]


def _model() -> TacReasonerForCausalLM:
    model = tiny_model(sensor_embedding=True, video_slots=2, cross_video=2)
    model.config.new_token_ids = NEW_IDS
    torch.nn.init.normal_(model.tactile_encoder.fusion.ffn[-1].weight, std=0.1)  # let gradients flow everywhere
    torch.nn.init.normal_(model.projector.cross_video.out.weight, std=0.1)
    torch.nn.init.normal_(model.projector.cross_video.verdict, std=0.1)
    torch.nn.init.normal_(model.projector.cross_video.directions, std=0.1)
    return model.train()


def _backward(module: torch.nn.Module) -> None:
    inputs = batch([prompt(2), prompt(1, question=[296, 11])])
    labels = inputs["input_ids"].masked_fill(inputs["input_ids"] == TACTILE_ID, -100)
    module(**inputs, pixel_values=videos(3), sensor_ids=torch.tensor([1, 2, 0]), labels=labels).loss.backward()


def _with_grad(module: torch.nn.Module) -> set[str]:
    return {n for n, p in module.named_parameters() if p.grad is not None and p.grad.abs().sum() > 0}


def test_stage_one_trains_temporal_fusion_projector_and_new_token_rows_only() -> None:
    model = _model()
    trained = configure_stage(model, 1)
    assert trained is model
    _backward(model)
    got = _with_grad(model)
    prefixes = ("tactile_encoder.temporal.", "tactile_encoder.fusion.", "tactile_encoder.sensor_embed.", "projector.")
    rows = "language_model.model.embed_tokens.rows"  # tied LLM: one row table for input and output
    assert got - {rows} and all(n.startswith(prefixes) for n in got - {rows})
    # the comparator's heads choose a direction discretely: only their own losses reach them (fitted in Stage II)
    heads = ("projector.cross_video.attribute.", "projector.cross_video.comparative.")
    # the name matcher and its verdicts act only on prompts listing named options, once fitted (Stage II)
    heads += ("projector.cross_video.names.", "projector.cross_video.assignments", "projector.option_marks")
    expected = {n for n, _ in model.named_parameters() if n.startswith(prefixes) and not n.startswith(heads)}
    assert expected - got == set(), f"never reached: {sorted(expected - got)}"
    assert not any(n.startswith(heads) for n in got)
    assert {"projector.video_slot.shift", "projector.video_slot.mix", "projector.cross_video.out.weight"} <= got
    assert not any(n.startswith("tactile_encoder.appearance.") for n in got)
    assert rows in got and model.get_input_embeddings().weight.grad is None  # the matrix itself stays frozen
    assert tuple(model.get_input_embeddings().rows.shape) == (len(NEW_IDS), model.config.text_hidden_size)
    assert rows in no_decay_parameter_names(model)


def test_stage_two_trains_projector_lora_and_new_token_rows_only() -> None:
    model = _model()
    peft_model = configure_stage(model, 2, LoraSettings(r=4, alpha=8))
    names = trainable_parameter_names(peft_model)
    rows = "base_model.model.language_model.model.embed_tokens.rows"
    assert names and all("lora_" in n or "projector" in n or n == rows for n in names)
    # the LM's output layer is tied to its input embeddings: the new rows must reach it as well (one shared table)
    language_model = peft_model.base_model.model.language_model
    assert language_model.lm_head.rows is language_model.get_input_embeddings().rows
    assert language_model.get_input_embeddings().weight.requires_grad is False
    assert {"q_proj", "k_proj", "v_proj", "o_proj"} <= {n.split(".")[-4] for n in names if "lora_A" in n}
    # LoRA B starts at zero, so give it a value to let gradients reach A as well
    for n, p in peft_model.named_parameters():
        if "lora_B" in n:
            torch.nn.init.normal_(p, std=0.01)
    _backward(peft_model)
    got = _with_grad(peft_model)
    heads = ("cross_video.attribute.", "cross_video.comparative.")  # reached by their own losses only (fitted)
    heads += ("cross_video.names.", "cross_video.assignments", "option_marks")  # only where options are matched
    assert got == {n for n in names if not any(h in n for h in heads)}, f"missing {set(names) - got}"
    assert any("projector.modules_to_save.default.video_slot" in n for n in got)
    assert any("projector.modules_to_save.default.cross_video" in n for n in got)
    assert not any("tactile_encoder" in n for n in got)


@pytest.mark.parametrize("tied", [True, False])
def test_stage_one_row_tables_change_no_output_hold_no_vocabulary_state_and_merge_back(tied: bool) -> None:
    """Wrapping changes nothing; an optimizer step moves only the new rows; the saved model is a plain LLM with the
    trained rows written in, answering as the wrapped one did."""
    from tacreasoner.model.token_rows import TokenRows, merge_token_rows

    model = tiny_model(text={"tie_word_embeddings": tied})
    model.config.new_token_ids = NEW_IDS
    inputs = batch([prompt(2), prompt(1, question=[296, 11])])
    labels = inputs["input_ids"].masked_fill(inputs["input_ids"] == TACTILE_ID, -100)
    pixels = videos(3)
    model.eval()
    with torch.no_grad():
        before = model(**inputs, pixel_values=pixels).logits
    embed_before = model.get_input_embeddings().weight.detach().clone()
    head_before = model.get_output_embeddings().weight.detach().clone()
    trained = configure_stage(model, 1)
    assert isinstance(trained.get_input_embeddings(), TokenRows)
    with torch.no_grad():
        wrapped = trained(**inputs, pixel_values=pixels).logits
    kept = [i for i in range(wrapped.shape[-1]) if i not in NEW_IDS]
    assert torch.equal(wrapped[..., kept], before[..., kept])
    # the new ids' logits come from a separate small matmul over their rows, whose summation order the BLAS may
    # choose differently from the full head's (1.2e-7 apart on an AVX512_BF16 AMD EPYC): equal up to rounding
    torch.testing.assert_close(wrapped[..., NEW_IDS], before[..., NEW_IDS], atol=1e-6, rtol=0)
    vocab = model.config.text_config.vocab_size
    params = [p for p in trained.parameters() if p.requires_grad]
    assert not any(p.shape[0] == vocab for p in params)  # nothing vocabulary-sized trains
    optimizer = torch.optim.AdamW(params, lr=0.05, weight_decay=0.0)
    trained.train()
    trained(**inputs, pixel_values=pixels, labels=labels).loss.backward()
    optimizer.step()
    assert not any(v.shape[0] == vocab for state in optimizer.state.values() for v in state.values()
                   if torch.is_tensor(v) and v.ndim)
    row_tables = {id(m.rows): m.rows for m in trained.modules() if isinstance(m, TokenRows)}
    assert len(row_tables) == (1 if tied else 2)
    trained.eval()
    with torch.no_grad():
        after = trained(**inputs, pixel_values=pixels).logits
    assert not torch.allclose(after, before)
    assert merge_token_rows(trained.language_model)
    assert not isinstance(trained.get_input_embeddings(), TokenRows)
    embed, head = trained.get_input_embeddings().weight, trained.get_output_embeddings().weight
    assert (embed is head) == tied
    others = [i for i in range(vocab) if i not in NEW_IDS]
    assert torch.equal(embed[others], embed_before[others]) and torch.equal(head[others], head_before[others])
    assert not torch.equal(embed[NEW_IDS], embed_before[NEW_IDS])
    with torch.no_grad():
        torch.testing.assert_close(trained(**inputs, pixel_values=pixels).logits, after)


def test_unknown_stage_and_bad_lora_settings_are_clear_errors() -> None:
    with pytest.raises(ValueError, match="stage must be one of"):
        configure_stage(_model(), 3)
    with pytest.raises(ValueError, match="lora: unknown keys"):
        LoraSettings.from_dict({"rank": 8})
    with pytest.raises(ValueError, match="r must be"):
        LoraSettings(r=0)


def test_wrapping_and_loading_with_peft_shows_users_no_library_deprecation_warnings(tmp_path) -> None:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        peft_model = configure_stage(_model(), 2, LoraSettings(r=4, alpha=8))
        peft_model.save_pretrained(tmp_path / "adapter")
        load_adapter(_model(), tmp_path / "adapter")
    assert not [w for w in caught if "is_gradient_checkpointing" in str(w.message)]


def test_adapter_saves_apart_and_merging_keeps_the_outputs(tmp_path) -> None:
    base = _model().eval()
    base.save_pretrained(tmp_path / "base")
    peft_model = configure_stage(base, 2, LoraSettings(r=4, alpha=8, dropout=0.0))
    with torch.no_grad():
        for _n, p in peft_model.named_parameters():
            if p.requires_grad:
                p.add_(torch.randn_like(p) * 0.05)
    from tacreasoner.model.build import save_model

    processor = SimpleNamespace(save_pretrained=lambda directory: None)  # only the weights matter here
    save_model(peft_model, processor, tmp_path / "adapter")
    files = {p.name for p in (tmp_path / "adapter").iterdir()}
    assert {"adapter_config.json", "adapter_model.safetensors", "token_rows.safetensors"} <= files
    inputs = batch([prompt(2)])
    pv = videos(2)
    peft_model.eval()
    with torch.no_grad():
        expected = peft_model(**inputs, pixel_values=pv).logits
    reloaded = load_adapter(TacReasonerForCausalLM.from_pretrained(tmp_path / "base").eval(), tmp_path / "adapter")
    merged = merge_adapter(TacReasonerForCausalLM.from_pretrained(tmp_path / "base").eval(), tmp_path / "adapter")
    assert type(merged) is TacReasonerForCausalLM
    merged.save_pretrained(tmp_path / "merged")
    again = TacReasonerForCausalLM.from_pretrained(tmp_path / "merged").eval()
    with torch.no_grad():
        assert torch.allclose(reloaded(**inputs, pixel_values=pv).logits, expected, atol=1e-5)
        assert torch.allclose(again(**inputs, pixel_values=pv).logits, expected, atol=1e-4)
    with pytest.raises(FileNotFoundError, match=r"adapter_config\.json"):
        load_adapter(again, tmp_path / "nothing")


def test_merge_adapter_command(tmp_path) -> None:
    from typer.testing import CliRunner

    from tacreasoner.cli import app
    from tacreasoner.model.build import load_model, save_model
    from tacreasoner.model.configuration import TacReasonerConfig
    from tacreasoner.model.processing import TacReasonerProcessor
    from tacreasoner.model.tokenizer import train_tokenizer
    from tests.model.test_processing import ENCODER, TEXTS
    from tests.model.tinymodel import TEXT_CONFIG

    processor = TacReasonerProcessor.for_encoder(train_tokenizer(TEXTS, vocab_size=400), ENCODER)
    config = TacReasonerConfig(text_config={**TEXT_CONFIG, "vocab_size": len(processor.tokenizer)},
                               encoder=ENCODER.to_dict(), tactile_token_id=processor.tactile_token_id)
    base = TacReasonerForCausalLM(config).eval()
    save_model(base, processor, tmp_path / "base")
    peft_model = configure_stage(base, 2, LoraSettings(r=4, alpha=8, dropout=0.0))
    with torch.no_grad():
        for _, p in peft_model.named_parameters():
            if p.requires_grad:
                p.add_(torch.randn_like(p) * 0.05)
    peft_model.save_pretrained(tmp_path / "adapter")
    runner = CliRunner()
    done = runner.invoke(app, ["merge-adapter", str(tmp_path / "base"), str(tmp_path / "adapter"),
                               "--out", str(tmp_path / "merged")])
    assert done.exit_code == 0, done.output
    merged, proc = load_model(tmp_path / "merged")
    inputs = proc.prompt("Is <tactile> hard?", [torch.zeros(6, 24, 32, 3, dtype=torch.uint8).numpy()])
    with torch.no_grad():
        assert torch.allclose(merged.eval()(**inputs).logits, peft_model.eval()(**inputs).logits, atol=1e-4)
    bad = runner.invoke(app, ["merge-adapter", str(tmp_path / "base"), str(tmp_path / "nowhere"),
                              "--out", str(tmp_path / "m2")])
    assert bad.exit_code == 2 and "adapter_config.json" in bad.output


def test_the_clip_reader_trains_in_stage_two_only() -> None:
    model = tiny_model(clip_reader=True)
    configure_stage(model, 1)
    assert not model.projector.clip_reader.readings.requires_grad  # unfitted in Stage I: nothing to learn
    assert model.projector.linear_1.weight.requires_grad
    trained = configure_stage(model, 2, LoraSettings(r=4, alpha=8, dropout=0.0))
    names = trainable_parameter_names(trained)
    assert any("clip_reader.readings" in n for n in names)
    assert not any("readout" in n for n in names)  # the read-out is a fitted buffer


FSDP2_CASES = (("untied", 2), ("tied", 2), ("tied", 1), ("untied", 1))

FSDP2_PREPARE = """
import sys, types
import torch.distributed as dist
dist.init_process_group("gloo", rank=0, world_size=1)
from accelerate.utils import FullyShardedDataParallelPlugin
from accelerate.utils.fsdp_utils import fsdp2_prepare_model
from torch.distributed.fsdp import FSDPModule
from tacreasoner.model.stages import LoraSettings, configure_stage
from tests.model.tinymodel import TACTILE_ID, batch, prompt, tiny_model, videos
for case in sys.argv[1:]:  # "tied:2": a fresh model per case, one process for all (imports cost the most)
    embeddings, stage = case.split(":")
    model = tiny_model(text={"tie_word_embeddings": embeddings == "tied"})
    model.config.new_token_ids = [296, 297]
    trained = configure_stage(model, int(stage), LoraSettings(r=4, alpha=8))
    plugin = FullyShardedDataParallelPlugin(fsdp_version=2, auto_wrap_policy="transformer_based_wrap",
                                            transformer_cls_names_to_wrap=["Qwen2DecoderLayer"])
    acc = types.SimpleNamespace(state=types.SimpleNamespace(fsdp_plugin=plugin), torch_device_mesh=None,
                                device="cpu", is_main_process=True, mixed_precision="no")
    sharded = fsdp2_prepare_model(acc, trained)
    inputs = batch([prompt(2), prompt(1, question=[296, 11])])
    labels = inputs["input_ids"].masked_fill(inputs["input_ids"] == TACTILE_ID, -100)
    sharded(**inputs, pixel_values=videos(3), labels=labels).loss.backward()
    rows = [p.grad is not None for n, p in sharded.named_parameters() if n.endswith(".rows")]
    print(case, "sharded" if isinstance(sharded, FSDPModule) and rows and all(rows) else "not sharded", flush=True)
"""


def test_accelerate_fsdp2_shards_and_backpropagates_both_stages_tied_or_not(tmp_path, free_port) -> None:
    """The new tokens' rows are plain parameters in both stages (model/token_rows.py), so accelerate's FSDP2 shards
    them and reaches them, tied or not. (Until 2026-11-28 Stage II used PEFT's trainable tokens, whose delta shared
    by tied embeddings accelerate 1.15 sharded twice: "Invariant encountered"; the trainer refused that case.)
    The four cases run in one process, each on a fresh model."""
    env = {**os.environ, "MASTER_ADDR": "127.0.0.1", "MASTER_PORT": str(free_port()),
           "PYTHONPATH": os.pathsep.join([str(Path(__file__).parents[2]), os.environ.get("PYTHONPATH", "")])}
    cases = [f"{embeddings}:{stage}" for embeddings, stage in FSDP2_CASES]
    done = subprocess.run([sys.executable, "-c", FSDP2_PREPARE, *cases], capture_output=True, text=True,
                          env=env, cwd=tmp_path, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip().splitlines()[-len(cases):] == [f"{case} sharded" for case in cases], (
        done.stdout[-2000:], done.stderr[-2000:])
