"""Applies the rule of criteria.md (fixed before measuring) to the per-seed val records of the direct answers (A) and
the stepwise candidates (B, C).

    python experiments/2026-11-29_stepwise/decide.py runs/physiclear/eval_val/rec.seeds0-1-2 \\
        B=runs/physiclear/eval_val_stepwise/rec.seeds0-1-2 C=runs/physiclear/eval_val_stepwise/plain_know.seeds0-1-2 \\
        > experiments/2026-11-29_stepwise/decision.md

Each folder is an ``evaluate-physiclear`` output over the three seeds' models (``scored/<run>.jsonl`` per seed, in
seed order); the first is A.
"""

from __future__ import annotations

import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "2026-11-28_compact_reasoning"))
from decide import READING, REASONING, per_seed  # the same per-seed columns as the compact experiment's rule


def mean(acc: dict[str, float], columns: dict[str, str]) -> float:
    return statistics.fmean(acc[c] for c in columns)


def main() -> None:
    direct = per_seed(Path(sys.argv[1]))
    candidates = {arg.split("=", 1)[0]: per_seed(Path(arg.split("=", 1)[1])) for arg in sys.argv[2:]}
    for name, seeds in candidates.items():
        if len(seeds) != len(direct) or len(direct) < 3:
            raise SystemExit(f"need the same seeds (at least 3) for A and {name}: {len(direct)} and {len(seeds)}")
    lines = ["| seed | " + " | ".join(f"{n}: reasoning mean | {n}: reading mean" for n in ["A", *candidates]) + " |",
             "|---|" + "---|---|" * (1 + len(candidates))]
    for s in range(len(direct)):
        row = [direct[s], *(c[s] for c in candidates.values())]
        lines.append(f"| {s} | " + " | ".join(f"{100 * mean(r, REASONING):.1f} | {100 * mean(r, READING):.1f}"
                                              for r in row) + " |")
    reading_a = [mean(a, READING) for a in direct]
    passed: dict[str, list[float]] = {}
    for name, seeds in candidates.items():
        wins = sum(mean(c, REASONING) > mean(a, REASONING) for c, a in zip(seeds, direct, strict=True))
        reading_c = [mean(c, READING) for c in seeds]
        margin = max(statistics.stdev(reading_a), statistics.stdev(reading_c))
        kept = statistics.fmean(reading_c) >= statistics.fmean(reading_a) - margin
        lines += ["", f"**{name}** against A:",
                  f"1. Reasoning columns (PC, PSS, POM, PSR) higher in {wins} of {len(direct)} seed pairs: "
                  f"{'met' if wins == len(direct) else 'not met'}.",
                  f"2. Reading columns: {100 * statistics.fmean(reading_c):.1f} against A's "
                  f"{100 * statistics.fmean(reading_a):.1f}, allowed down to "
                  f"{100 * (statistics.fmean(reading_a) - margin):.1f} (the larger seed std, {100 * margin:.1f}): "
                  f"{'met' if kept else 'not met'}."]
        if wins == len(direct) and kept:
            passed[name] = [mean(c, REASONING) for c in seeds]
    if not passed:
        verdict = "direct answers stay"
    elif len(passed) == 1:
        verdict = f"{next(iter(passed))} answering stepwise is recommended"
    else:
        (b, rb), (c, rc) = list(passed.items())[:2]
        margin = max(statistics.stdev(rb), statistics.stdev(rc))
        better = statistics.fmean(rc) > statistics.fmean(rb) + margin
        lines += ["", f"Both pass: {c}'s reasoning mean {100 * statistics.fmean(rc):.1f} against {b}'s "
                  f"{100 * statistics.fmean(rb):.1f}, margin {100 * margin:.1f} (the larger seed std)."]
        verdict = f"{c if better else b} answering stepwise is recommended"
    lines += ["", f"**Verdict: {verdict}** (criteria.md)."]
    print("\n".join(lines))


if __name__ == "__main__":
    main()
