"""How much a val gap moves with which objects val happens to hold: a bootstrap over val objects (val only).

    python experiments/2026-12-01_imprint_recipe/bootstrap_val.py [--draws 2000]

Each draw resamples val's objects with replacement (an item goes with its first object, in both styles at once),
scores each seed's answers as the benchmark does (the mean over tasks of each task's share right), and takes the
gap (Mini − DIGIT) of both recipes and their difference on the same draw, averaged over the three seeds.
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict
from pathlib import Path

import numpy as np
from per_object_val import RUNS, val_items  # the same scored answers


def load(folder: str, prep: str, objects: list[str]) -> list[dict[str, np.ndarray]]:
    """Per seed and style: a tasks × objects array of [right, asked] counts."""
    items = val_items()
    index = {o: k for k, o in enumerate(objects)}
    tasks = sorted({t for t, _ in items.values()})
    seeds = []
    for seed in sorted(Path(folder).glob("seed*")):
        per_style = {}
        for split, style in (("val", "Mini"), ("val_heldout_sensor", "DIGIT")):
            counts = np.zeros((2, len(tasks), len(objects)))
            for line in (seed / f"{split}_{prep}" / "scored" / f"{split}.jsonl").read_text().splitlines():
                row = json.loads(line)
                task, obj = items[row["id"]]
                counts[0, tasks.index(task), index[obj]] += bool(row["correct"])
                counts[1, tasks.index(task), index[obj]] += 1
            per_style[style] = counts
        seeds.append(per_style)
    return seeds


def gap(seeds: list[dict[str, np.ndarray]], weights: np.ndarray) -> float:
    """Mean over seeds of Mini − DIGIT, each the mean over tasks of the share right, objects weighted."""
    out = []
    for per_style in seeds:
        avg = {}
        for style, counts in per_style.items():
            right, asked = counts[0] @ weights, counts[1] @ weights
            avg[style] = np.mean(right[asked > 0] / asked[asked > 0])
        out.append(avg["Mini"] - avg["DIGIT"])
    return 100 * float(np.mean(out))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--draws", type=int, default=2000)
    args = ap.parse_args()
    objects = sorted(o for o, s in json.loads(Path("runs/sens/bench/bench.json").read_text())["splits"].items()
                     if s == "val")
    runs = {name: load(folder, prep, objects) for name, (folder, prep) in RUNS.items()}
    rng = np.random.default_rng(0)
    draws = defaultdict(list)
    for _ in range(args.draws):
        weights = np.bincount(rng.integers(0, len(objects), len(objects)), minlength=len(objects)).astype(float)
        gaps = {name: gap(seeds, weights) for name, seeds in runs.items()}
        for name, value in gaps.items():
            draws[name].append(value)
        draws["control − candidate"].append(gaps["control (gate)"] - gaps["candidate (imprint)"])
    ones = np.ones(len(objects))
    print(f"{len(objects)} val objects, {args.draws} draws (seed 0)\n")
    print("| gap (Mini − DIGIT), val | as measured | 95% of draws within |\n|---|---|---|")
    measured = {name: gap(seeds, ones) for name, seeds in runs.items()}
    measured["control − candidate"] = measured["control (gate)"] - measured["candidate (imprint)"]
    for name, values in draws.items():
        lo, hi = np.percentile(values, [2.5, 97.5])
        print(f"| {name} | {measured[name]:.1f} | {lo:.1f} to {hi:.1f} |")


if __name__ == "__main__":
    main()
