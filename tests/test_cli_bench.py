"""The benchmark commands end to end: build-bench → baseline → score → compare, and their errors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from tacreasoner.cli import app
from tacreasoner.tasks.bench import load_bench

runner = CliRunner()


def invoke(*args: object):
    return runner.invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def bench(small_sim_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("cli_bench") / "bench"
    result = invoke("build-bench", "--source", "sim", "--data", small_sim_dataset, "--out", out)
    assert result.exit_code == 0, result.output
    assert "TFA-hardness" in result.output and "objects" in result.output
    return out


def test_baseline_score_and_compare(bench: Path, tmp_path: Path) -> None:
    for kind in ("random", "majority"):
        result = invoke("baseline", "--bench", bench, "--kind", kind, "--out", tmp_path / f"{kind}.jsonl")
        assert result.exit_code == 0, result.output
    val_items = len(load_bench(bench, "val")[1])
    assert sum(1 for _ in (tmp_path / "random.jsonl").open()) == val_items != len(load_bench(bench, "test")[1])
    result = invoke("score", tmp_path / "random.jsonl", tmp_path / "majority.jsonl", "--bench", bench,
                    "--out", tmp_path / "report")
    assert result.exit_code == 0, result.output
    assert "Average" in result.output and f"scored split: val of {bench}" in result.output
    for name in ("report.md", "report.csv", "report.json", "report.png"):
        assert (tmp_path / "report" / name).stat().st_size > 100
    report = json.loads((tmp_path / "report" / "report.json").read_text())
    assert report["n_runs"] == 2
    result = invoke("compare", tmp_path / "random.jsonl", tmp_path / "majority.jsonl", "--bench", bench,
                    "--out", tmp_path / "cmp")
    assert result.exit_code == 0, result.output
    assert "McNemar" in result.output and f"split: val of {bench}" in result.output
    assert json.loads((tmp_path / "cmp" / "comparison.json").read_text())["overall"]["n"] > 0


def test_an_evaluation_corpus_keeps_a_models_train_objects_out_of_val_and_test(
        bench: Path, small_sim_dataset: Path, tmp_path: Path) -> None:
    """A second corpus built to evaluate a model must not ask it about objects it trained on."""
    first = json.loads((bench / "bench.json").read_text())["splits"]
    trained = {obj for obj, split in first.items() if split == "train"}
    out = tmp_path / "eval_bench"
    result = invoke("build-bench", "--source", "sim", "--data", small_sim_dataset, "--out", out, "--seed", 5,
                    "--fractions", "0,0.5,0.5", "--keep-train-of", bench)
    assert result.exit_code == 0, result.output
    info = json.loads((out / "bench.json").read_text())
    assert info["kept_in_train"] == sorted(trained) and info["fractions"] == [0, 0.5, 0.5]
    assert {obj for obj, split in info["splits"].items() if split == "train"} == trained
    for split in ("val", "test"):
        asked = {obj for item in load_bench(out, split)[1] for obj in item.objects}
        assert asked and not asked & trained
    assert f"{len(trained)} object(s) kept in train" in result.output


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["build-bench", "--source", "sim", "--out", "x"], "needs --data"),
        (["build-bench", "--source", "octopi", "--data", ".", "--out", "x"], "unknown source"),
        (["build-bench", "--source", "sim", "--data", "/no/such/dir", "--out", "x"], "no such directory"),
        (["baseline", "--bench", "/no/bench", "--kind", "random", "--out", "p.jsonl"], "not a benchmark directory"),
        (["build-bench", "--source", "sim", "--data", ".", "--out", "x", "--fractions", "0.5,0.5"],
         "three shares"),
        (["build-bench", "--source", "sim", "--data", ".", "--out", "x", "--fractions", "0.5,0.5,0.5"],
         "summing to 1"),
        (["build-bench", "--source", "sim", "--data", ".", "--out", "x", "--keep-train-of", "/no/bench"],
         "not a benchmark directory"),
    ],
)
def test_errors_are_one_line(args: list[str], needle: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    result = invoke(*args)
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and needle in lines[0], result.stderr


def test_score_reports_malformed_prediction_line(bench: Path, tmp_path: Path) -> None:
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"id": "x", "prediction": "<answer>A</answer>"}\nnot json\n')
    result = invoke("score", bad, "--bench", bench)
    assert result.exit_code == 2
    assert "bad.jsonl:2" in result.stderr
