"""The removed-touch control (Touch-R1's check): does a trained model answer from touch or from the text alone?

The same model answers the same items three times (``predict_items``' ``touch`` modes, ``tacreasoner evaluate
--touch``): with each item's real videos, with a blank clip in place of every video (the preprocessed form of a clip
that never changes: zeros, sensor ids kept), and with the videos of other items of the split (a seeded permutation of
all its video slots that, where possible, gives no item its own clip or a clip of its own object). Each run is scored
with the project's scorer; per task the table gives accuracy with a Wilson 95% interval, chance, and the exact McNemar
p-value of real against blank and against shuffled on the same items. A model that uses touch loses accuracy without
it; where blank or shuffled stays at real's level, that task is answered from the text.

``run_touch_control`` does the three runs (predictions resumable under its ``out`` folder:
``predictions/<split>[_<mode>].jsonl``, reports under ``touch_<mode>/``); ``touch_table`` and ``table_markdown`` make
the table from the scorer's per-item records. ``benchmarks/touch_control.py`` publishes a run as a result file.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = ["CONTROLS", "MODES", "TITLE", "TouchControl", "run_touch_control", "table_markdown", "touch_table"]

MODES = ("real", "blank", "shuffled")
"""The three runs; equal to ``tacreasoner.evaluate.predict.TOUCH_MODES`` (tested), here so the table needs no torch."""
CONTROLS = ("blank", "shuffled")
TITLE = "Removed-touch control: real, blank and shuffled touch on the same items"
"""The title of a published control (``benchmarks/touch_control.py``)."""


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


@dataclass
class TouchControl:
    """One model's control on one split: the table, where the predictions are, and each mode's full report."""

    model: Path
    bench: Path
    bench_name: str
    split: str
    n_items: int
    limit: int | None
    mode: str
    touch_seed: int
    device: str
    table: dict[str, Any]
    predictions: dict[str, Path]
    reports: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
        return {"device": self.device, "model": str(self.model), "bench": str(self.bench), "split": self.split,
                "n_items": self.n_items, "limit": self.limit, "mode": self.mode, "touch_seed": self.touch_seed,
                "table": self.table, "predictions": {m: str(p) for m, p in self.predictions.items()},
                "reports": {m: r.to_dict() for m, r in self.reports.items()}}

    def markdown(self) -> str:
        """What was run and how to read it, then the table (no title: the publisher heads it)."""
        return (f"- Model: `{self.model}` (on {self.device})\n- Benchmark: `{self.bench}` ({self.bench_name}), split "
                f"**{self.split}**, {self.n_items} items{' (--limit)' if self.limit else ''}; {self.mode} extraction; "
                f"shuffle seed {self.touch_seed}\n\n"
                "Cells: accuracy % [Wilson 95% CI]. Blank: every video replaced by a featureless clip (zeros after "
                "preprocessing, sensor ids kept). Shuffled: each item gets the videos of other items of the split "
                "(same number; where possible none of its own clips or objects). p: exact McNemar test of real "
                "against the control on the same items (bold when p < 0.05); ↓ items real answers right and the "
                "control wrong, ↑ the reverse. A task whose blank and shuffled accuracy stay at real's is answered "
                "without touch.\n\n" + table_markdown(self.table))


def _device(model: Any) -> str:
    import torch

    device = next(model.parameters()).device
    return torch.cuda.get_device_name(device) if device.type == "cuda" else str(device)


def run_touch_control(model_dir: Path, bench: Path, split: str, out: Path, *, limit: int | None = None,
                      touch_seed: int = 0, mode: str = "strict", batch_size: int = 32, max_new_tokens: int = 512,
                      video_cache: Path | None = None, device: str | None = None,
                      say: Callable[[str], None] = print) -> TouchControl:
    """Answer ``split``'s items (the first ``limit``; the shuffle draws from them) with real, blank and shuffled
    touch, score each run and make the table. Predictions resume under ``out``; the three runs share one video cache
    (default ``out/video_cache``)."""
    from tacreasoner.evaluate.predict import cut_warning, load_trained, predict_items, predictions_path
    from tacreasoner.evaluate.report import evaluate, load_scored
    from tacreasoner.tasks.bench import load_bench
    from tacreasoner.train.data import bench_video_root

    if limit is not None and limit < 1:
        raise ValueError(f"limit must be at least 1, got {limit}")
    info, items = load_bench(bench, split)
    items = items[:limit] if limit else items
    if not items:
        raise ValueError(f"{bench}: split {split!r} has no items")
    model, processor = load_trained(model_dir, device=device)
    cache = video_cache or out / "video_cache"
    reports, records, paths = {}, {}, {}
    for touch in MODES:
        path = paths[touch] = predictions_path(out, split, touch)
        predict_items(model, processor, items, bench_video_root(bench, info), path, batch_size=batch_size,
                      max_new_tokens=max_new_tokens, video_cache=cache, touch=touch, touch_seed=touch_seed)
        if (warning := cut_warning(path, max_new_tokens)) is not None:
            say(warning)
        reports[touch] = evaluate(items, [path], mode, out / f"touch_{touch}")
        records[touch] = load_scored(reports[touch].files[f"scored:{path.stem}"])
        say(f"{touch}: Average {100 * reports[touch].average['value']:.1f}%")
    return TouchControl(model=model_dir, bench=bench, bench_name=info.get("name", ""), split=split,
                        n_items=len(items), limit=limit, mode=mode, touch_seed=touch_seed, device=_device(model),
                        table=touch_table(records), predictions=paths, reports=reports)
