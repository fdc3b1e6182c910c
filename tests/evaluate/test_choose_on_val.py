"""The recipe choice reads val only: highest val average, ties within the tie to the earliest-listed (cheapest)
(tacreasoner.evaluate.recipe_choice, and benchmarks/choose_on_val.py that runs it from a shell)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from tacreasoner.evaluate.recipe_choice import choose_on_val

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "choose_on_val.py"


def _report(root: Path, name: str, split: str, average: float) -> None:
    path = root / name / split / "report.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({"average": {"value": average}}))


def test_the_best_val_average_wins_and_test_is_never_read(tmp_path: Path) -> None:
    _report(tmp_path, "cheap", "val", 0.40)
    _report(tmp_path, "big", "val", 0.45)
    _report(tmp_path, "cheap", "test", 0.99)  # a test score must not sway the choice
    choice = choose_on_val(tmp_path, ["cheap", "big", "gone"])
    assert choice.winner == "big" and choice.scores == {"cheap": 0.40, "big": 0.45}
    assert choice.to_dict() == {"split": "val", "candidates": {"cheap": 0.40, "big": 0.45}, "missing": ["gone"],
                                "winner": "big", "tie_points": 0.0}


def test_a_tie_goes_to_the_earlier_cheaper_candidate(tmp_path: Path) -> None:
    _report(tmp_path, "cheap", "val", 0.440)
    _report(tmp_path, "big", "val", 0.446)
    assert choose_on_val(tmp_path, ["cheap", "big"], tie_points=1).winner == "cheap"
    assert choose_on_val(tmp_path, ["cheap", "big"], tie_points=0.5).winner == "big"


def test_no_val_report_or_no_average_is_an_error(tmp_path: Path) -> None:
    _report(tmp_path, "only", "test", 0.5)
    with pytest.raises(ValueError, match="none of the candidates has a val report"):
        choose_on_val(tmp_path, ["only"])
    (tmp_path / "broken" / "val").mkdir(parents=True)
    (tmp_path / "broken" / "val" / "report.json").write_text("{}")
    with pytest.raises(ValueError, match=r"no val report with average\.value"):
        choose_on_val(tmp_path, ["broken"])


def _script(root: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), "--eval", str(root), *args], capture_output=True, text=True,
                          check=False)


def test_the_script_prints_the_winner_for_a_shell_and_fails_in_one_line(tmp_path: Path) -> None:
    _report(tmp_path, "cheap", "val", 0.440)
    _report(tmp_path, "big", "val", 0.446)
    out = _script(tmp_path, "--tie", "1", "--out", str(tmp_path / "choice.json"), "cheap", "big", "gone")
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "cheap" and "big: val average 44.6" in out.stderr
    choice = json.loads((tmp_path / "choice.json").read_text())
    assert choice["winner"] == "cheap" and choice["missing"] == ["gone"] and choice["tie_points"] == 1.0
    out = _script(tmp_path, "nothing")
    assert out.returncode != 0 and "none of the candidates has a val report" in out.stderr
    assert "Traceback" not in out.stderr
