"""How far a split's figures move with which objects it happens to hold: a bootstrap over its objects.

A val split of a simulated benchmark holds 15 objects; a gap between two sensor styles measured on them moved by
5–8 points between val and test for every recipe tried (experiments/2026-12-01_imprint_recipe/bootstrap_val.md).
Seeds spread much less than that, so a rule weighing only the seed spread can choose on object sampling alone. Each
draw here resamples the objects with replacement (an item goes with its first object; both styles and every seed
share the draw) and scores each seed as the benchmark does: the unweighted mean over tasks of each task's share right.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import numpy as np

Counts = np.ndarray
"""``[2, tasks, objects]``: items answered right, items asked."""


def item_objects(bench: Path, splits: Sequence[str]) -> dict[str, tuple[str, str]]:
    """Every item of ``splits``: id → (task, its first object)."""
    items = {}
    for split in splits:
        for line in (bench / f"{split}.jsonl").read_text().splitlines():
            item = json.loads(line)
            items[item["id"]] = (item["task"], item["objects"][0])
    return items


def scored_counts(scored: Path, items: Mapping[str, tuple[str, str]], tasks: Sequence[str],
                  objects: Sequence[str]) -> Counts:
    """One evaluation's per-item decisions (``evaluate``'s ``scored/<split>.jsonl``) as task × object counts."""
    where = {o: k for k, o in enumerate(objects)}
    counts = np.zeros((2, len(tasks), len(objects)))
    for line in scored.read_text().splitlines():
        row = json.loads(line)
        task, obj = items[row["id"]]
        counts[0, tasks.index(task), where[obj]] += bool(row["correct"])
        counts[1, tasks.index(task), where[obj]] += 1
    return counts


def average(counts: Counts, weights: np.ndarray) -> float:
    """The benchmark's average (mean over tasks of the share right, in %) with objects weighted."""
    right, asked = counts[0] @ weights, counts[1] @ weights
    return 100 * float(np.mean(right[asked > 0] / asked[asked > 0]))


def bootstrap(statistics: Mapping[str, Callable[[np.ndarray], float]], n_objects: int, draws: int = 2000,
              seed: int = 0) -> dict[str, tuple[float, float, float]]:
    """Each statistic (a function of the objects' weights) as measured and its central 95% over ``draws``
    resamplings of the objects, all statistics on the same draws (so differences between them are paired)."""
    rng = np.random.default_rng(seed)
    values: dict[str, list[float]] = {name: [] for name in statistics}
    for _ in range(draws):
        weights = np.bincount(rng.integers(0, n_objects, n_objects), minlength=n_objects).astype(float)
        for name, statistic in statistics.items():
            values[name].append(statistic(weights))
    ones = np.ones(n_objects)
    out = {}
    for name, statistic in statistics.items():
        lo, hi = np.percentile(values[name], [2.5, 97.5])
        out[name] = (statistic(ones), float(lo), float(hi))
    return out


def seed_mean(per_seed: Sequence[Counts]) -> Callable[[np.ndarray], float]:
    """The mean over seeds of the average, as a function of the objects' weights."""
    return lambda weights: float(np.mean([average(c, weights) for c in per_seed]))
