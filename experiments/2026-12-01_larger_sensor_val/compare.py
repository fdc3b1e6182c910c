"""The two recipes on the larger val, paired: each difference over the same resamplings of val's objects.

    python experiments/2026-12-01_larger_sensor_val/compare.py [--draws 2000] > experiments/.../compare.md

Reads the answers run.sh left (benchmarks/sensor_transfer.py's folders) and applies criteria.md's rule 1.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "benchmarks"))

from _object_bootstrap import average, bootstrap, item_objects, scored_counts, seed_mean  # noqa: E402

BENCH = REPO / "runs/sens300/bench"
RECIPES = {"candidate (imprint)": ("runs/swt/eval300", "match+gel+imprint"),
           "control (gate)": ("runs/mini_ctl/eval300", "match+gel+swap+gate")}
SEEDS = 3


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--draws", type=int, default=2000)
    args = ap.parse_args()
    items = item_objects(BENCH, ["val", "val_heldout_sensor"])
    objects = sorted({o for _, o in items.values()})
    tasks = sorted({t for t, _ in items.values()})
    counts = {}
    for name, (folder, prep) in RECIPES.items():
        for split, style in (("val", "Mini"), ("val_heldout_sensor", "DIGIT")):
            counts[name, style] = [scored_counts(REPO / folder / f"seed{k}" / f"{split}_{prep}" / "scored" /
                                                 f"{split}.jsonl", items, tasks, objects) for k in range(SEEDS)]
    stats = {}
    for name in RECIPES:
        mini, digit = seed_mean(counts[name, "Mini"]), seed_mean(counts[name, "DIGIT"])
        stats[f"{name}: Mini"] = mini
        stats[f"{name}: DIGIT"] = digit
        stats[f"{name}: gap"] = lambda w, a=mini, b=digit: a(w) - b(w)
    cand, ctl = RECIPES
    for style in ("Mini", "DIGIT", "gap"):
        stats[f"candidate − control: {style}"] = (lambda w, a=stats[f"{cand}: {style}"], b=stats[f"{ctl}: {style}"]:
                                                  a(w) - b(w))
    out = bootstrap(stats, len(objects), args.draws)
    print(f"Val of `runs/sens300/bench`: {len(objects)} objects, both styles, {len(tasks)} tasks; seeds 3–5 of each "
          f"recipe; {args.draws} resamplings of the objects (seed 0), the same draws for every row.\n")
    print("| mean over seeds | as measured | 95% of draws within |\n|---|---|---|")
    for key, (value, lo, hi) in out.items():
        print(f"| {key} | {value:.1f} | {lo:.1f} to {hi:.1f} |")
    ones = [1.0] * len(objects)
    per_seed = {key: [average(c, ones) for c in seeds] for key, seeds in counts.items()}
    print("\n| per seed (3, 4, 5) | " + " | ".join(f"{name}: {style}" for name, style in per_seed) + " |")
    print("|---|" + "---|" * len(per_seed))
    for k in range(SEEDS):
        print(f"| seed {k + 3} | " + " | ".join(f"{v[k]:.1f}" for v in per_seed.values()) + " |")
    digit_lo, digit_hi = out["candidate − control: DIGIT"][1:]
    mini_diff, mini_lo, mini_hi = out["candidate − control: Mini"]
    revert = digit_hi < 0 or (mini_diff < -1 and mini_hi < -1)
    gap = out[f"{cand}: gap"][0]
    print(f"\nRule 1 (criteria.md): candidate − control DIGIT range {digit_lo:.1f} to {digit_hi:.1f}, Mini "
          f"{mini_diff:+.1f} ({mini_lo:.1f} to {mini_hi:.1f}) → "
          f"{'the control is ahead: revert to the gate' if revert else 'the imprint recipe stays the default'}.")
    print(f"Rule 2: the candidate's gap on this val {gap:.1f} → issue 60's bar (≤ 5) "
          f"{'met' if gap <= 5 else 'not met'} on val.")


if __name__ == "__main__":
    main()
