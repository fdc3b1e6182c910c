"""Removed-touch control (Touch-R1's check): does the trained model answer from touch or from the text alone?

Usage:

    python benchmarks/touch_control.py --model runs/quickstart/model --bench runs/quickstart/bench \
        --split test --out runs/touch_control [--limit N] [--touch-seed 0] [--results-dir DIR]

The same model answers the same items three times (``tacreasoner evaluate --touch``): with each item's real
videos, with a blank clip in place of every video (the preprocessed form of a clip that never changes: zeros,
sensor ids kept), and with the videos of other items of the split (a seeded permutation of all its video slots
that, where possible, gives no item its own clip or a clip of its own object). Each run is scored with the
project's scorer; per task the table gives accuracy with a Wilson 95% interval, chance, and the exact McNemar
p-value of real against blank and against shuffled on the same items. A model that uses touch loses accuracy
without it; where blank or shuffled stays at real's level, that task is answered from the text.
Predictions (resumable) and reports go under --out (predictions/<split>[_<mode>].jsonl, touch_<mode>/);
results: benchmarks/results/touch_control.{json,md} (or --results-dir).
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, publish, stamp

MODES = ("real", "blank", "shuffled")
"""Kept equal to ``tacreasoner.evaluate.predict.TOUCH_MODES`` (checked in main); here so the table needs no torch."""
CONTROLS = ("blank", "shuffled")


def _cell(accuracy: float, low: float, high: float) -> dict[str, float]:
    return {"accuracy": accuracy, "ci_low": low, "ci_high": high}


def touch_table(records: Mapping[str, Sequence[dict]]) -> dict[str, Any]:
    """Per task and overall: each mode's accuracy with its Wilson 95% interval, chance, and the exact McNemar test
    of real against each control, from the scorer's per-item records (``scored/<run>.jsonl``) of the three modes.

    The records of all modes must cover the same items (the control only means something on paired items)."""
    from tacreasoner.evaluate.report import compare_runs, summarize
    from tacreasoner.intervals import wilson_interval

    missing = [m for m in MODES if m not in records]
    if missing:
        raise ValueError(f"touch_table needs the records of {', '.join(MODES)}; missing {', '.join(missing)}")
    reports = {m: summarize({m: records[m]}) for m in MODES}
    tests = {m: compare_runs(records["real"], records[m], "real", m) for m in CONTROLS}
    rows = []
    for real_row in reports["real"].tasks:
        task = real_row.task
        by_mode = {m: next(r for r in reports[m].tasks if r.task == task) for m in MODES}
        chance = None if math.isnan(real_row.chance) else real_row.chance  # a task without a known chance level
        row: dict[str, Any] = {"task": task, "n": real_row.n, "chance": chance}
        for m, r in by_mode.items():
            row[m] = {**_cell(r.accuracy, r.ci_low, r.ci_high), "parse_failure_rate": r.parse_failure_rate}
        for m in CONTROLS:
            row[f"real_vs_{m}"] = tests[m].per_task[task].to_dict()
        rows.append(row)
    n = reports["real"].overall["n"]
    overall: dict[str, Any] = {"task": "Overall", "n": n}
    for m in MODES:
        acc = reports[m].overall["accuracy"]
        overall[m] = _cell(acc, *wilson_interval(round(acc * n), n))
    for m in CONTROLS:
        overall[f"real_vs_{m}"] = tests[m].overall.to_dict()
    return {"tasks": rows, "overall": overall, "average": {m: reports[m].average["value"] for m in MODES}}


def _pct(cell: Mapping[str, float]) -> str:
    return f"{100 * cell['accuracy']:.1f} [{100 * cell['ci_low']:.0f}–{100 * cell['ci_high']:.0f}]"


def _p(test: Mapping[str, Any]) -> str:
    p = test["p_value"]
    text = f"{p:.2g} ({test['b10']}↓ {test['b01']}↑)"
    return f"**{text}**" if p < 0.05 else text


def table_markdown(table: Mapping[str, Any]) -> str:
    """The table as Markdown: accuracy % [Wilson 95%], chance %, McNemar p of real vs each control (bold < 0.05)."""
    head = ["Task", "n", "Chance", "Real", "Blank", "Shuffled", "p real vs blank", "p real vs shuffled"]
    lines = ["| " + " | ".join(head) + " |", "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for row in [*table["tasks"], table["overall"]]:
        chance = f"{100 * row['chance']:.1f}" if row.get("chance") is not None else "–"
        name = row["task"] if row["task"] != "Overall" else "**Overall** (items)"
        cells = [name, str(row["n"]), chance, *(_pct(row[m]) for m in MODES),
                 *(_p(row[f"real_vs_{m}"]) for m in CONTROLS)]
        lines.append("| " + " | ".join(cells) + " |")
    avg = table["average"]
    lines.append("| **Average** (tasks) | | | " + " | ".join(f"{100 * avg[m]:.1f}" for m in MODES) + " | | |")
    return "\n".join(lines) + "\n"


def _device(model: Any) -> str:
    import torch

    device = next(model.parameters()).device
    return torch.cuda.get_device_name(device) if device.type == "cuda" else str(device)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", type=Path, required=True, help="trained model directory (stage2/model)")
    parser.add_argument("--bench", type=Path, required=True, help="benchmark directory")
    parser.add_argument("--split", choices=("val", "test"), default="test")
    parser.add_argument("--out", type=Path, required=True, help="predictions and reports (resumable)")
    parser.add_argument("--limit", type=int, default=None, help="only the first N items (the shuffle draws from them)")
    parser.add_argument("--touch-seed", type=int, default=0, help="seed of the shuffled videos")
    parser.add_argument("--mode", default="strict", help="answer extraction: strict or lenient")
    parser.add_argument("--batch-size", type=int, default=32)
    parser.add_argument("--max-new-tokens", type=int, default=256)
    parser.add_argument("--video-cache", type=Path, default=None,
                        help="preprocessed-video cache shared by the three runs (default: <out>/video_cache)")
    parser.add_argument("--results-dir", type=Path, default=None, help="default: benchmarks/results")
    parser.add_argument("--name", default="touch_control", help="result file stem")
    args = parser.parse_args()
    if args.limit is not None and args.limit < 1:
        parser.error("--limit must be at least 1")

    from tacreasoner.evaluate.predict import TOUCH_MODES, load_trained, predict_items, predictions_path
    from tacreasoner.evaluate.report import evaluate, load_scored
    from tacreasoner.tasks.bench import load_bench
    from tacreasoner.train.data import bench_video_root

    assert tuple(TOUCH_MODES) == MODES, TOUCH_MODES
    info, items = load_bench(args.bench, args.split)
    items = items[:args.limit] if args.limit else items
    if not items:
        parser.error(f"{args.bench}: split {args.split!r} has no items")
    model, processor = load_trained(args.model)
    cache = args.video_cache or args.out / "video_cache"
    reports, records = {}, {}
    for touch in MODES:
        path = predictions_path(args.out, args.split, touch)
        predict_items(model, processor, items, bench_video_root(args.bench, info), path, batch_size=args.batch_size,
                      max_new_tokens=args.max_new_tokens, video_cache=cache, touch=touch, touch_seed=args.touch_seed)
        reports[touch] = evaluate(items, [path], args.mode, args.out / f"touch_{touch}")
        records[touch] = load_scored(reports[touch].files[f"scored:{path.stem}"])
        print(f"{touch}: Average {100 * reports[touch].average['value']:.1f}%", flush=True)

    table = touch_table(records)
    info_stamp = stamp()
    device = _device(model)
    md = header_md("Removed-touch control: real, blank and shuffled touch on the same items", info_stamp)
    md += (f"- Model: `{args.model}` (on {device})\n- Benchmark: `{args.bench}` ({info.get('name', '')}), split "
           f"**{args.split}**, {len(items)} items{' (--limit)' if args.limit else ''}; {args.mode} extraction; "
           f"shuffle seed {args.touch_seed}\n\n"
           "Cells: accuracy % [Wilson 95% CI]. Blank: every video replaced by a featureless clip (zeros after "
           "preprocessing, sensor ids kept). Shuffled: each item gets the videos of other items of the split (same "
           "number; where possible none of its own clips or objects). p: exact McNemar test of real against the "
           "control on the same items (bold when p < 0.05); ↓ items real answers right and the control wrong, ↑ the "
           "reverse. A task whose blank and shuffled accuracy stay at real's is answered without touch.\n\n")
    md += table_markdown(table)
    payload = {**info_stamp, "device": device, "model": str(args.model), "bench": str(args.bench),
               "split": args.split, "n_items": len(items), "limit": args.limit, "mode": args.mode,
               "touch_seed": args.touch_seed, "table": table,
               "predictions": {m: str(predictions_path(args.out, args.split, m)) for m in MODES},
               "reports": {m: reports[m].to_dict() for m in MODES}}
    publish(args.name, payload, md, args.results_dir)


if __name__ == "__main__":
    main()
