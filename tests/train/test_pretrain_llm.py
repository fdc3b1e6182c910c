"""Tiny pre-training runs: loadable output, falling loss, exact resume after an interruption, knowledge eval."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch

from tacreasoner.knowledge import build_corpus
from tacreasoner.model.tokenizer import wording_texts
from tacreasoner.train.pretrain_llm import evaluate_knowledge, pretrain_llm, tokenizer_training_texts

MODEL = {"hidden_size": 32, "num_hidden_layers": 1, "num_attention_heads": 2, "num_key_value_heads": 1,
         "intermediate_size": 64}
CORPUS = {"n_compare": 200, "n_scenario": 100, "n_fact": 50, "n_eval": 4, "n_seen": 2, "fact_passes": 1,
          "need_passes": 1}
RUN = {"batch_size": 4, "seq_len": 128, "lr": 1e-2, "vocab_size": 400, "progress": False, "threads": 1,
       "model_overrides": MODEL, "corpus_options": CORPUS, "checkpoint_every": 5, "log_every": 5, "warmup_steps": 2}


def _log(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "train_log.jsonl").read_text().splitlines()]


@pytest.fixture(scope="module")
def finished(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return pretrain_llm(tmp_path_factory.mktemp("pretrain") / "run", steps=20, **RUN)


def test_output_dir_is_loadable_and_loss_falls(finished: Path) -> None:
    from transformers import AutoModelForCausalLM, AutoTokenizer

    model = AutoModelForCausalLM.from_pretrained(finished)
    tokenizer = AutoTokenizer.from_pretrained(finished)
    assert model.config.eos_token_id == tokenizer.eos_token_id == tokenizer.convert_tokens_to_ids("<|im_end|>")
    assert model.config.vocab_size == len(tokenizer)
    assert model.generation_config.eos_token_id == tokenizer.eos_token_id
    log = _log(finished)
    assert [r["step"] for r in log] == [5, 10, 15, 20]
    assert log[-1]["loss"] < log[0]["loss"] and all(r["tokens_per_s"] > 0 for r in log)
    assert (finished / "checkpoints").is_dir() and (finished / "tokenizer" / "tokenizer.json").is_file()
    info = json.loads((finished / "pretrain.json").read_text())
    assert info["steps_done"] == 20 and info["settings"]["model"] == MODEL


def test_resume_continues_from_the_checkpoint_exactly(finished: Path, tmp_path: Path) -> None:
    from safetensors.torch import load_file

    out = tmp_path / "run"
    pretrain_llm(out, steps=20, stop_after=10, **RUN)  # "killed" after step 10
    assert not (out / "model.safetensors").exists()
    assert sorted(p.name for p in (out / "checkpoints").iterdir()) == ["step-00000005", "step-00000010"]
    with pytest.raises(ValueError, match="already holds a pre-training run"):
        pretrain_llm(out, steps=20, **RUN)
    with pytest.raises(ValueError, match=r"different settings.*lr"):
        pretrain_llm(out, steps=20, resume=True, **{**RUN, "lr": 5e-3})
    pretrain_llm(out, steps=20, resume=True, **RUN)
    assert [r["step"] for r in _log(out)] == [5, 10, 15, 20]
    resumed, straight = load_file(str(out / "model.safetensors")), load_file(str(finished / "model.safetensors"))
    assert resumed.keys() == straight.keys()
    for name in resumed:
        assert torch.equal(resumed[name], straight[name]), name


def test_evaluate_knowledge_reports_per_kind(finished: Path) -> None:
    corpus = build_corpus(seed=0, **CORPUS)
    result = evaluate_knowledge(finished, corpus.eval_questions, max_new_tokens=8)
    assert set(result["kinds"]) == {"compare_yesno", "compare_which", "scenario"}
    for summary in result["kinds"].values():
        assert summary["n"] == 4 and summary["chance"] == 0.5
        lo, hi = summary["ci95"]
        assert 0 <= lo <= summary["accuracy"] <= hi <= 1
    assert len(result["predictions"]) == 12


def test_bad_arguments(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="steps must be at least 1"):
        pretrain_llm(tmp_path, steps=0, **RUN)
    with pytest.raises(FileNotFoundError, match=r"config\.json missing"):
        evaluate_knowledge(tmp_path, build_corpus(seed=0, **CORPUS).eval_questions)


def test_packed_rows_keep_examples_apart() -> None:
    """A packed row gives each example exactly the logits it gets alone (block-diagonal attention)."""
    from transformers import Qwen2ForCausalLM

    from tacreasoner.model.tiny import tiny_qwen2_config
    from tacreasoner.train.pretrain_llm import _Example, _pack, packed_forward

    torch.manual_seed(0)
    model = Qwen2ForCausalLM(tiny_qwen2_config(300, **MODEL)).eval()
    a, b = list(range(5, 25)), list(range(40, 70))
    (ids, labels, positions, real), = _pack([_Example(a, a), _Example(b, [-100] * 10 + b[10:])], 64, pad_id=0)
    assert real == 50 and len(ids) == 64 and labels[20:30] == [-100] * 10 and positions[20] == 0
    with torch.no_grad():
        packed = packed_forward(model, torch.tensor([ids]), torch.tensor([positions])).logits[0]
        alone_a = model(input_ids=torch.tensor([a])).logits[0]
        alone_b = model(input_ids=torch.tensor([b])).logits[0]
    assert torch.allclose(packed[:20], alone_a, atol=1e-5)
    assert torch.allclose(packed[20:50], alone_b, atol=1e-5)


def test_cli_defaults_match_the_library_and_a_short_run_works(tmp_path: Path) -> None:
    import inspect

    from typer.testing import CliRunner

    from tacreasoner.cli import app, pretrain_llm_cmd
    from tacreasoner.train.pretrain_llm import PretrainSettings

    params = inspect.signature(pretrain_llm_cmd).parameters
    for name in ("steps", "batch_size", "seq_len", "lr", "vocab_size"):
        assert params[name].default == getattr(PretrainSettings, name), name
    out = tmp_path / "llm"
    result = CliRunner().invoke(app, ["pretrain-llm", "--out", str(out), "--steps", "2", "--batch-size", "2",
                                      "--no-eval", "--threads", "1"])
    assert result.exit_code == 0, result.output
    assert "model + tokenizer:" in result.output and (out / "model.safetensors").is_file()
    again = CliRunner().invoke(app, ["pretrain-llm", "--out", str(out), "--steps", "2", "--batch-size", "2"])
    assert again.exit_code == 2 and "already holds a pre-training run" in again.output
    alone = CliRunner().invoke(app, ["pretrain-llm", "--out", str(tmp_path / "r"), "--rehearse", str(out)])
    assert alone.exit_code == 2 and "--rehearse and --bench go together" in alone.output


def test_untrained_vocabulary_is_recorded_and_becomes_new_token_rows(finished: Path) -> None:
    """Entries of the BPE vocabulary the corpus never uses have untrained rows: build_model marks them new."""
    from transformers import AutoTokenizer

    from tacreasoner.model.build import UNTRAINED_TOKENS_FILE, build_model, untrained_token_ids

    tokenizer = AutoTokenizer.from_pretrained(finished)
    ids = json.loads((finished / UNTRAINED_TOKENS_FILE).read_text())["ids"]
    assert ids == untrained_token_ids(finished) and 0 < len(ids) < len(tokenizer)
    corpus_ids = set(tokenizer("a soft sponge is highly deformable", add_special_tokens=False)["input_ids"])
    assert not corpus_ids & set(ids), "words the corpus uses must not be listed as untrained"
    model, _ = build_model(finished)
    assert set(ids) <= set(model.config.new_token_ids)
    (finished / UNTRAINED_TOKENS_FILE).write_text('{"ids": [-1]}')
    try:
        with pytest.raises(ValueError, match="non-negative token ids"):
            untrained_token_ids(finished)
    finally:
        (finished / UNTRAINED_TOKENS_FILE).write_text(json.dumps({"ids": ids}))


def test_bf16_is_chosen_only_where_the_cpu_has_native_bf16() -> None:
    """oneDNN calls bf16 supported on every AVX-512 CPU, where it is emulated and several times slower than float32:
    the CPU's flags decide."""
    from tacreasoner.train.pretrain_llm import bf16_supported

    assert not bf16_supported("processor: 0\nflags\t\t: fpu sse avx2 avx512f avx512bw avx512_vnni\n")
    assert bf16_supported("processor: 0\nflags\t\t: fpu avx512f avx512_bf16\n")
    assert bf16_supported("processor: 0\nflags\t\t: fpu amx_bf16 amx_tile\n")
    assert bf16_supported("processor\t: 0\nFeatures\t: fp asimd sve bf16 i8mm\n")
    assert not bf16_supported("processor\t: 0\nFeatures\t: fp asimd\n")


def test_training_texts_hold_corpus_and_package_wording() -> None:
    texts = tokenizer_training_texts()
    wording = wording_texts()
    assert len(wording) >= 10 and all(w in texts for w in wording)
    assert any("tangerine" in t for t in texts)
    assert any(t.startswith("<|im_start|>user\n") for t in texts)
