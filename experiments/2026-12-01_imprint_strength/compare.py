"""The imprint recipe's DIGIT answers on the larger val with and without the imprint gain, paired over objects.

    python experiments/2026-12-01_imprint_strength/compare.py [--draws 2000] > .../compare.md

Applies criteria.md's rule; the Mini figure (unchanged by the gain) is the larger val's, for the gap.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "benchmarks"))

from _object_bootstrap import average, bootstrap, item_objects, scored_counts, seed_mean  # noqa: E402

BENCH = REPO / "runs/sens300/bench"
PREP = "match+gel+imprint"
SEEDS = 3


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--draws", type=int, default=2000)
    args = ap.parse_args()
    items = item_objects(BENCH, ["val", "val_heldout_sensor"])
    objects = sorted({o for _, o in items.values()})
    tasks = sorted({t for t, _ in items.values()})

    def load(folder: str, split: str) -> list:
        return [scored_counts(REPO / folder.format(k=k) / "scored" / f"{split}.jsonl", items, tasks, objects)
                for k in range(SEEDS)]

    counts = {"Mini (imprint)": load(f"runs/swt/eval300/seed{{k}}/val_{PREP}", "val"),
              "DIGIT (imprint)": load(f"runs/swt/eval300/seed{{k}}/val_heldout_sensor_{PREP}", "val_heldout_sensor"),
              "DIGIT (imprint + gain)": load("runs/swt/eval300_gain/seed{k}/val_heldout_sensor",
                                             "val_heldout_sensor")}
    stats = {name: seed_mean(c) for name, c in counts.items()}
    stats["gap (imprint)"] = lambda w: stats["Mini (imprint)"](w) - stats["DIGIT (imprint)"](w)
    stats["gap (imprint + gain)"] = lambda w: stats["Mini (imprint)"](w) - stats["DIGIT (imprint + gain)"](w)
    stats["DIGIT: gain − none"] = lambda w: stats["DIGIT (imprint + gain)"](w) - stats["DIGIT (imprint)"](w)
    out = bootstrap(stats, len(objects), args.draws)
    print(f"Val of `runs/sens300/bench`: {len(objects)} objects; the imprint recipe's seeds 3–5; {args.draws} "
          "resamplings of the objects (seed 0), the same draws for every row.\n")
    print("| mean over seeds | as measured | 95% of draws within |\n|---|---|---|")
    for key, (value, lo, hi) in out.items():
        print(f"| {key} | {value:.1f} | {lo:.1f} to {hi:.1f} |")
    ones = [1.0] * len(objects)
    per_seed = {name: [average(c, ones) for c in seeds] for name, seeds in counts.items()}
    print("\n| seed | " + " | ".join(per_seed) + " |\n|---|" + "---|" * len(per_seed))
    for k in range(SEEDS):
        print(f"| {k + 3} | " + " | ".join(f"{v[k]:.1f}" for v in per_seed.values()) + " |")
    every = all(a > b for a, b in zip(per_seed["DIGIT (imprint + gain)"], per_seed["DIGIT (imprint)"], strict=True))
    lo = out["DIGIT: gain − none"][1]
    print(f"\nRule (criteria.md): DIGIT higher with the gain in every seed: {'yes' if every else 'no'}; paired range "
          f"above 0: {'yes' if lo > 0 else 'no'} → "
          f"{'adopted as the step for a new sensor' if every and lo > 0 else 'not adopted'}.")


if __name__ == "__main__":
    main()
