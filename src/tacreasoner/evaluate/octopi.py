"""A report in Octopi's shape: PhysiCLeAR's columns (Yu et al., RSS 2024, Table 3) from a benchmark report.

Octopi reports property description per attribute, all three right for one clip (combined), property comparison
(PC), property superlative selection (PSS), property-object matching (POM) and zero-shot scenario reasoning (PSR)
on unseen objects. The project builds the same task set under its own names (docs/benchmark.md); this module only
renames and lays out the columns, so the numbers are the project scorer's, with their Wilson intervals.
"""

from __future__ import annotations

import math
from typing import Any

from tacreasoner.evaluate.report import Report

__all__ = ["OCTOPI_COLUMNS", "PUBLISHED", "octopi_markdown", "octopi_table"]

OCTOPI_COLUMNS: tuple[tuple[str, str], ...] = (
    ("hardness", "TFA-hardness"), ("roughness", "TFA-roughness"), ("bumpiness", "TFA-bumpiness"),
    ("combined", "TFA-combined"), ("PC", "PC"), ("PSS", "SOI"), ("POM", "OSC"), ("PSR", "TSA"),
)
"""Octopi's column → the project's task."""

PUBLISHED: dict[str, dict[str, float]] = {
    "Octopi CLIP encoder + classifier": {"hardness": 86.8, "roughness": 76.3, "bumpiness": 71.1, "combined": 57.9},
    "Octopi-13b": {"hardness": 73.7, "roughness": 79.0, "bumpiness": 79.0, "combined": 55.3, "PC": 55.1,
                   "PSS": 84.0, "POM": 60.4, "PSR": 67.4},
}
"""Published accuracies (%) on Octopi's unseen *test* objects (arXiv 2405.02794), for reference beside ours."""


def octopi_table(report: Report) -> dict[str, Any]:
    """Per Octopi column: n, accuracy, Wilson 95% interval, chance, parse failures (None where the task is absent)."""
    rows = {r.task: r for r in report.tasks}
    out: dict[str, Any] = {}
    for column, task in OCTOPI_COLUMNS:
        r = rows.get(task)
        out[column] = None if r is None else {
            "task": task, "n": r.n, "accuracy": r.accuracy, "ci_low": r.ci_low, "ci_high": r.ci_high,
            "chance": r.chance, "parse_failure_rate": r.parse_failure_rate, "std": r.std, "runs": len(r.per_run),
            "follows_rate": r.follows_rate}
    return out


def _cell(value: dict | None) -> str:
    if value is None:
        return "–"
    text = f"{100 * value['accuracy']:.1f} [{100 * value['ci_low']:.0f}–{100 * value['ci_high']:.0f}]"
    if value["runs"] > 1 and not math.isnan(value["std"]):
        text += f" ± {100 * value['std']:.1f}"
    return text


def _follows_cell(value: dict | None) -> str:
    rate = None if value is None else value.get("follows_rate")
    return "–" if rate is None or math.isnan(rate) else f"{100 * rate:.1f}"


def octopi_markdown(table: dict[str, Any], *, label: str, split: str) -> str:
    """The table with chance and Octopi's published rows beneath (their split is Octopi's test objects)."""
    columns = [c for c, _ in OCTOPI_COLUMNS]
    lines = [f"| model ({split}) | " + " | ".join(columns) + " |", "|---|" + "---|" * len(columns)]
    lines.append(f"| {label} | " + " | ".join(_cell(table[c]) for c in columns) + " |")
    lines.append("| replies in the asked form % | " + " | ".join(
        f"{100 * (1 - table[c]['parse_failure_rate']):.1f}" if table[c] else "–" for c in columns) + " |")
    lines.append("| answer follows from the levels it stated % | " + " | ".join(
        _follows_cell(table[c]) for c in columns) + " |")
    lines.append("| n items | " + " | ".join(str(table[c]["n"]) if table[c] else "–" for c in columns) + " |")
    lines.append("| chance | " + " | ".join(f"{100 * table[c]['chance']:.1f}" if table[c] else "–"
                                           for c in columns) + " |")
    for name, row in PUBLISHED.items():
        lines.append(f"| {name} (published, Octopi's test objects) | "
                     + " | ".join(f"{row[c]:.1f}" if c in row else "–" for c in columns) + " |")
    return "\n".join(lines) + ("\n\nAccuracy in % with the Wilson 95% interval over items (± std over runs when "
                               "several); the project's strict scorer; chance is uniform guessing among valid "
                               "answers. Replies in the asked form: the strict scorer could read an answer of the "
                               "asked kind (a level word of the asked property, a letter for PSR, ...). Follows: of "
                               "all replies, those whose answer is one the levels their reasoning stated imply (– "
                               "where no reply states levels). Octopi's task "
                               "names: PSS = SOI, POM = OSC, PSR = TSA here.\n")
