"""The real-data recipe in one call, on a synthetic PhysiCLeAR-shaped folder: every step runs, the run resumes
without redoing finished steps, and val is scored in the benchmark's and in held-out wordings, questions over several
objects answered stepwise (the recommended mode)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest


def tiny_llm(out: Path, bench: Path) -> Path:
    """A 2-layer Qwen2 with a BPE tokenizer trained on the benchmark's own questions and answers, saved to disk."""
    import torch
    from transformers import Qwen2Config, Qwen2ForCausalLM

    from tacreasoner.model.tokenizer import train_tokenizer
    from tacreasoner.tasks.bench import load_bench

    _, items = load_bench(bench, "train")
    tokenizer = train_tokenizer([f"{i.question} <answer>{i.answer}</answer>" for i in items] * 2, vocab_size=600)
    config = Qwen2Config(vocab_size=len(tokenizer), hidden_size=64, num_hidden_layers=2, num_attention_heads=4,
                         num_key_value_heads=2, intermediate_size=128, max_position_embeddings=1024,
                         tie_word_embeddings=True, eos_token_id=tokenizer.eos_token_id,
                         pad_token_id=tokenizer.pad_token_id)
    torch.manual_seed(0)
    Qwen2ForCausalLM(config).save_pretrained(out)
    tokenizer.save_pretrained(out)
    return out


def test_the_recipe_runs_end_to_end_and_resumes(physiclear_folder: Path, make_physiclear_folder,
                                                tmp_path: Path) -> None:
    from tacreasoner.recipes.physiclear import run_recipe
    from tacreasoner.tasks.bench import build_bench

    build_bench("physiclear", physiclear_folder, tmp_path / "words")
    llm = tiny_llm(tmp_path / "llm", tmp_path / "words")
    overrides = {"stage1.steps": 2, "stage2.steps": 2, "stage1.batch_size": 4, "stage2.batch_size": 4,
                 "runtime.log_with": "none", "runtime.progress": False, "runtime.threads": 1,
                 "model.encoder.temporal_hidden_size": 32, "model.encoder.fusion_heads": 2,
                 "model.dtype": "float32", "model.attn_implementation": "eager"}
    said: list[str] = []
    record = run_recipe(physiclear_folder, tmp_path / "run", llm=llm, overrides=overrides,
                        encoder={"size": "48x64", "frames": 4}, say=said.append)
    assert set(record["seconds"]) == {"encoder", "bench", "seed0.stage1", "seed0.stage2",
                                      "evaluate val (benchmark wordings, stepwise-vote answers)",
                                      "evaluate val (heldout wordings, stepwise-vote answers)"}
    model = tmp_path / "run" / "train" / "seed0" / "stage2" / "model"
    assert (model / "config.json").is_file()
    assert json.loads((model / "config.json").read_text())["encoder"]["backbone"] == "efficientnet_lite0"
    # ask/serve/demo answer it the recommended way unless told otherwise
    assert json.loads((model / "processor_config.json").read_text())["answers"] == "stepwise-vote"
    val = record["results"]["val_benchmark"]
    assert val["hardness"]["n"] == 8 and 0 <= val["hardness"]["accuracy"] <= 1 and val["PSR"] is not None
    heldout = record["results"]["val_heldout"]
    assert heldout["hardness"]["n"] == 8 and heldout["PSR"] is None  # TSA has no held-out wording
    report = (tmp_path / "run" / "report.md").read_text()
    assert "held-out wordings" in report and "replies in the asked form" in report and "stepwise-vote answers" in report
    scored = json.loads((tmp_path / "run" / "eval" / "val_stepwise-vote" / "octopi.json").read_text())
    assert scored["answers"] == "stepwise-vote"  # questions over several objects answered the recommended way
    # again: nothing is redone
    said.clear()
    again = run_recipe(physiclear_folder, tmp_path / "run", llm=llm, overrides=overrides,
                       encoder={"size": "48x64", "frames": 4}, say=said.append)
    assert all("done before" in line for line in said if line.endswith(("done before", "...")))
    assert not any(line.endswith("...") for line in said) and again["seconds"] == record["seconds"]
    # more seeds in the same folder: the new seed trains, and val is scored over both (the first's answers kept)
    kept = (tmp_path / "run" / "eval" / "val_stepwise-vote" / "model0" / "predictions" / "val.jsonl").read_text()
    more = run_recipe(physiclear_folder, tmp_path / "run", seeds=(0, 1), llm=llm, overrides=overrides,
                      encoder={"size": "48x64", "frames": 4}, say=said.append)
    assert more["results"]["val_benchmark"]["hardness"]["n"] == 8
    scored = json.loads((tmp_path / "run" / "eval" / "val_stepwise-vote" / "octopi.json").read_text())
    assert len(scored["models"]) == 2 and scored["table"]["hardness"]["runs"] == 2
    assert (tmp_path / "run" / "eval" / "val_stepwise-vote" / "model0" / "predictions" / "val.jsonl").read_text() \
        == kept
    # the maintainers' path: the recipe's model scored by the CLI on a folder that holds only a test split
    from typer.testing import CliRunner

    from tacreasoner.cli import app

    held_out = make_physiclear_folder(tmp_path / "held_out", {"test": 3}, clips_per_object=1)
    result = CliRunner().invoke(app, ["evaluate-physiclear", "--model", str(model), "--data", str(held_out),
                                      "--out", str(tmp_path / "scored")])
    assert result.exit_code == 0, result.output
    octopi = (tmp_path / "scored" / "octopi.md").read_text()
    assert "hardness" in octopi.lower() and "test" in (tmp_path / "scored" / "report.md").read_text()
    assert json.loads((tmp_path / "scored" / "octopi.json").read_text())["answers"] == "stepwise-vote"


def test_a_folder_without_train_objects_is_refused(make_physiclear_folder, tmp_path: Path) -> None:
    from tacreasoner.recipes.physiclear import run_recipe

    folder = make_physiclear_folder(tmp_path / "only_test", {"test": 3})
    with pytest.raises(ValueError, match="no labelled object has split 'train'"):
        run_recipe(folder, tmp_path / "run")
