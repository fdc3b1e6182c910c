"""``build-cot`` and ``cot-review`` from the command line, and their one-line errors."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from tacreasoner.cli import app
from tacreasoner.tasks.bench import build_bench

runner = CliRunner()


def invoke(*args: object, env: dict | None = None):
    return runner.invoke(app, [str(a) for a in args], env=env)


@pytest.fixture(scope="module")
def bench(small_sim_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("cli_cot") / "bench"
    build_bench("sim", small_sim_dataset, out, seed=0, heldout_sensor="digit")
    return out


def test_build_cot_with_rules_then_review_round_trip(bench: Path, tmp_path: Path) -> None:
    out = tmp_path / "cot"
    result = invoke("build-cot", "--bench", bench, "--out", out, "--limit", "60")
    assert result.exit_code == 0, result.output
    assert "accepted" in result.output
    report = json.loads((out / "build_cot.json").read_text())
    assert report["jobs"] == 60 and report["accepted"] > 50
    assert (out / "touchcot" / "touchcot_train.jsonl").exists()
    again = invoke("build-cot", "--bench", bench, "--out", out, "--limit", "60")
    assert again.exit_code == 0 and "0 generated now, 60 already done" in again.output

    result = invoke("cot-review", "--cot", out, "--export", "--n", "10", "--bench", bench)
    assert result.exit_code == 0, result.output
    sheet = out / "review" / "review.csv"
    rows = list(csv.DictReader(sheet.open(encoding="utf-8")))
    assert len(rows) == 10 and "data:image/png;base64" in (out / "review" / "review.html").read_text()
    rows[0]["decision"] = "reject"
    with sheet.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    result = invoke("cot-review", "--cot", out, "--import", sheet)
    assert result.exit_code == 0, result.output
    train = [json.loads(x) for x in (out / "touchcot" / "touchcot_train.jsonl").read_text().splitlines()]
    val = [json.loads(x) for x in (out / "touchcot" / "touchcot_val.jsonl").read_text().splitlines()]
    kept = {r.get("key") or r.get("id") for r in train + val}
    assert rows[0]["key"] not in kept and rows[0]["item_id"] not in kept
    # The decision survives a re-run of build-cot.
    assert invoke("build-cot", "--bench", bench, "--out", out, "--limit", "60").exit_code == 0
    rerun = json.loads((out / "build_cot.json").read_text())
    assert rerun["accepted"] == report["accepted"] - 1


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--teacher", "claude"], "backend"),
        (["--teacher", "openai", "--model", "m"], "MISSING_KEY_FOR_TEST"),
        (["--concurrency", "0"], "--concurrency"),
        (["--tasks", "TSA"], "TSA"),
    ],
)
def test_bad_configuration_is_one_line(bench: Path, tmp_path: Path, args: list[str], needle: str) -> None:
    extra = []
    if "openai" in args:
        cfg = tmp_path / "t.yaml"
        cfg.write_text("teacher:\n  backend: openai\n  model: m\n  base_url: http://127.0.0.1:9/v1\n"
                       "  api_key_env: MISSING_KEY_FOR_TEST\n")
        args = ["--teacher-config", str(cfg)]
    result = invoke("build-cot", "--bench", bench, "--out", tmp_path / "o", *args, *extra)
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and needle in lines[0], result.stderr


def test_teacher_failures_are_reported_with_their_reason(bench: Path, tmp_path: Path) -> None:
    """A wrong API key must not look like success: the run says why the calls failed."""
    from tests.cot.fake_openai_server import FakeOpenAIServer

    with FakeOpenAIServer(expected_key="sk-right") as server:
        cfg = tmp_path / "t.yaml"
        cfg.write_text(f"teacher:\n  backend: openai\n  model: fake\n  base_url: {server.base_url}\n"
                       "  api_key_env: TEST_TEACHER_KEY\n  max_retries: 0\n")
        result = invoke("build-cot", "--bench", bench, "--out", tmp_path / "o", "--teacher-config", cfg,
                        "--limit", "3", env={"TEST_TEACHER_KEY": "sk-wrong"})
    assert result.exit_code == 1, result.output  # incomplete run: non-zero so scripts notice
    assert "3 failed" in result.output and "401" in result.output
