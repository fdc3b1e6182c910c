"""Statistics for benchmark reports: paired tests, seed spread, chance levels.

Benchmarks here are a few hundred items per task, so a point accuracy alone overstates what is known.
Reports carry a Wilson interval (``tacreasoner.intervals``, shared with training-time checks), the spread
over training seeds, and an exact McNemar test when two models answered the same items.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

from scipy.stats import binom

__all__ = ["McNemarResult", "chance_level", "mcnemar_exact", "mean_std", "paper_average"]


@dataclass(frozen=True)
class McNemarResult:
    """Paired comparison of two models on the same items.

    ``b01``: items A got wrong and B got right; ``b10``: A right, B wrong. ``p_value`` is the two-sided
    exact binomial test of ``b01`` vs ``b10`` (1.0 when there are no discordant pairs).
    """

    n: int
    b01: int
    b10: int
    p_value: float
    a_correct: int
    b_correct: int

    @property
    def n_discordant(self) -> int:
        return self.b01 + self.b10

    def to_dict(self) -> dict:
        return {"n": self.n, "b01": self.b01, "b10": self.b10, "n_discordant": self.n_discordant,
                "p_value": self.p_value, "a_correct": self.a_correct, "b_correct": self.b_correct}


def mcnemar_exact(a_correct: Sequence[bool], b_correct: Sequence[bool]) -> McNemarResult:
    """Exact McNemar test on paired per-item correctness (same items, same order)."""
    if len(a_correct) != len(b_correct):
        raise ValueError(f"paired test needs equal lengths, got {len(a_correct)} and {len(b_correct)}")
    a = [bool(x) for x in a_correct]
    b = [bool(x) for x in b_correct]
    b01 = sum(1 for x, y in zip(a, b, strict=True) if not x and y)
    b10 = sum(1 for x, y in zip(a, b, strict=True) if x and not y)
    m = b01 + b10
    p = 1.0 if m == 0 else min(1.0, 2.0 * float(binom.cdf(min(b01, b10), m, 0.5)))
    return McNemarResult(n=len(a), b01=b01, b10=b10, p_value=p, a_correct=sum(a), b_correct=sum(b))


def mean_std(values: Iterable[float]) -> tuple[float, float]:
    """Mean and sample standard deviation (ddof=1) over seeds; std is NaN for a single value."""
    xs = [float(v) for v in values]
    if not xs:
        raise ValueError("mean_std of no values")
    mean = sum(xs) / len(xs)
    if len(xs) == 1:
        return mean, math.nan
    var = sum((x - mean) ** 2 for x in xs) / (len(xs) - 1)
    return mean, math.sqrt(var)


def paper_average(per_task: Mapping[str, float]) -> float:
    """The papers' "Average" column: the unweighted mean of the task columns (not of all items).

    Tasks with many items do not dominate it, which is why it differs from overall item accuracy.
    """
    if not per_task:
        raise ValueError("paper_average needs at least one task")
    values = [float(v) for v in per_task.values()]
    bad = [t for t, v in per_task.items() if math.isnan(float(v))]
    if bad:
        raise ValueError(f"paper_average: no value for tasks {bad}")
    return sum(values) / len(values)


_CHANCE = {"SFD": 1 / 2, "PC": 1 / 3, "SOI": 1 / 3, "OSC": 1 / 6, "TSA": 1 / 2, "RFOR": 1 / 2}


def chance_level(task: str, n_options: int | None = None, n_attributes: int | None = None) -> float:
    """Accuracy of uniform guessing among valid answers.

    TFA-<attr>: 1/3 (three levels); TFA-combined: (1/3)^n_attributes (4 for VTV-150K, 3 for PhysiCLeAR;
    pass ``n_attributes``); SFD 1/2; PC 1/3 (more, less, similar); SOI 1/3; OSC 1/6 (permutations of three);
    TSA 1/2; RFOR 1/2; OCSE 1/n_options (the listed contact states).
    """
    if task == "TFA-combined":
        if not n_attributes or n_attributes < 1:
            raise ValueError("chance_level('TFA-combined') needs n_attributes >= 1")
        return (1 / 3) ** n_attributes
    if task.startswith("TFA-"):
        return 1 / 3
    if task == "OCSE":
        if not n_options or n_options < 1:
            raise ValueError("chance_level('OCSE') needs n_options >= 1")
        return 1 / n_options
    if task in _CHANCE:
        return _CHANCE[task]
    raise ValueError(f"no chance level for task {task!r}")
