"""Choose a recipe among candidates by their **val** scores only, and say which one won and why.

Each candidate is a name under one evaluation folder holding ``<name>/val/report.json`` (``tacreasoner evaluate
--split val`` output). The highest unweighted task average wins (the papers' convention). A candidate within
``tie_points`` of the best counts as tied, and among tied ones the earliest listed wins: list candidates from the
cheapest (fewest steps, smallest rank) so that a tie goes to the cheaper recipe. Test reports are never read.
``benchmarks/choose_on_val.py`` runs it from a shell (the winner's name on stdout).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = ["RecipeChoice", "choose", "choose_on_val", "val_average", "val_report"]


def val_report(eval_dir: Path, name: str) -> Path:
    """Where candidate ``name``'s val report is."""
    return Path(eval_dir) / name / "val" / "report.json"


def val_average(eval_dir: Path, name: str) -> float:
    """Candidate ``name``'s val task average (a fraction); ValueError when its report lacks one."""
    path = val_report(eval_dir, name)
    try:
        return float(json.loads(path.read_text(encoding="utf-8"))["average"]["value"])
    except (OSError, KeyError, TypeError, ValueError) as e:
        raise ValueError(f"{path}: no val report with average.value ({e})") from None


def choose(scores: dict[str, float], tie: float) -> str:
    """The earliest-listed candidate within ``tie`` (a fraction) of the best val average."""
    best = max(scores.values())
    return next(name for name, score in scores.items() if score >= best - tie)


@dataclass(frozen=True)
class RecipeChoice:
    """The candidates' val averages (in the order given), those without a val report, and the winner."""

    scores: dict[str, float]
    missing: list[str]
    winner: str
    tie_points: float

    def to_dict(self) -> dict[str, Any]:
        return {"split": "val", "candidates": self.scores, "missing": self.missing, "winner": self.winner,
                "tie_points": self.tie_points}


def choose_on_val(eval_dir: Path, candidates: Sequence[str], tie_points: float = 0.0) -> RecipeChoice:
    """Pick among ``candidates`` (cheapest first) by val average; ``tie_points`` in points of 100. Candidates without
    a val report are skipped (and listed); a report without an average is an error, as is no report at all."""
    available = [c for c in candidates if val_report(eval_dir, c).is_file()]
    if not available:
        raise ValueError(f"{eval_dir}: none of the candidates has a val report")
    scores = {name: val_average(eval_dir, name) for name in available}
    return RecipeChoice(scores=scores, missing=sorted(set(candidates) - set(available)),
                        winner=choose(scores, tie_points / 100), tie_points=tie_points)
