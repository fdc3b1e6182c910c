"""Benchmark reports: score prediction files, summarise per task with honest uncertainty, compare models.

Inputs are prediction files (JSONL, one line per item: ``{"id": ..., "prediction": "<think>…</think>
<answer>…</answer>"}``, extra keys kept), one file per training seed. :func:`evaluate` scores each file
against the items, keeps the per-item records (``scored/<run>.jsonl``) and writes ``report.md``,
``report.csv``, ``report.json`` and ``report.png``. :func:`report_from_scored` rebuilds a report from
kept records alone. :func:`compare_runs` is the paired McNemar test between two models' records.

Numbers: per task, accuracy (the mean over runs), a Wilson 95% interval for item sampling (at the
mean correct count when there are several runs), mean ± sample std over runs (seed spread),
the hallucination rate (replies whose reasoning names an object the question does not, or concludes
otherwise than its own answer, among the checkable ones: :mod:`tacreasoner.tasks.consistency`), the
parse-failure rate and the chance level; plus the papers' "Average" (unweighted mean of the task
columns), the overall item accuracy and the overall hallucination rate. JSON and CSV hold fractions;
Markdown and the plot show percentages with one decimal, as the papers' tables do.
"""

from __future__ import annotations

import csv
import json
import math
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

from tacreasoner.evaluate.stats import (
    McNemarResult,
    chance_level,
    mcnemar_exact,
    mean_std,
    paper_average,
)
from tacreasoner.intervals import wilson_interval
from tacreasoner.jsonl import iter_jsonl, write_jsonl
from tacreasoner.tasks.conclude import REASONED_TASKS
from tacreasoner.tasks.conclude import consistency as conclusion_consistency
from tacreasoner.tasks.consistency import ObjectVocabulary, check_reasoning, object_vocabulary
from tacreasoner.tasks.everyday_objects import everyday_object_names
from tacreasoner.tasks.extract import MODES, Mode
from tacreasoner.tasks.schema import CONTACT_STATES, TASKS, QAItem
from tacreasoner.tasks.scoring import check_gold, score_predictions

__all__ = [
    "Comparison",
    "Report",
    "TaskRow",
    "compare_runs",
    "evaluate",
    "item_chance",
    "load_predictions",
    "load_scored",
    "object_names",
    "plot_report",
    "report_from_scored",
    "summarize",
    "write_comparison",
    "write_report",
]

_RECORD_KEYS = ("id", "task", "correct", "parse_failed")


# -------------------------------------------------------------------------------------------------- files


def load_predictions(path: str | Path) -> dict[str, dict]:
    """Prediction records by item id, in file order; each keeps its extra keys.

    Every line needs a string ``id`` and a string ``prediction``; ids must be unique.
    """
    out: dict[str, dict] = {}
    first_line: dict[str, int] = {}
    for lineno, obj in iter_jsonl(path):
        for key in ("id", "prediction"):
            if key not in obj:
                raise ValueError(f"{path}:{lineno}: missing field {key!r} (line has {sorted(obj)})")
            if not isinstance(obj[key], str):
                raise ValueError(f"{path}:{lineno}: field {key!r} must be a string, got {type(obj[key]).__name__}")
        item_id = obj["id"]
        if item_id in out:
            raise ValueError(f"{path}:{lineno}: duplicate id {item_id!r} (first on line {first_line[item_id]})")
        first_line[item_id] = lineno
        out[item_id] = obj
    return out


def load_scored(path: str | Path) -> list[dict]:
    """Per-item score records written by :func:`evaluate` (``scored/<run>.jsonl``)."""
    records = []
    for lineno, obj in iter_jsonl(path):
        missing = [k for k in _RECORD_KEYS if k not in obj]
        if missing:
            raise ValueError(f"{path}:{lineno}: score record lacks fields {missing}")
        records.append(obj)
    return records


# ------------------------------------------------------------------------------------------------ summary


def item_chance(item: QAItem) -> float:
    """Chance accuracy of one item (OCSE counts its listed states; combined counts its attributes)."""
    if item.task == "TFA-combined":
        return chance_level(item.task, n_attributes=len(item.gold.get("levels", {})) or None)
    if item.task == "OCSE":
        return chance_level(item.task, n_options=len(item.options) or len(CONTACT_STATES))
    return chance_level(item.task)


def _task_order(tasks: Iterable[str]) -> list[str]:
    rank = {t: i for i, t in enumerate(TASKS)}
    return sorted(set(tasks), key=lambda t: (rank.get(t, len(rank)), t))


@dataclass
class TaskRow:
    """One task's line of the report; rates are fractions."""

    task: str
    n: int
    accuracy: float
    ci_low: float
    ci_high: float
    mean: float
    std: float
    parse_failure_rate: float
    chance: float
    per_run: list[float]
    hallucination_rate: float = math.nan
    """Flagged / checkable replies, pooled over runs; NaN when none is checkable (e.g. records from before)."""
    n_checkable: int = 0
    """Checkable replies, summed over runs (at most n × runs)."""
    n_hallucinated: int = 0
    """Flagged replies, summed over runs."""
    hallucination_per_run: list[float] = field(default_factory=list)
    n_stated: int = 0
    """Multi-object tasks: replies whose reasoning states every video's needed levels, summed over runs."""
    n_follows: int = 0
    """Replies whose answer is one their own stated levels imply (``tasks.conclude``), summed over runs."""
    follows_rate: float = math.nan
    """n_follows / replies (n × runs): a reply stating no levels does not count as following; NaN when no reply of
    the task stated levels (plain answers, single-clip tasks)."""


@dataclass
class Report:
    mode: str
    runs: list[str]
    tasks: list[TaskRow]
    average: dict[str, Any]
    """The papers' Average: ``value`` (mean over runs), ``std``, ``per_run``."""
    overall: dict[str, Any]
    """Item-level accuracy over all tasks: ``accuracy``, ``std``, ``per_run``, ``n``; and the hallucination rate
    pooled over tasks and runs: ``hallucination_rate``, ``n_checkable``, ``n_hallucinated``."""
    missing: dict[str, list[str]] = field(default_factory=dict)
    """Run → ids of items with no prediction (scored wrong + parse failure)."""
    unknown_ids: dict[str, int] = field(default_factory=dict)
    """Run → number of predictions whose id is not a benchmark item (ignored)."""
    sources: dict[str, int] = field(default_factory=dict)
    files: dict[str, str] = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {"mode": self.mode, "runs": self.runs, "n_runs": len(self.runs),
                "tasks": [_json_safe(vars(r)) for r in self.tasks], "average": _json_safe(self.average),
                "overall": _json_safe(self.overall), "missing": self.missing, "unknown_ids": self.unknown_ids,
                "sources": self.sources, "files": self.files}

    def to_markdown(self) -> str:
        multi = len(self.runs) > 1
        n_items = self.overall["n"]
        lines = ["# Benchmark report", "",
                 f"Extraction: **{self.mode}** · runs: {len(self.runs)} ({', '.join(self.runs)}) · items: {n_items}"]
        if "sim" in self.sources:
            lines += ["", "Simulated items (DynTAC-Sim-Bench) are the project's stand-in, "
                      "not the paper's DynTAC-Bench."]
        lines += ["", "Accuracy in %; 95% CI is the Wilson interval over items"
                  + (" at the mean correct count; mean ± std is over runs (sample std)." if multi else ".")
                  + " Unparseable answers count as wrong. Halluc. % = replies whose reasoning names an object "
                  "the question does not mention or concludes otherwise than its own answer, among the checkable "
                  "ones (Checked" + (", pooled over runs" if multi else "") + "; docs/benchmark.md). Follows % = "
                  "replies of a multi-object task whose answer is one the levels their reasoning stated imply, among "
                  "all its replies (– when none stated levels).", ""]
        head = (["Task", "n", "Accuracy", "95% CI"] + (["Mean ± std"] if multi else [])
                + ["Halluc. %", "Checked", "Follows %", "Parse fail", "Chance"])
        lines += ["| " + " | ".join(head) + " |", "|" + "|".join(["---"] + ["---:"] * (len(head) - 1)) + "|"]
        for r in self.tasks:
            cells = [r.task, str(r.n), _pct(r.accuracy), f"{_pct(r.ci_low)}–{_pct(r.ci_high)}"]
            cells += [_pm(r.mean, r.std)] if multi else []
            cells += [_pct(r.hallucination_rate), f"{r.n_checkable}/{r.n * len(self.runs)}", _pct(r.follows_rate)]
            cells += [_pct(r.parse_failure_rate), _pct(r.chance)]
            lines.append("| " + " | ".join(cells) + " |")
        avg = ["**Average**", "", f"**{_pct(self.average['value'])}**", ""]
        avg += [_pm(self.average["value"], self.average["std"])] if multi else []
        lines.append("| " + " | ".join([*avg, "", "", "", "", ""]) + " |")
        n_checkable = self.overall.get("n_checkable", 0)
        lines += ["", "Average = unweighted mean of the task columns (the papers' convention); "
                  f"overall item accuracy = {_pct(self.overall['accuracy'])}%"
                  + (f" ± {_pct(self.overall['std'])}" if multi else "") + "; overall hallucination = "
                  + (f"{_pct(self.overall['hallucination_rate'])}% of {n_checkable} checkable replies."
                     if n_checkable else "– (no checkable replies).")]
        for run, ids in self.missing.items():
            if ids:
                shown = ", ".join(ids[:10]) + (" …" if len(ids) > 10 else "")
                lines.append(f"\n**{run}: {len(ids)} item(s) had no prediction** (scored wrong): {shown}")
        for run, count in self.unknown_ids.items():
            if count:
                lines.append(f"\n{run}: {count} prediction(s) for ids not in the benchmark were ignored.")
        return "\n".join(lines) + "\n"


def _pct(x: float | None) -> str:
    return "–" if x is None or math.isnan(x) else f"{100 * x:.1f}"


def _pm(mean: float, std: float) -> str:
    return f"{_pct(mean)} ± {_pct(std)}"


def _json_safe(obj: Any) -> Any:
    """NaN → None so the JSON is standard."""
    if isinstance(obj, float) and math.isnan(obj):
        return None
    if isinstance(obj, dict):
        return {k: _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_json_safe(v) for v in obj]
    return obj


def _index(records: Sequence[dict], name: str) -> dict[str, dict]:
    out: dict[str, dict] = {}
    for r in records:
        missing = [k for k in _RECORD_KEYS if k not in r]
        if missing:
            raise ValueError(f"{name}: score record {r.get('id', '?')!r} lacks fields {missing}")
        if r["id"] in out:
            raise ValueError(f"{name}: duplicate item id {r['id']!r}")
        out[r["id"]] = r
    return out


def _same_items(a: Mapping[str, dict], b: Mapping[str, dict], a_name: str, b_name: str) -> None:
    only_a, only_b = sorted(set(a) - set(b)), sorted(set(b) - set(a))
    if only_a or only_b:
        raise ValueError(f"item sets differ: {a_name} has {len(a)} items, {b_name} has {len(b)}; "
                         f"{len(only_a)} only in {a_name} {only_a[:5]}, {len(only_b)} only in {b_name} {only_b[:5]}")
    wrong_task = [i for i in a if a[i]["task"] != b[i]["task"]]
    if wrong_task:
        i = wrong_task[0]
        raise ValueError(f"{len(wrong_task)} item(s) have different tasks in {a_name} and {b_name}, "
                         f"e.g. {i!r}: {a[i]['task']} vs {b[i]['task']}")


def summarize(runs: Mapping[str, Sequence[dict]], mode: str | None = None) -> Report:
    """Report from per-item score records, one list per run (seed); all runs must cover the same items."""
    if not runs:
        raise ValueError("summarize needs at least one run")
    names = list(runs)
    indexed = {name: _index(recs, name) for name, recs in runs.items()}
    if not indexed[names[0]]:
        raise ValueError(f"{names[0]}: no score records")
    for name in names[1:]:
        _same_items(indexed[names[0]], indexed[name], names[0], name)
    modes = {r.get("mode") for recs in runs.values() for r in recs} - {None}
    if len(modes) > 1:
        raise ValueError(f"runs were scored with different extraction modes: {sorted(modes)}")
    mode = mode or (modes.pop() if modes else "unknown")

    first = indexed[names[0]]
    tasks = _task_order(r["task"] for r in first.values())
    rows: list[TaskRow] = []
    per_run_task: dict[str, dict[str, float]] = {name: {} for name in names}
    for task in tasks:
        ids = [i for i, r in first.items() if r["task"] == task]
        n = len(ids)
        correct = [sum(bool(indexed[name][i]["correct"]) for i in ids) for name in names]
        failures = sum(bool(indexed[name][i]["parse_failed"]) for name in names for i in ids)
        per_run = [k / n for k in correct]
        for name, acc in zip(names, per_run, strict=True):
            per_run_task[name][task] = acc
        mean, std = mean_std(per_run)
        lo, hi = wilson_interval(sum(correct) / len(names), n)
        chances = [first[i].get("chance") for i in ids]
        chance = (sum(chances) / n) if all(c is not None for c in chances) else _task_chance(task)
        flags = {name: [indexed[name][i].get("hallucinated") for i in ids] for name in names}
        n_checkable, n_flagged, halluc_rate = _hallucination([f for name in names for f in flags[name]])
        follows = [indexed[name][i].get("follows") for name in names for i in ids]
        n_stated, n_follows = sum(f is not None for f in follows), sum(f is True for f in follows)
        rows.append(TaskRow(task=task, n=n, accuracy=mean, ci_low=lo, ci_high=hi, mean=mean, std=std,
                            parse_failure_rate=failures / (n * len(names)), chance=chance, per_run=per_run,
                            hallucination_rate=halluc_rate, n_checkable=n_checkable, n_hallucinated=n_flagged,
                            hallucination_per_run=[_hallucination(flags[name])[2] for name in names],
                            n_stated=n_stated, n_follows=n_follows,
                            follows_rate=n_follows / (n * len(names)) if n_stated else math.nan))
    averages = [paper_average(per_run_task[name]) for name in names]
    avg_mean, avg_std = mean_std(averages)
    overall_runs = [sum(bool(r["correct"]) for r in indexed[name].values()) / len(first) for name in names]
    ov_mean, ov_std = mean_std(overall_runs)
    ov_checkable, ov_flagged, ov_halluc = _hallucination(
        [r.get("hallucinated") for name in names for r in indexed[name].values()])
    missing = {name: [r["id"] for r in runs[name] if r.get("missing")] for name in names}
    sources = dict(Counter(r.get("source") or "unknown" for r in first.values()))
    return Report(mode=mode, runs=names, tasks=rows,
                  average={"value": avg_mean, "std": avg_std, "per_run": averages},
                  overall={"accuracy": ov_mean, "std": ov_std, "per_run": overall_runs, "n": len(first),
                           "hallucination_rate": ov_halluc, "n_checkable": ov_checkable, "n_hallucinated": ov_flagged},
                  missing=missing, sources=sources)


def _hallucination(flags: Sequence[bool | None]) -> tuple[int, int, float]:
    """(checkable, flagged, flagged / checkable) of per-reply flags; None (not checkable, or a record written
    before the check existed) stays out of the denominator, and the rate is NaN when nothing is checkable."""
    checkable = [bool(f) for f in flags if f is not None]
    flagged = sum(checkable)
    return len(checkable), flagged, (flagged / len(checkable)) if checkable else math.nan


def _follows(item: QAItem, prediction: str | None) -> bool | None:
    """Does a multi-object reply's answer follow from the levels it stated? None: not such a task, no reply, or no
    levels stated (``tasks.conclude.consistency``)."""
    if prediction is None or item.task not in REASONED_TASKS:
        return None
    status = conclusion_consistency(item, prediction).status
    return None if status == "no levels" else status == "consistent"


def _task_chance(task: str) -> float:
    try:
        return chance_level(task)
    except ValueError:
        return math.nan


# ---------------------------------------------------------------------------------------------- writing


def plot_report(report: Report, path: str | Path) -> Path:
    """Bar chart of accuracy per task with Wilson 95% error bars and a chance marker per bar."""
    from matplotlib.figure import Figure  # Figure + savefig renders with Agg; no pyplot, no global backend

    path = Path(path)
    labels = [r.task for r in report.tasks] + ["Average"]
    acc = [100 * r.accuracy for r in report.tasks] + [100 * report.average["value"]]
    lo = [100 * (r.accuracy - r.ci_low) for r in report.tasks]
    hi = [100 * (r.ci_high - r.accuracy) for r in report.tasks]
    avg_std = report.average["std"]
    avg_err = 0.0 if math.isnan(avg_std) else 100 * avg_std
    x = list(range(len(labels)))
    fig = Figure(figsize=(max(6.0, 0.8 * len(labels) + 2), 4.2), layout="constrained")
    ax = fig.add_subplot()
    colors = ["#4C78A8"] * len(report.tasks) + ["#9D755D"]
    ax.bar(x, acc, color=colors, yerr=[[*lo, avg_err], [*hi, avg_err]], capsize=3, ecolor="black", zorder=2)
    for i, r in enumerate(report.tasks):
        if not math.isnan(r.chance):
            ax.hlines(100 * r.chance, i - 0.4, i + 0.4, colors="#E45756", linestyles="--", zorder=3,
                      label="chance" if i == 0 else None)
        if len(report.runs) > 1:
            ax.scatter([i + 0.2] * len(r.per_run), [100 * a for a in r.per_run], s=12, color="white",
                       edgecolors="black", linewidths=0.8, zorder=4, label="runs" if i == 0 else None)
    ax.set_xticks(x, labels, rotation=35, ha="right")
    ax.set_ylim(0, 105)
    ax.set_ylabel("accuracy (%)")
    err = "Wilson 95% CI" + ("; Average: ± std over runs" if len(report.runs) > 1 else "")
    ax.set_title(f"Accuracy per task ({report.mode} extraction, {len(report.runs)} run(s); {err})", fontsize=9)
    ax.grid(axis="y", alpha=0.3, zorder=0)
    ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=8)
    fig.savefig(path, dpi=120)
    return path


def write_report(report: Report, out_dir: str | Path, stem: str = "report") -> dict[str, Path]:
    """Write ``<stem>.md``, ``.csv``, ``.json`` and ``.png`` into ``out_dir``; returns their paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {ext: out / f"{stem}.{ext}" for ext in ("md", "csv", "json", "png")}
    report.files.update({ext: str(p) for ext, p in paths.items()})
    paths["md"].write_text(report.to_markdown(), encoding="utf-8")
    with paths["csv"].open("w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(["task", "n", "n_runs", "accuracy", "ci_low", "ci_high", "mean", "std", "hallucination_rate",
                    "n_checkable", "n_hallucinated", "parse_failure_rate", "chance", "per_run"])
        for r in report.tasks:
            w.writerow([r.task, r.n, len(report.runs), _num(r.accuracy), _num(r.ci_low), _num(r.ci_high),
                        _num(r.mean), _num(r.std), _num(r.hallucination_rate), r.n_checkable, r.n_hallucinated,
                        _num(r.parse_failure_rate), _num(r.chance), ";".join(_num(a) for a in r.per_run)])
        avg = report.average
        w.writerow(["Average", "", len(report.runs), _num(avg["value"]), "", "", _num(avg["value"]), _num(avg["std"]),
                    "", "", "", "", "", ";".join(_num(a) for a in avg["per_run"])])
    paths["json"].write_text(json.dumps(report.to_dict(), indent=2, ensure_ascii=False) + "\n", encoding="utf-8")
    plot_report(report, paths["png"])
    return paths


def _num(x: float) -> str:
    return "" if math.isnan(x) else f"{x:.6g}"


def _run_names(paths: Sequence[Path]) -> list[str]:
    stems = [p.stem for p in paths]
    if len(set(stems)) == len(stems):
        return stems
    return [f"{i}_{s}" for i, s in enumerate(stems)]


@lru_cache(maxsize=1)
def object_names() -> tuple[frozenset[str], ...]:
    """Known objects for the hallucination check: the simulator catalogue plus the everyday objects of
    ``tasks/everyday_objects.yaml``, which the commonsense corpus teaches (a model trained on it is most likely
    to bring them in)."""
    return object_vocabulary(everyday_object_names())


def evaluate(items: Sequence[QAItem], prediction_paths: Sequence[str | Path], mode: Mode | str = "strict",
             out_dir: str | Path = "eval", objects: ObjectVocabulary | None = None) -> Report:
    """Score each prediction file (one per seed) against ``items`` and write the report and per-item records.

    Before scoring, every item's gold answer text is checked against its gold values (a mismatch is a
    builder bug and would make the benchmark unanswerable). Each record also gets ``hallucinated``
    (True/False, None when not checkable) and the check's ``consistency`` details; ``objects`` is the
    known-object vocabulary for that check (default :func:`object_names`).
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    if not prediction_paths:
        raise ValueError("evaluate needs at least one prediction file")
    for item in items:
        check_gold(item)
    out = Path(out_dir)
    (out / "scored").mkdir(parents=True, exist_ok=True)
    paths = [Path(p) for p in prediction_paths]
    item_ids = {item.id for item in items}
    by_id = {item.id: item for item in items}
    vocabulary = object_names() if objects is None else objects
    extras = {item.id: {"chance": item_chance(item), "source": item.source, "vocabulary": item.vocabulary}
              for item in items}
    runs: dict[str, list[dict]] = {}
    unknown: dict[str, int] = {}
    scored_files: dict[str, str] = {}
    for name, path in zip(_run_names(paths), paths, strict=True):
        preds = load_predictions(path)
        records = score_predictions(items, {i: p["prediction"] for i, p in preds.items()}, mode)
        for r in records:
            r.update(extras[r["id"]])
            check = None if r["prediction"] is None else check_reasoning(by_id[r["id"]], r["prediction"], vocabulary)
            r["hallucinated"] = None if check is None else check.flag
            r["consistency"] = None if check is None else check.to_dict()
            r["follows"] = _follows(by_id[r["id"]], r["prediction"])
            kept = {k: v for k, v in preds.get(r["id"], {}).items() if k not in ("id", "prediction")}
            if kept:
                r["extra"] = kept
        unknown[name] = len(set(preds) - item_ids)
        scored = out / "scored" / f"{name}.jsonl"
        write_jsonl(scored, records)
        scored_files[f"scored:{name}"] = str(scored)
        runs[name] = records
    report = summarize(runs, mode)
    report.unknown_ids = unknown
    report.files.update(scored_files)
    write_report(report, out)
    return report


def report_from_scored(scored_paths: Sequence[str | Path], out_dir: str | Path) -> Report:
    """Rebuild a report from kept per-item records (``scored/<run>.jsonl``), one file per run."""
    paths = [Path(p) for p in scored_paths]
    if not paths:
        raise ValueError("report_from_scored needs at least one scored file")
    report = summarize({name: load_scored(p) for name, p in zip(_run_names(paths), paths, strict=True)})
    write_report(report, out_dir)
    return report


# ------------------------------------------------------------------------------------------- comparison


@dataclass
class Comparison:
    """Paired McNemar tests between two models' records on the same items, per task and overall."""

    a_name: str
    b_name: str
    per_task: dict[str, McNemarResult]
    overall: McNemarResult

    def to_dict(self) -> dict:
        return {"a": self.a_name, "b": self.b_name, "test": "exact McNemar (two-sided binomial)",
                "per_task": {t: r.to_dict() for t, r in self.per_task.items()}, "overall": self.overall.to_dict()}

    def to_markdown(self) -> str:
        a, b = self.a_name, self.b_name
        lines = [f"# {a} vs {b}", "",
                 f"Exact McNemar test on the same items. b01 = {a} wrong & {b} right; b10 = {a} right & {b} wrong.",
                 "", f"| Task | n | {a} (%) | {b} (%) | b01 | b10 | p |", "|---|---:|---:|---:|---:|---:|---:|"]
        for task, r in [*self.per_task.items(), ("**Overall**", self.overall)]:
            lines.append(f"| {task} | {r.n} | {_pct(r.a_correct / r.n)} | {_pct(r.b_correct / r.n)} | {r.b01} | "
                         f"{r.b10} | {r.p_value:.3g} |")
        return "\n".join(lines) + "\n"


def compare_runs(a_records: Sequence[dict], b_records: Sequence[dict], a_name: str = "A",
                 b_name: str = "B") -> Comparison:
    """Join two models' score records on item id and run exact McNemar tests per task and overall.

    Raises ValueError when the item sets differ (naming the counts) or an item's task differs.
    """
    a, b = _index(a_records, a_name), _index(b_records, b_name)
    _same_items(a, b, a_name, b_name)
    if not a:
        raise ValueError("compare_runs: no items")
    ids = list(a)
    per_task = {}
    for task in _task_order(a[i]["task"] for i in ids):
        tids = [i for i in ids if a[i]["task"] == task]
        per_task[task] = mcnemar_exact([a[i]["correct"] for i in tids], [b[i]["correct"] for i in tids])
    overall = mcnemar_exact([a[i]["correct"] for i in ids], [b[i]["correct"] for i in ids])
    return Comparison(a_name, b_name, per_task, overall)


def compare_prediction_files(a: str | Path, b: str | Path, bench: str | Path, split: str = "test",
                             mode: Mode | str = "strict") -> Comparison:
    """Score two models' prediction files on one benchmark split and pair them item by item (named by file stem)."""
    from tacreasoner.tasks.bench import load_bench

    _, items = load_bench(bench, split)
    records = [score_predictions(items, {i: p["prediction"] for i, p in load_predictions(path).items()}, mode)
               for path in (a, b)]
    return compare_runs(records[0], records[1], Path(a).stem, Path(b).stem)


def write_comparison(comparison: Comparison, out_dir: str | Path, stem: str = "comparison") -> dict[str, Path]:
    """Write ``<stem>.md`` and ``<stem>.json`` into ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"md": out / f"{stem}.md", "json": out / f"{stem}.json"}
    paths["md"].write_text(comparison.to_markdown(), encoding="utf-8")
    paths["json"].write_text(json.dumps(comparison.to_dict(), indent=2) + "\n", encoding="utf-8")
    return paths
