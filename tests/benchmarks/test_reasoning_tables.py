"""benchmarks/reasoning_gap.py and the 'follows' row of benchmarks/physiclear_table.py, run as a user runs them on a
scored folder: replies written in the compact style follow from their stated levels; plain ones state none; a reply
whose answer contradicts its own levels is counted."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from tacreasoner.cot.compact import compact_target
from tacreasoner.evaluate.report import evaluate
from tacreasoner.tasks.bench import build_bench, load_bench
from tacreasoner.tasks.conclude import REASONED_TASKS

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"


def _scored(tmp_path: Path, folder: Path, name: str, reply) -> Path:
    _, items = load_bench(folder, "val")
    preds = tmp_path / f"{name}.jsonl"
    preds.write_text("".join(json.dumps({"id": i.id, "prediction": reply(i)}) + "\n" for i in items))
    evaluate(items, [preds], "strict", tmp_path / name)
    return tmp_path / name


def _flip_last_answer(item) -> str:
    """The compact reply with its answer swapped for a wrong one (for the items where one is at hand)."""
    target = compact_target(item)
    if item.task == "PC":
        wrong = {"more": "less", "less": "more", "similar": "more"}[item.answer]
        return target.replace(f"<answer>{item.answer}</answer>", f"<answer>{wrong}</answer>")
    return target


def test_gap_and_follows_rows(physiclear_folder: Path, tmp_path: Path) -> None:
    bench = tmp_path / "bench"
    build_bench("physiclear", physiclear_folder, bench)
    compact = _scored(tmp_path, bench, "compact", compact_target)
    plain = _scored(tmp_path, bench, "plain", lambda i: f"<answer>{i.answer}</answer>")
    flipped = _scored(tmp_path, bench, "flipped", _flip_last_answer)
    out = tmp_path / "results"
    run = subprocess.run([sys.executable, str(BENCHMARKS / "reasoning_gap.py"), "--split", "val", "--bench", str(bench),
                          "--row", f"compact={compact}", "--row", f"plain={plain}", "--row", f"flipped={flipped}",
                          "--name", "gap", "--results", str(out)], capture_output=True, text=True, cwd=tmp_path,
                         env={"PYTHONPATH": str(BENCHMARKS.parent / "src"), "PATH": "/usr/bin:/bin"})
    assert run.returncode == 0, run.stderr
    rows = json.loads((out / "gap.json").read_text())["rows"]
    full = "| compact (1 seed(s)) | PC | 100.0 | 100.0 | 100.0 | 100.0 | 100.0 | 100.0 |"
    assert full in (out / "gap.md").read_text()
    for task in set(REASONED_TASKS) & set(rows["compact"]):
        assert rows["compact"][task]["model"] == [1.0] and rows["compact"][task]["rule"] == [1.0]
        assert rows["compact"][task]["follows"] == [1.0] and rows["plain"][task]["follows"] == [0.0]
    assert rows["flipped"]["PC"]["follows"] == [0.0] and rows["flipped"]["PC"]["model"] == [0.0]
    assert rows["flipped"]["PC"]["rule"] == [1.0]  # its readings were right: the rule still concludes correctly
    assert rows["flipped"]["PC"]["rule_on_stated"] == [1.0] and rows["flipped"]["PC"]["stated"] == [1.0]
    assert rows["plain"]["PC"]["stated"] == [0.0] and rows["plain"]["PC"]["rule_on_stated"] == [1.0]  # its own

    sys.path.insert(0, str(BENCHMARKS))
    try:
        from physiclear_table import row_table
    finally:
        sys.path.remove(str(BENCHMARKS))
    table, runs = row_table(compact)
    assert runs == 1 and table["PC"]["follows_rate"] == 1.0 and table["POM"]["follows_rate"] == 1.0
    plain_table, _ = row_table(plain)
    assert all(plain_table[c]["follows_rate"] != plain_table[c]["follows_rate"] for c in ("PC", "PSS"))  # NaN
