"""TouchCoT training files (paper §3.1 step 4): accepted samples → train/val JSONL, LLaVA JSON and a stats report.

Which samples are written: ``accepted is True`` and not rejected by a reviewer, minus tasks that must
never be trained on (TSA is zero-shot by design; excluded by default and counted). A sample from a
*test*-split QA item is an error: it would put benchmark test objects into training.

Train/val split — by object, never by sample: objects are assigned with
:func:`~tacreasoner.data.splits.object_level_split` (deterministic for a seed) and a sample goes to
val when **any** of its objects is a val object. Objects of samples whose QA item is already in the
``val`` split are pinned to val, so a benchmark's own val objects never reach TouchCoT train. The
guarantee checked with :func:`~tacreasoner.data.splits.check_no_leakage` is therefore: no val object
appears in any train sample. A val sample comparing a val object with a train object (SFD, SOI, OSC)
does hold a train object; such samples are counted as ``val_mixed`` in the stats.

Files in ``out_dir``: ``touchcot_train.jsonl``, ``touchcot_val.jsonl`` (one record per sample: id = the
sample key, item_id, task, question with ``<tactile>`` placeholders, videos, answer (gold), output —
the full ``<think>…</think><answer>…</answer>`` target — objects, stages, teacher, model,
prompt_version, created, cues), ``touchcot_{train,val}_llava.json`` (human = question with
``<video>`` tokens, gpt = output; ``segments`` added when a video is a frame segment, as LLaVA
records only carry paths), ``stats.json``, ``stats.md`` and ``lengths.png``.
"""

from __future__ import annotations

import json
from collections import Counter, defaultdict
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tacreasoner.cot.filter import REASONS, acceptance_stats
from tacreasoner.cot.schema import CoTSample
from tacreasoner.data.splits import check_no_leakage, object_level_split
from tacreasoner.jsonl import atomic_write_text, write_jsonl
from tacreasoner.tasks.extract import split_reasoning
from tacreasoner.tasks.formats import to_video_tokens

__all__ = ["FormatResult", "assign_splits", "llava_record", "training_record", "write_training_files"]

EXCLUDED_TASKS = ("TSA",)
"""Zero-shot tasks: never in training (DESIGN.md, Benchmarks)."""


@dataclass
class FormatResult:
    out_dir: Path
    train_path: Path
    val_path: Path
    train_llava_path: Path
    val_llava_path: Path
    stats_path: Path
    stats_md_path: Path
    lengths_path: Path
    n_train: int
    n_val: int
    stats: dict = field(default_factory=dict)

    @property
    def files(self) -> dict[str, Path]:
        """Every file written, by role (for run reports)."""
        return {"train": self.train_path, "val": self.val_path, "train_llava": self.train_llava_path,
                "val_llava": self.val_llava_path, "stats": self.stats_path, "stats_md": self.stats_md_path,
                "lengths": self.lengths_path}


# ------------------------------------------------------------------------------------------------ records


def training_record(sample: CoTSample) -> dict:
    """The training-ready JSONL record of one sample."""
    return {"id": sample.key, "item_id": sample.item_id, "task": sample.task, "question": sample.question,
            "videos": sample.videos, "answer": sample.gold_answer, "output": sample.output,
            "objects": sample.objects, "stages": sample.stages, "teacher": sample.teacher, "model": sample.model,
            "prompt_version": sample.prompt_version, "created": sample.created, "cues": sample.cues}


def llava_record(sample: CoTSample) -> dict:
    """LLaVA-style conversation: ``<video>`` tokens in the question, the full think/answer output as the reply."""
    record: dict = {"id": sample.key,
                    "videos": [v.get("path") or v["clip_id"] for v in sample.videos],
                    "conversations": [{"from": "human", "value": to_video_tokens(sample.question)},
                                      {"from": "gpt", "value": sample.output}]}
    if any(v.get("start") is not None or v.get("end") is not None for v in sample.videos):
        record["segments"] = [[v.get("start"), v.get("end")] for v in sample.videos]
    return record


# ------------------------------------------------------------------------------------------------ selection and split


def _select(samples: Sequence[CoTSample], exclude_tasks: Sequence[str]) -> tuple[list[CoTSample], dict]:
    test = [s.key for s in samples if s.split == "test"]
    if test:
        raise ValueError(f"{len(test)} sample(s) come from test-split QA items (e.g. {test[:3]}); test objects must "
                         f"never reach training")
    kept: list[CoTSample] = []
    excluded: dict = {"not_accepted": 0, "reviewer_reject": 0, "tasks": Counter()}
    for s in samples:
        if s.review == "reject":
            excluded["reviewer_reject"] += 1
        elif s.accepted is not True:
            excluded["not_accepted"] += 1
        elif s.task in exclude_tasks:
            excluded["tasks"][s.task] += 1
        else:
            kept.append(s)
    excluded["tasks"] = dict(sorted(excluded["tasks"].items()))
    return kept, excluded


def assign_splits(samples: Sequence[CoTSample], val_fraction: float = 0.1, seed: int = 0) -> dict[str, str]:
    """Sample key → ``train``/``val`` by object (see the module docstring); checked for leakage."""
    if not 0.0 <= val_fraction < 1.0:
        raise ValueError(f"val_fraction must be in [0, 1), got {val_fraction}")
    for s in samples:
        if not s.objects:
            raise ValueError(f"sample {s.key!r} (item {s.item_id!r}): field 'objects' is empty; cannot split by object")
    objects = [o for s in samples for o in s.objects]
    pinned = {o: "val" for s in samples if s.split == "val" for o in s.objects}
    by_object = object_level_split(objects, (1.0 - val_fraction, val_fraction), seed, ("train", "val"), fixed=pinned)
    splits = {s.key: "val" if any(by_object[o] == "val" for o in s.objects) else "train" for s in samples}
    check_no_leakage([(splits[s.key], o) for s in samples for o in s.objects if splits[s.key] == "train"]
                     + [("val", o) for o, split in by_object.items() if split == "val"])
    return splits


# ------------------------------------------------------------------------------------------------ stats


def _think_words(sample: CoTSample) -> int:
    think, _ = split_reasoning(sample.output)
    return len((think or "").split())


def _usage_totals(samples: Sequence[CoTSample]) -> dict[str, float]:
    totals: Counter[str] = Counter()
    for s in samples:
        for k, v in (s.usage or {}).items():
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                totals[k] += v
    return {k: round(v, 6) if isinstance(v, float) else v for k, v in sorted(totals.items())}


def _length_summary(words: list[int]) -> dict:
    a = np.asarray(words)
    return {"n": len(words), "mean": round(float(a.mean()), 1), "median": float(np.median(a)),
            "min": int(a.min()), "max": int(a.max())}


def _stats(samples: Sequence[CoTSample], kept: Sequence[CoTSample], splits: dict[str, str], excluded: dict,
           val_fraction: float, seed: int) -> dict:
    per_task: dict[str, Counter[str]] = defaultdict(Counter)
    for s in kept:
        per_task[s.task][splits[s.key]] += 1
    val_objects = {o for s in kept if splits[s.key] == "val" for o in s.objects}
    train_objects = {o for s in kept if splits[s.key] == "train" for o in s.objects}
    words: dict[str, list[int]] = defaultdict(list)
    for s in kept:
        words[s.task].append(_think_words(s))
    filt = acceptance_stats(samples)
    warnings = list(filt["warnings"])
    if excluded["tasks"]:
        warnings.append(f"excluded zero-shot task(s) from training: {excluded['tasks']}")
    n_val = sum(1 for s in kept if splits[s.key] == "val")
    if kept and val_fraction > 0 and n_val / len(kept) > 2 * val_fraction:
        warnings.append(f"val holds {100 * n_val / len(kept):.1f}% of the samples for a val fraction of "
                        f"{val_fraction}: a multi-object item goes to val when any of its objects is a val object")
    return {
        "n_input": len(samples), "n_written": len(kept),
        "train": sum(1 for s in kept if splits[s.key] == "train"),
        "val": n_val,
        "val_fraction": val_fraction, "seed": seed,
        "objects": {"train": len(train_objects), "val": len(val_objects - train_objects)},
        "val_mixed": sum(1 for s in kept if splits[s.key] == "val" and any(o in train_objects for o in s.objects)),
        "per_task": {t: {"train": c["train"], "val": c["val"]} for t, c in sorted(per_task.items())},
        "excluded": excluded,
        "filter": {k: v for k, v in filt.items() if k != "warnings"},
        "teachers": dict(sorted(Counter(s.teacher for s in kept).items())),
        "models": dict(sorted(Counter(s.model for s in kept).items())),
        "prompt_versions": dict(sorted(Counter(s.prompt_version for s in kept).items())),
        "usage": _usage_totals(samples),
        "think_words": {t: _length_summary(w) for t, w in sorted(words.items())},
        "warnings": warnings,
    }


def _pct(x: float | None) -> str:
    return "–" if x is None else f"{100 * x:.1f}%"


def _table(header: Sequence[str], rows: list[Sequence[object]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return [*lines, ""]


def _markdown(stats: dict) -> str:
    f = stats["filter"]
    out = ["# TouchCoT training files", "",
           f"{stats['n_written']} samples written ({stats['train']} train, {stats['val']} val) from "
           f"{stats['n_input']} generated; overall acceptance {_pct(f['acceptance_rate'])}. Split by object "
           f"(val fraction {stats['val_fraction']}, seed {stats['seed']}): {stats['objects']['train']} train objects, "
           f"{stats['objects']['val']} val objects; {stats['val_mixed']} val samples also hold a train object.", ""]
    out += ["## Per task", ""]
    out += _table(["task", "generated", "accepted", "acceptance", "train", "val"],
                  [[t, e["total"], e["accepted"], _pct(e["acceptance_rate"]),
                    stats["per_task"].get(t, {}).get("train", 0), stats["per_task"].get(t, {}).get("val", 0)]
                   for t, e in f["tasks"].items()])
    out += ["## Per class", "", "Share = the class's share of the task's samples (all / accepted).", ""]
    out += _table(["task", "class", "generated", "accepted", "acceptance", "share (all)", "share (accepted)"],
                  [[t, c, e["total"], e["accepted"], _pct(e["acceptance_rate"]), _pct(e["share_all"]),
                    _pct(e["share_accepted"])] for t, te in f["tasks"].items() for c, e in te["classes"].items()])
    out += ["## Rejection reasons", "", "A sample rejected for several reasons counts under each.", ""]
    out += _table(["reason", *f["tasks"]],
                  [[r] + [te["reasons"].get(r, 0) for te in f["tasks"].values()] for r in REASONS
                   if any(te["reasons"].get(r) for te in f["tasks"].values())] or [["(none)"] + [""] * len(f["tasks"])])
    ex = stats["excluded"]
    out += [f"Not written: {ex['not_accepted']} not accepted, {ex['reviewer_reject']} rejected by reviewers"
            + (f", excluded tasks {ex['tasks']}" if ex["tasks"] else "") + ".", ""]
    out += ["## Teachers", ""]
    for title, key in (("teacher", "teachers"), ("model", "models"), ("prompt version", "prompt_versions")):
        out += _table([title, "samples"], [[k or "(none)", v] for k, v in stats[key].items()] or [["(none)", 0]])
    if stats["usage"]:
        out += ["## Usage (all generated samples)", ""]
        out += _table(["quantity", "total"], [[k, v] for k, v in stats["usage"].items()])
    out += ["## Reasoning length (words)", ""]
    out += _table(["task", "n", "mean", "median", "min", "max"],
                  [[t, s["n"], s["mean"], s["median"], s["min"], s["max"]] for t, s in stats["think_words"].items()])
    if stats["warnings"]:
        out += ["## Warnings", ""] + [f"- {w}" for w in stats["warnings"]] + [""]
    return "\n".join(out)


def _plot_lengths(kept: Sequence[CoTSample], path: Path) -> Path:
    """Histogram of think length in words, one panel per task."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.ticker import MaxNLocator

    words: dict[str, list[int]] = defaultdict(list)
    for s in kept:
        words[s.task].append(_think_words(s))
    tasks = sorted(words)
    cols = min(3, max(1, len(tasks)))
    rows = max(1, -(-len(tasks) // cols))
    fig = Figure(figsize=(3.2 * cols, 2.4 * rows), dpi=100)
    FigureCanvasAgg(fig)
    if not tasks:
        fig.text(0.5, 0.5, "no samples written", ha="center", va="center")
    for i, task in enumerate(tasks):
        ax = fig.add_subplot(rows, cols, i + 1)
        ax.hist(words[task], bins=min(30, max(5, len(words[task]) // 3)), color="#4e79a7")
        ax.set_title(f"{task} (n={len(words[task])})", fontsize=9)
        ax.set_xlabel("think length (words)", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, format="png", metadata={"Software": None})
    return path


# ------------------------------------------------------------------------------------------------ entry point


def _write_json(path: Path, data: object) -> Path:
    return atomic_write_text(path, json.dumps(data, ensure_ascii=False, indent=2) + "\n")


def write_training_files(samples: Sequence[CoTSample], out_dir: str | Path, *, val_fraction: float = 0.1, seed: int = 0,
                         exclude_tasks: Sequence[str] = EXCLUDED_TASKS) -> FormatResult:
    """Write the training files for the accepted samples (see the module docstring); deterministic for a seed."""
    out_dir = Path(out_dir)
    kept, excluded = _select(samples, exclude_tasks)
    splits = assign_splits(kept, val_fraction, seed)
    parts = {name: [s for s in kept if splits[s.key] == name] for name in ("train", "val")}
    paths = {}
    for name, group in parts.items():
        paths[name] = write_jsonl(out_dir / f"touchcot_{name}.jsonl", (training_record(s) for s in group))
        paths[f"{name}_llava"] = _write_json(out_dir / f"touchcot_{name}_llava.json", [llava_record(s) for s in group])
    stats = _stats(samples, kept, splits, excluded, val_fraction, seed)
    stats_path = _write_json(out_dir / "stats.json", stats)
    md_path = atomic_write_text(out_dir / "stats.md", _markdown(stats))
    lengths = _plot_lengths(kept, out_dir / "lengths.png")
    return FormatResult(out_dir, paths["train"], paths["val"], paths["train_llava"], paths["val_llava"], stats_path,
                        md_path, lengths, len(parts["train"]), len(parts["val"]), stats)
