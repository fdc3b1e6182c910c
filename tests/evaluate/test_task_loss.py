"""The teacher-forced answer loss per task and split (`tacreasoner task-loss`)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from typer.testing import CliRunner

from tacreasoner.evaluate.task_loss import task_loss_markdown, task_losses
from tacreasoner.tasks.bench import load_bench
from tests.evaluate.evalsetup import save_untrained_model


@pytest.fixture(scope="module")
def bench(small_sim_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    from tacreasoner.tasks.bench import build_bench

    out = tmp_path_factory.mktemp("loss_bench") / "bench"
    build_bench("sim", small_sim_dataset, out, seed=0)
    return out


@pytest.fixture(scope="module")
def model_dir(bench: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    texts = [f"{i.question} {i.answer}" for i in load_bench(bench, "train")[1]]
    return save_untrained_model(texts, tmp_path_factory.mktemp("loss_model"))


def test_losses_per_task_and_split_follow_the_draw(model_dir: Path, bench: Path, tmp_path: Path) -> None:
    cache = tmp_path / "cache"
    losses = task_losses(model_dir, bench, splits=("train", "val"), per_task=2, video_cache=cache)
    assert list(losses) == ["train", "val"]
    for split, tasks in losses.items():
        in_split = {i.task for i in load_bench(bench, split)[1]} - {"TSA"}
        assert set(tasks) == in_split  # every task but TSA (no training target), nothing else
        for cell in tasks.values():
            assert 1 <= cell["n"] <= 2 and math.isfinite(cell["loss"]) and cell["loss"] > 0
    again = task_losses(model_dir, bench, splits=("train", "val"), per_task=2, video_cache=cache)
    assert again == losses  # the same items, drawn with the same seed
    other = task_losses(model_dir, bench, splits=("train",), per_task=2, seed=5, video_cache=cache)
    assert other["train"] != losses["train"]  # another draw, other items
    table = task_loss_markdown(losses)
    assert all(f"| {task} |" in table for task in losses["train"]) and "val / train" in table


def test_the_command_writes_both_files_and_refuses_a_negative_count(model_dir: Path, bench: Path,
                                                                     tmp_path: Path) -> None:
    from tacreasoner.cli import app

    runner = CliRunner()
    out = tmp_path / "loss"
    result = runner.invoke(app, ["task-loss", "--model", str(model_dir), "--bench", str(bench), "--out", str(out),
                                 "--splits", "train,val", "--per-task", "1"])
    assert result.exit_code == 0, result.output
    written = json.loads((out / "task_loss.json").read_text())
    assert written["per_task"] == 1 and set(written["losses"]) == {"train", "val"}
    assert (out / "task_loss.md").read_text().startswith("## Answer loss per task")
    refused = runner.invoke(app, ["task-loss", "--model", str(model_dir), "--bench", str(bench), "--out",
                                  str(out), "--per-task", "-1"])
    assert refused.exit_code != 0 and "--per-task -1" in refused.output
