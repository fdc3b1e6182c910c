"""What reasoning loses: per multi-object task, a model's own accuracy beside the conclusion rule applied to its own
single-clip answers (``tacreasoner.evaluate.clip_rule``), and the share of its replies whose answer follows from the
levels they stated.

Each ``--row LABEL=DIR`` is an ``evaluate-physiclear`` (or ``evaluate``) output folder: its items in
``DIR/bench/<split>.jsonl`` (or ``--bench``) and one ``DIR/scored/*.jsonl`` per seed. Per seed the rule reads the
clips from that seed's own single-clip answers; the table gives mean ± std over seeds.

    python benchmarks/reasoning_gap.py --split val --name physiclear_reasoning_gap_val \\
        --row "plain=runs/physiclear/eval_val/rec.seeds0-1-2" \\
        --row "compact=runs/physiclear/eval_val/compact.seeds0-1-2"
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, pm, publish, stamp

COLUMNS = {"PC": "PC", "SOI": "PSS", "OSC": "POM", "TSA": "PSR", "SFD": "SFD"}
"""Task → the name Octopi's table gives it (SFD has none there)."""


def _spread(values: list[float]) -> tuple[float, float]:
    return statistics.fmean(values), (statistics.stdev(values) if len(values) > 1 else math.nan)


def row(folder: Path, split: str, bench: Path | None) -> dict:
    """Per task: model accuracy, the rule on the model's own clip readings, coverage, follows share (per seed)."""
    from tacreasoner.evaluate.clip_rule import clip_readings, rule_on_readings, rule_on_stated
    from tacreasoner.evaluate.report import load_scored
    from tacreasoner.tasks.bench import load_bench

    _, items = load_bench(bench or folder / "bench", split)
    files = sorted((folder / "scored").glob("*.jsonl"))
    if not files:
        raise SystemExit(f"{folder}: no scored/*.jsonl (evaluate the models first)")
    per_seed: dict[str, dict[str, list[float]]] = {}
    for path in files:
        records = load_scored(path)
        rule = rule_on_readings(items, clip_readings(items, records))
        stated = rule_on_stated(items, records)
        for task, score in rule.items():
            mine = [r for r in records if r["task"] == task]
            cells = per_seed.setdefault(task, {"model": [], "rule": [], "covered": [], "follows": [], "stated": [],
                                               "rule_on_stated": []})
            cells["stated"].append(stated[task].covered / stated[task].n)
            cells["rule_on_stated"].append(stated[task].accuracy)
            cells["model"].append(sum(bool(r["correct"]) for r in mine) / len(mine))
            cells["rule"].append(score.accuracy)
            cells["covered"].append(score.covered / score.n)
            cells["follows"].append(sum(r.get("follows") is True for r in mine) / len(mine))
    return {task: {k: list(v) for k, v in cells.items()} for task, cells in per_seed.items()} | {"seeds": len(files)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--row", action="append", required=True, metavar="LABEL=DIR")
    ap.add_argument("--split", default="val")
    ap.add_argument("--bench", type=Path, default=None, help="benchmark folder (default: DIR/bench)")
    ap.add_argument("--name", default="physiclear_reasoning_gap_val")
    ap.add_argument("--notes", default="")
    ap.add_argument("--results", type=Path, default=None, help="where to write (default: benchmarks/results)")
    args = ap.parse_args()
    rows = {}
    for spec in args.row:
        label, sep, path = spec.partition("=")
        if not sep:
            raise SystemExit(f"--row {spec!r}: expected LABEL=DIR")
        rows[label] = row(Path(path), args.split, args.bench)
    info = stamp()
    md = header_md(f"What reasoning loses ({args.split}): the model's multi-object answers against the rule on its "
                   "own single-clip answers", info) + (args.notes + "\n\n" if args.notes else "")
    md += ("| model | task | model's answers % | rule on its own clip readings % | clips read % | replies stating "
           "levels % | answer follows from its stated levels % | rule on its stated levels % |\n"
           "|---|---|---|---|---|---|---|---|\n")
    for label, cells in rows.items():
        for task in [t for t in COLUMNS if t in cells]:
            c = cells[task]
            name = task if COLUMNS[task] == task else f"{COLUMNS[task]} ({task})"
            md += (f"| {label} ({cells['seeds']} seed(s)) | {name} | {pm(*_spread(c['model']))} | "
                   f"{pm(*_spread(c['rule']))} | {pm(*_spread(c['covered']))} | {pm(*_spread(c['stated']))} | "
                   f"{pm(*_spread(c['follows']))} | {pm(*_spread(c['rule_on_stated']))} |\n")
    md += ("\nMean ± std over seeds. The rule (tasks/conclude.py) takes each clip's levels from the same model's "
           "answers to the single-clip questions about that clip (the property's own question, else the combined "
           "one) and concludes: PC compares, PSS/SFD take the arg-max, PSR scores the scenario's needs, POM matches "
           "videos to the named objects given those objects' **gold** levels (so POM's rule figure assumes perfect "
           "knowledge of what named objects feel like). Ties in the readings share the credit. Items with an unread "
           "clip count as wrong ('clips read' is the share of items whose every clip was read). 'Answer follows': "
           "replies whose answer is one the levels their own reasoning stated imply, among all replies; 0 for "
           "models that state no levels. 'Rule on its stated levels': each reply's answer replaced by the rule applied "
           "to the levels it stated in context (POM with the levels it stated for the named objects; replies stating "
           "none keep their answer): what the model's own descriptions are worth when the last step cannot go "
           "wrong.\n")
    publish(args.name, {**info, "split": args.split, "rows": rows, "notes": args.notes}, md, args.results)


if __name__ == "__main__":
    main()
