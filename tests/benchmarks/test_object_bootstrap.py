"""The bootstrap over a split's objects that sensor-transfer pages report beside the seed spread."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

from _object_bootstrap import average, bootstrap, item_objects, scored_counts, seed_mean


def _write(path: Path, rows: list[dict]) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    return path


def test_counts_and_average_follow_the_benchmarks_mean_over_tasks(tmp_path: Path) -> None:
    _write(tmp_path / "val.jsonl", [{"id": "a", "task": "T1", "objects": ["x", "y"]},
                                    {"id": "b", "task": "T1", "objects": ["y"]},
                                    {"id": "c", "task": "T2", "objects": ["y"]}])
    items = item_objects(tmp_path, ["val"])
    assert items == {"a": ("T1", "x"), "b": ("T1", "y"), "c": ("T2", "y")}  # an item goes with its first object
    scored = _write(tmp_path / "scored.jsonl", [{"id": "a", "correct": True}, {"id": "b", "correct": False},
                                                {"id": "c", "correct": True}])
    counts = scored_counts(scored, items, ["T1", "T2"], ["x", "y"])
    assert counts.tolist() == [[[1, 0], [0, 1]], [[1, 1], [0, 1]]]
    assert average(counts, np.ones(2)) == pytest.approx(100 * (0.5 + 1.0) / 2)  # tasks weigh alike, not items
    assert average(counts, np.array([0.0, 2.0])) == pytest.approx(100 * (0.0 + 1.0) / 2)  # only y drawn


def test_intervals_are_wide_only_where_objects_differ_and_differences_are_paired() -> None:
    rng = np.random.default_rng(1)
    asked = np.ones((1, 40))
    same = np.stack([asked * 0.5, asked])  # every object half right: no draw can move it
    varied = np.stack([rng.integers(0, 2, (1, 40)).astype(float), asked])
    out = bootstrap({"same": seed_mean([same]), "varied": seed_mean([varied]),
                     "varied − varied": lambda w: seed_mean([varied])(w) - seed_mean([varied])(w)},
                    n_objects=40, draws=300)
    assert out["same"] == pytest.approx((50.0, 50.0, 50.0))
    measured, low, high = out["varied"]
    assert low < measured < high and high - low > 10  # 40 coin flips: about ±15 points
    assert out["varied − varied"] == (0.0, 0.0, 0.0)  # the same draws for every statistic
