"""Applies the rule of criteria.md (fixed before training) to the per-seed val records of plain (rec) and compact.

    python experiments/2026-11-28_compact_reasoning/decide.py runs/physiclear/eval_val/rec.seeds0-1-2 \\
        runs/physiclear/eval_val/compact.seeds0-1-2 > experiments/2026-11-28_compact_reasoning/decision.md

Each folder is an ``evaluate-physiclear`` output over the three seeds' models (``scored/<run>.jsonl`` per seed, in
seed order).
"""

from __future__ import annotations

import statistics
import sys
from pathlib import Path

from tacreasoner.evaluate.report import load_scored

READING = {"hardness": "TFA-hardness", "roughness": "TFA-roughness", "bumpiness": "TFA-bumpiness",
           "combined": "TFA-combined"}
REASONING = {"PC": "PC", "PSS": "SOI", "POM": "OSC", "PSR": "TSA"}


def per_seed(folder: Path) -> list[dict[str, float]]:
    out = []
    for path in sorted((folder / "scored").glob("*.jsonl")):
        records = load_scored(path)
        acc = {}
        for column, task in {**READING, **REASONING}.items():
            mine = [r for r in records if r["task"] == task]
            acc[column] = sum(bool(r["correct"]) for r in mine) / len(mine)
        out.append(acc)
    return out


def main() -> None:
    plain, compact = (per_seed(Path(a)) for a in sys.argv[1:3])
    if len(plain) != len(compact) or len(plain) < 3:
        raise SystemExit(f"need the same seeds (at least 3) for both: {len(plain)} plain, {len(compact)} compact")

    def mean(acc: dict[str, float], columns: dict[str, str]) -> float:
        return statistics.fmean(acc[c] for c in columns)

    lines = ["| seed | plain: reasoning mean | compact: reasoning mean | plain: reading mean | compact: reading mean |",
             "|---|---|---|---|---|"]
    wins = 0
    for s, (p, c) in enumerate(zip(plain, compact, strict=True)):
        wins += mean(c, REASONING) > mean(p, REASONING)
        lines.append(f"| {s} | {100 * mean(p, REASONING):.1f} | {100 * mean(c, REASONING):.1f} | "
                     f"{100 * mean(p, READING):.1f} | {100 * mean(c, READING):.1f} |")
    reading_p = [mean(p, READING) for p in plain]
    reading_c = [mean(c, READING) for c in compact]
    margin = max(statistics.stdev(reading_p), statistics.stdev(reading_c))
    kept = statistics.fmean(reading_c) >= statistics.fmean(reading_p) - margin
    rule1 = wins == len(plain)
    lines += ["", f"1. Reasoning columns (PC, PSS, POM, PSR) higher for compact in {wins} of {len(plain)} seed pairs: "
              f"{'met' if rule1 else 'not met'}.",
              "2. Reading columns (hardness, roughness, bumpiness, combined): compact "
              f"{100 * statistics.fmean(reading_c):.1f} against plain {100 * statistics.fmean(reading_p):.1f}, allowed "
              "down to "
              f"{100 * (statistics.fmean(reading_p) - margin):.1f} (the larger seed std, {100 * margin:.1f}): "
              f"{'met' if kept else 'not met'}.",
              "", f"**Verdict: {'compact becomes the recommended recipe' if rule1 and kept else 'plain answers stay'}**"
              " (criteria.md)."]
    print("\n".join(lines))


if __name__ == "__main__":
    main()
