"""The recipe choice reads val only: highest val average, ties within --tie to the earliest-listed (cheapest)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"


def _report(root: Path, name: str, split: str, average: float) -> None:
    path = root / name / split / "report.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({"average": {"value": average}}))


def _choose(root: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(BENCHMARKS / "choose_on_val.py"), "--eval", str(root), *args],
                          capture_output=True, text=True, check=False)


def test_the_best_val_average_wins_and_test_is_never_read(tmp_path: Path) -> None:
    _report(tmp_path, "cheap", "val", 0.40)
    _report(tmp_path, "big", "val", 0.45)
    _report(tmp_path, "cheap", "test", 0.99)  # a test score must not sway the choice
    out = _choose(tmp_path, "--out", str(tmp_path / "choice.json"), "cheap", "big", "gone")
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "big"
    choice = json.loads((tmp_path / "choice.json").read_text())
    assert choice["winner"] == "big" and choice["missing"] == ["gone"] and choice["split"] == "val"


def test_a_tie_goes_to_the_earlier_cheaper_candidate(tmp_path: Path) -> None:
    _report(tmp_path, "cheap", "val", 0.440)
    _report(tmp_path, "big", "val", 0.446)
    assert _choose(tmp_path, "--tie", "1", "cheap", "big").stdout.strip() == "cheap"
    assert _choose(tmp_path, "--tie", "0.5", "cheap", "big").stdout.strip() == "big"


def test_no_val_report_is_a_one_line_error(tmp_path: Path) -> None:
    _report(tmp_path, "only", "test", 0.5)
    out = _choose(tmp_path, "only")
    assert out.returncode != 0 and "none of the candidates has a val report" in out.stderr
    (tmp_path / "broken" / "val").mkdir(parents=True)
    (tmp_path / "broken" / "val" / "report.json").write_text("{}")
    out = _choose(tmp_path, "broken")
    assert out.returncode != 0 and "no val report with average.value" in out.stderr
    assert "Traceback" not in out.stderr
