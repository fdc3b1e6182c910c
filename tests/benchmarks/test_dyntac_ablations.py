"""benchmarks/dyntac_ablations.py run as a user runs it, on hand-made score records: the paired verdict and the
answer-form table (share of replies in the asked form; share cut by the reply budget where the predictions record
it; accuracy on those items beside the recipe's)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "dyntac_ablations.py"


def _write(run: Path, variant: str, seed: int, records: list[dict]) -> None:
    folder = run / "eval" / f"{variant}.seed{seed}" / "val" / "scored"
    folder.mkdir(parents=True)
    (folder / "val.jsonl").write_text("".join(json.dumps(r) + "\n" for r in records), encoding="utf-8")


def _predictions(run: Path, variant: str, seed: int, cut: list[bool] | None) -> None:
    """The predictions file beside the scored one; ``cut`` None: written before evaluation recorded cuts."""
    folder = run / "eval" / f"{variant}.seed{seed}" / "val" / "predictions"
    folder.mkdir(parents=True)
    lines = [{"id": f"item-{i}", "task": "TFA-hardness", "prediction": ""} | ({} if cut is None else {"cut": c})
             for i, c in enumerate(cut or [False] * 80)]
    (folder / "val.jsonl").write_text("".join(json.dumps(r) + "\n" for r in lines), encoding="utf-8")


def _records(correct: list[bool], unreadable: set[int] = frozenset()) -> list[dict]:
    return [{"id": f"item-{i}", "task": "TFA-hardness", "correct": ok and i not in unreadable,
             "parse_failed": i in unreadable, "chance": 1 / 3} for i, ok in enumerate(correct)]


def test_a_variant_that_answers_out_of_form_is_lower_and_its_readable_items_are_compared(tmp_path: Path) -> None:
    run, out = tmp_path / "run", tmp_path / "out"
    for seed in (0, 1):
        _write(run, "rec", seed, _records([True] * 60 + [False] * 20))
        # half the replies out of form; on the other half right as often as the recipe on those items
        _write(run, "cot", seed, _records([True] * 60 + [False] * 20, unreadable=set(range(0, 80, 2))))
    _predictions(run, "cot", 0, [i % 4 == 0 for i in range(80)])  # 20 of the 40 out-of-form replies were cut
    _predictions(run, "cot", 1, None)
    done = subprocess.run([sys.executable, str(SCRIPT), "--run", str(run), "--name", "t", "--out-dir", str(out),
                           "--variant", "cot=TouchCoT"], capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    payload = json.loads((out / "t.json").read_text(encoding="utf-8"))
    assert payload["ablations"]["cot"]["verdict"] == "lower in 2/2 seeds"
    form = payload["answer_form"]["cot"]
    assert [f["in_form"] for f in form] == [0.5, 0.5]
    assert [f["items"] for f in form] == [40, 40]
    assert all(f["variant"] == f["recipe"] == 0.75 for f in form)
    assert [f["cut"] for f in form] == [0.25, None]
    md = (out / "t.md").read_text(encoding="utf-8")
    assert "## Answer form on val" in md and "| cot | 50.0 / 50.0 | 25.0 / not recorded |" in md
