"""Replies stopped by the reply budget (``max_new_tokens``) before the model ended them: recorded on each prediction
line, counted per task, and reported to the user. Such a reply has no ``<answer>`` and scores wrong, so a budget
shorter than the reasoning a model was trained to write must not pass silently (TouchCoT's OSC reasoning is ~370
tokens, past the old default of 256)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import torch
from typer.testing import CliRunner

from tacreasoner.evaluate.predict import (
    REPLY_TOKENS,
    _stopped_by_budget,
    cut_replies,
    cut_warning,
    load_trained,
    predict_items,
)
from tacreasoner.tasks.bench import load_bench
from tacreasoner.train.data import bench_video_root

EOS = [7, 9]
PAD = 0


def test_a_row_is_cut_only_when_the_budget_ends_it_without_an_end_of_turn() -> None:
    new = torch.tensor([[5, 6, 9, PAD], [5, 6, 8, 8], [7, PAD, PAD, PAD]])
    assert _stopped_by_budget(new, EOS, max_new_tokens=4) == [False, True, False]
    # generation stopped before the budget: every row ended its turn
    assert _stopped_by_budget(new, EOS, max_new_tokens=5) == [False, False, False]


def test_counts_and_warning_name_the_tasks(tmp_path: Path) -> None:
    path = tmp_path / "test.jsonl"
    lines = [{"id": "a", "task": "OSC", "prediction": "<think>…", "cut": True},
             {"id": "b", "task": "OSC", "prediction": "<think>…", "cut": True},
             {"id": "c", "task": "SFD", "prediction": "<answer>yes</answer>", "cut": False},
             {"id": "d", "task": "SOI", "prediction": "<answer>B</answer>"}]  # written before cuts were recorded
    path.write_text("".join(json.dumps(line) + "\n" for line in lines) + '{"id": "e", "ta')  # a crash cut the last
    assert cut_replies(path) == {"OSC": 2}
    warning = cut_warning(path, 256)
    assert warning is not None and warning.startswith("warning: 2 replies") and "OSC 2" in warning
    assert "--max-new-tokens" in warning and "256" in warning
    path.write_text(json.dumps(lines[2]) + "\n")
    assert cut_replies(path) == {} and cut_warning(path, 256) is None


def test_the_default_budget_fits_touchcot_reasoning_over_three_videos() -> None:
    assert REPLY_TOKENS >= 450  # the builder's longest reasoning (OSC, TFA-combined) is ~420 tokens


@pytest.fixture(scope="module")
def answered(model_dir: Path, bench: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """Three test items answered by the untrained model with a 3-token budget (noise that never ends its turn in
    3 tokens) and with the model's generate made to end every turn at once."""
    model, processor = load_trained(model_dir, device="cpu")
    info, items = load_bench(bench, "test")
    items, root = items[:3], bench_video_root(bench, info)
    out = tmp_path_factory.mktemp("budget")
    short = predict_items(model, processor, items, root, out / "short.jsonl", max_new_tokens=3)
    real = model.generate
    eos = processor.eos_token_ids[0]

    def ends_at_once(**kwargs: Any) -> torch.Tensor:
        new = real(**kwargs)
        return torch.full((new.shape[0], 3), eos, dtype=new.dtype)

    model.generate = ends_at_once
    try:
        ended = predict_items(model, processor, items, root, out / "ended.jsonl", max_new_tokens=3)
    finally:
        model.generate = real
    return {"items": items, "short": short, "ended": ended}


def test_prediction_lines_record_whether_the_budget_cut_them(answered: dict[str, Any]) -> None:
    short = [json.loads(line) for line in answered["short"].read_text().splitlines()]
    ended = [json.loads(line) for line in answered["ended"].read_text().splitlines()]
    assert len(short) == len(ended) == 3
    assert all(line["cut"] is True for line in short)
    assert all(line["cut"] is False for line in ended)
    tasks = [item.task for item in answered["items"]]
    assert cut_replies(answered["short"]) == {t: tasks.count(t) for t in set(tasks)}


def test_evaluate_tells_the_user_when_replies_were_cut(model_dir: Path, bench: Path, tmp_path: Path) -> None:
    from tacreasoner.cli import app

    base = ["evaluate", "--model", str(model_dir), "--bench", str(bench), "--limit", "2"]
    result = CliRunner().invoke(app, [*base, "--out", str(tmp_path / "short"), "--max-new-tokens", "2"])
    assert result.exit_code == 0, result.output
    assert "warning: 2 replies" in result.output and "--max-new-tokens" in result.output


def test_every_answering_entry_point_defaults_to_the_same_budget() -> None:
    import inspect

    from tacreasoner.cli.evaluate import evaluate_cmd, evaluate_physiclear_cmd
    from tacreasoner.cli.serve import ask
    from tacreasoner.evaluate.physiclear import evaluate_folder
    from tacreasoner.evaluate.predict import answer_with_model, predict_split
    from tacreasoner.evaluate.touch_control import run_touch_control
    from tacreasoner.recipes.quickstart_report import evaluate_seeds
    from tacreasoner.serve.engine import Sampling

    for entry in (evaluate_cmd, evaluate_physiclear_cmd, ask, evaluate_folder, answer_with_model, predict_split,
                  run_touch_control, evaluate_seeds, predict_items):
        assert inspect.signature(entry).parameters["max_new_tokens"].default == REPLY_TOKENS, entry.__name__
    assert Sampling().max_new_tokens == REPLY_TOKENS
