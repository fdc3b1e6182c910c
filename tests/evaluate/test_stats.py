"""Tests for report statistics against hand-computed values."""

from __future__ import annotations

import math
from math import comb

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.stats import binomtest

from tacreasoner.evaluate.stats import chance_level, mcnemar_exact, mean_std, paper_average
from tacreasoner.intervals import wilson_interval


def test_wilson_known_values() -> None:
    lo, hi = wilson_interval(8, 10)
    assert (round(lo, 3), round(hi, 3)) == (0.490, 0.943)
    assert lo == pytest.approx(0.4902, abs=1e-4) and hi == pytest.approx(0.9434, abs=1e-4)
    lo, hi = wilson_interval(0, 10)
    assert lo == 0.0 and hi == pytest.approx(0.2775, abs=1e-4)
    lo, hi = wilson_interval(10, 10)
    assert lo == pytest.approx(0.7225, abs=1e-4) and hi == 1.0
    assert wilson_interval(0, 0) == (0.0, 1.0)


@given(st.integers(1, 500).flatmap(lambda n: st.tuples(st.integers(0, n), st.just(n))))
def test_wilson_matches_scipy_and_is_symmetric(kn: tuple[int, int]) -> None:
    k, n = kn
    lo, hi = wilson_interval(k, n)
    ref = binomtest(k, n).proportion_ci(confidence_level=0.95, method="wilson")
    assert lo == pytest.approx(ref.low, abs=1e-3) and hi == pytest.approx(ref.high, abs=1e-3)
    assert lo <= k / n <= hi
    lo2, hi2 = wilson_interval(n - k, n)
    assert lo == pytest.approx(1 - hi2) and hi == pytest.approx(1 - lo2)


def test_wilson_rejects_bad_counts() -> None:
    with pytest.raises(ValueError):
        wilson_interval(11, 10)
    with pytest.raises(ValueError):
        wilson_interval(-1, 10)


def test_mcnemar_hand_computed() -> None:
    # 7 discordant pairs: A wrong/B right once, A right/B wrong six times; 5 concordant.
    a = [False] + [True] * 6 + [True, True, False, False, True]
    b = [True] + [False] * 6 + [True, True, False, False, True]
    r = mcnemar_exact(a, b)
    assert (r.b01, r.b10, r.n_discordant, r.n) == (1, 6, 7, 12)
    assert r.p_value == pytest.approx(2 * (comb(7, 0) + comb(7, 1)) / 2**7)  # = 0.125
    assert (r.a_correct, r.b_correct) == (9, 4)
    assert mcnemar_exact(b, a).p_value == pytest.approx(r.p_value)
    assert mcnemar_exact([True] * 5, [False] * 5).p_value == pytest.approx(2 / 32)
    balanced = mcnemar_exact([True, True, True, False, False, False], [False, False, False, True, True, True])
    assert balanced.p_value == 1.0


def test_mcnemar_identical_and_errors() -> None:
    r = mcnemar_exact([True, False, True], [True, False, True])
    assert (r.b01, r.b10, r.p_value) == (0, 0, 1.0)
    with pytest.raises(ValueError, match="equal lengths"):
        mcnemar_exact([True], [True, False])


def test_mean_std() -> None:
    mean, std = mean_std([0.60, 0.64, 0.62])
    assert mean == pytest.approx(0.62)
    assert std == pytest.approx(0.02)  # sample std (ddof=1): sqrt((0.02² + 0.02²) / 2)
    assert std == pytest.approx(np.std([0.60, 0.64, 0.62], ddof=1))
    one = mean_std([0.7])
    assert one[0] == 0.7 and math.isnan(one[1])
    with pytest.raises(ValueError):
        mean_std([])


def test_paper_average_reproduces_a_table_row() -> None:
    # A made-up Table-1-style row (percent): Hardness, Protrusion, Elasticity, Friction, Combined, SFD, SOI, OSC, TSA.
    row = {"Hardness": 65.3, "Protrusion": 58.7, "Elasticity": 61.2, "Friction": 55.9, "Combined": 30.4,
           "SFD": 72.1, "SOI": 60.0, "OSC": 45.5, "TSA": 68.8}
    avg = paper_average(row)
    assert avg == pytest.approx(517.9 / 9)  # 57.5444…
    assert round(avg, 1) == 57.5
    assert round(paper_average({"a": 57.5, "b": 57.62}), 1) == 57.6  # 57.56 rounds up, as in the tables
    assert paper_average({"a": 0.5, "b": 1.0}) == 0.75  # unit-agnostic: fractions work the same
    with pytest.raises(ValueError):
        paper_average({})
    with pytest.raises(ValueError, match="b"):
        paper_average({"a": 0.5, "b": float("nan")})


def test_paper_average_is_not_item_weighted() -> None:
    # 90/100 on one task and 1/10 on another: the paper's Average is 50%, item accuracy 91/110.
    assert paper_average({"big": 0.9, "small": 0.1}) == pytest.approx(0.5)


@pytest.mark.parametrize(("task", "kwargs", "expected"), [
    ("TFA-hardness", {}, 1 / 3), ("TFA-bumpiness", {}, 1 / 3), ("TFA-combined", {"n_attributes": 4}, 1 / 81),
    ("TFA-combined", {"n_attributes": 3}, 1 / 27), ("SFD", {}, 0.5), ("PC", {}, 1 / 3), ("SOI", {}, 1 / 3),
    ("OSC", {}, 1 / 6),
    ("TSA", {}, 0.5), ("RFOR", {}, 0.5), ("OCSE", {"n_options": 5}, 0.2), ("OCSE", {"n_options": 3}, 1 / 3),
])
def test_chance_level(task: str, kwargs: dict, expected: float) -> None:
    assert chance_level(task, **kwargs) == pytest.approx(expected)


def test_chance_level_errors() -> None:
    for task in ("TFA-combined", "OCSE", "NOPE"):
        with pytest.raises(ValueError):
            chance_level(task)
