"""Manual audit of TouchCoT samples: a CSV review sheet plus a self-contained HTML page to read it with.

Reviewers open ``review.html`` (one file: CSS inline, every image a base64 PNG data URI, so it can be
mailed or archived) to see each sample's video frames, its contact-area/intensity curve with the
interaction stages shaded, the question, gold answer, reasoning and answer; they write ``accept`` or
``reject`` (and a comment) into ``review.csv`` and the sheet is read back with :func:`import_review`.

Decisions on import (case-insensitive; anything else is an error naming the row):

* ``reject`` — the sample is rejected whatever the filter said (reason ``reviewer_reject``).
* ``accept`` — recorded as ``sample.review = "accept"``, but a sample the filter rejected **stays
  rejected**: the filter's reasons are checkable facts (wrong answer, bad format, duplicate), so a
  reviewer accept is only counted (``accept_of_rejected``) for someone to look into.
* blank — not reviewed (``sample.review = None``); an earlier ``reviewer_reject`` is withdrawn.

A non-blank comment goes to ``sample.meta["review_comment"]``. Run the filter before exporting:
the sheet shows its decision, and export/import keep earlier reviews (the sheet is pre-filled).
Pass only the samples you want audited (e.g. the accepted ones); ``n`` draws a sample stratified by task.
"""

from __future__ import annotations

import base64
import csv
import html
import io
from collections import Counter, defaultdict
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tacreasoner.cot.schema import CoTSample
from tacreasoner.data.splits import split_counts
from tacreasoner.jsonl import atomic_write_text
from tacreasoner.tasks.extract import split_reasoning
from tacreasoner.tasks.schema import PLACEHOLDER

__all__ = ["COLUMNS", "DECISIONS", "ReviewResult", "export_review", "import_review", "stratified_sample"]

COLUMNS = ("key", "item_id", "task", "question", "gold_answer", "think", "answer", "auto_decision", "auto_reasons",
           "decision", "comment")
DECISIONS = ("accept", "reject")
CSV_NAME = "review.csv"
HTML_NAME = "review.html"
_STRIP_HEIGHT = 96
_STAGE_COLOURS = {"press": "#4e79a7", "hold": "#f28e2b", "slide": "#59a14f", "rotate": "#b07aa1",
                  "release": "#e15759"}


# ------------------------------------------------------------------------------------------------ selection


def stratified_sample(samples: Sequence[CoTSample], n: int | None, seed: int = 0) -> list[CoTSample]:
    """``n`` samples spread over tasks in proportion to their size (at least one per task when n allows),
    drawn at random within each task with ``seed``; returned in input order. ``None`` → all."""
    if n is None or n >= len(samples):
        return list(samples)
    if n < 0:
        raise ValueError(f"n must be >= 0, got {n}")
    by_task: dict[str, list[int]] = defaultdict(list)
    for i, s in enumerate(samples):
        by_task[s.task].append(i)
    tasks = sorted(by_task)
    counts = split_counts(n, [len(by_task[t]) / len(samples) for t in tasks])
    rng = np.random.default_rng(seed)
    chosen: list[int] = []
    for task, count in zip(tasks, counts, strict=True):
        chosen += rng.choice(by_task[task], size=min(count, len(by_task[task])), replace=False).tolist()
    return [samples[i] for i in sorted(chosen)]


# ------------------------------------------------------------------------------------------------ CSV


def _think_and_answer(sample: CoTSample) -> tuple[str, str]:
    think, answer = split_reasoning(sample.output)
    if think is None and answer is None:
        return f"[unparsed output] {sample.output}", ""
    return think or "", answer or ""


def _auto_decision(sample: CoTSample) -> str:
    return "" if sample.accepted is None else ("accept" if sample.accepted else "reject")


def _row(sample: CoTSample) -> dict[str, str]:
    think, answer = _think_and_answer(sample)
    return {"key": sample.key, "item_id": sample.item_id, "task": sample.task, "question": sample.question,
            "gold_answer": sample.gold_answer, "think": think, "answer": answer,
            "auto_decision": _auto_decision(sample), "auto_reasons": "; ".join(sample.reject_reasons),
            "decision": sample.review or "", "comment": str(sample.meta.get("review_comment", ""))}


def _write_csv(samples: Sequence[CoTSample], path: Path) -> Path:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=COLUMNS)
    writer.writeheader()
    for s in samples:
        writer.writerow(_row(s))
    return atomic_write_text(path, buf.getvalue())


# ------------------------------------------------------------------------------------------------ images


def _png_data_uri(fig_or_image: object) -> str:
    """A base64 PNG data URI of a matplotlib Figure or an H×W×3 uint8 image."""
    buf = io.BytesIO()
    if isinstance(fig_or_image, np.ndarray):
        from matplotlib.image import imsave

        imsave(buf, fig_or_image, format="png")
    else:
        fig_or_image.savefig(buf, format="png")  # type: ignore[attr-defined]
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _frame_strip(frames: np.ndarray, start: int, end: int, k: int) -> np.ndarray:
    """k evenly spaced frames of [start, end), downscaled, side by side with thin white gaps."""
    from tacreasoner.data.sampling import sample_indices

    idx = start + sample_indices(end - start, k, "uniform")
    step = max(1, int(np.ceil(frames.shape[1] / _STRIP_HEIGHT)))
    tiles = [np.asarray(frames[i, ::step, ::step]) for i in idx]
    gap = np.full((tiles[0].shape[0], 2, 3), 255, np.uint8)
    parts: list[np.ndarray] = []
    for tile in tiles:
        parts += [tile, gap]
    return np.concatenate(parts[:-1], axis=1)


def _curve_plot(frames: np.ndarray, phases: dict, segment: tuple[int, int] | None) -> str:
    """Contact area and intensity over the whole clip (each scaled to its maximum), stages shaded, segment marked.

    A segment's phases are relative to its first frame (``prepare``'s convention), so they are shifted.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from tacreasoner.data.cues import frame_signals

    signals = frame_signals(frames)
    t = np.arange(len(signals))
    offset = segment[0] if segment is not None else 0
    fig = Figure(figsize=(3.8, 1.6), dpi=90)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    for stage, span in phases.items():
        if isinstance(span, (list, tuple)) and len(span) == 2:
            ax.axvspan(offset + span[0], offset + span[1], color=_STAGE_COLOURS.get(stage, "#bab0ac"), alpha=0.25,
                       lw=0, label=stage)
    for name, values, style in (("area", signals.area, "-"), ("intensity", signals.intensity, "--")):
        peak = float(np.nanmax(values)) if len(values) else 0.0
        ax.plot(t, values / peak if peak > 0 else values, style, color="black", lw=1, label=name)
    if segment is not None:
        for x in segment:
            ax.axvline(x, color="red", lw=1, ls=":")
    ax.set_xlim(0, max(1, len(t) - 1))
    ax.set_xlabel("frame", fontsize=7)
    ax.tick_params(labelsize=6)
    ax.legend(fontsize=5, ncol=7, loc="lower left", bbox_to_anchor=(0, 1.0), frameon=False, borderaxespad=0.1)
    fig.tight_layout(pad=0.3)
    return _png_data_uri(fig)


def _resolve(path: str | None, root: str | Path | None) -> Path | None:
    if not path:
        return None
    p = Path(path)
    return p if p.is_absolute() or root is None else Path(root) / p


def _placeholder(text: str) -> str:
    return f'<div class="missing">{html.escape(text)}</div>'


def _video_panel(i: int, video: dict, cues: dict, root: str | Path | None, k: int) -> str:
    from tacreasoner.data.cache import load_frames

    start, end = video.get("start"), video.get("end")
    label = f"Video {i + 1}: {video.get('clip_id', '?')}"
    if start is not None or end is not None:
        label += f" [frames {start}–{end})"
    head = f'<div class="vlabel">{html.escape(label)}</div>'
    path = _resolve(video.get("path"), root)
    if path is None:
        return head + _placeholder("no video path recorded")
    try:
        frames = load_frames(path)
        lo = max(0, start or 0)
        hi = min(len(frames), end if end is not None else len(frames))
        if hi <= lo:
            raise ValueError(f"segment [{start}, {end}) is empty for a clip of {len(frames)} frames")
        strip = f'<img class="strip" alt="frames" src="{_png_data_uri(_frame_strip(frames, lo, hi, k))}">'
    except (OSError, ValueError) as e:
        return head + _placeholder(f"video not readable: {path} ({e})")
    segment = (lo, hi) if (start is not None or end is not None) else None
    try:
        uri = _curve_plot(frames, cues.get("phases") or {}, segment)
        curve = f'<img class="curve" alt="contact curve" src="{uri}">'
    except ValueError as e:
        curve = _placeholder(f"no contact curve ({e})")
    return head + strip + curve


# ------------------------------------------------------------------------------------------------ HTML

_CSS = """
body{font-family:system-ui,sans-serif;margin:1.5em;color:#222;max-width:1400px}
h1{font-size:1.3em} .summary td,.summary th{padding:2px 10px;text-align:left}
.sample{border:1px solid #ccc;border-radius:6px;margin:1em 0;padding:.6em 1em}
.sample h2{font-size:1em;margin:.2em 0 .6em 0} .key{color:#777;font-weight:normal;font-family:monospace}
.row{display:flex;gap:1.5em;flex-wrap:wrap} .media{flex:0 0 auto;max-width:520px} .text{flex:1 1 420px}
.strip{display:block;max-width:100%;margin:.2em 0} .curve{display:block;margin-bottom:.6em}
.vlabel{font-size:.8em;color:#555;margin-top:.4em} .label{font-weight:bold;font-size:.85em;color:#555}
.think{white-space:pre-wrap;background:#f6f6f6;padding:.5em;border-radius:4px;font-size:.9em}
.missing{border:1px dashed #c33;color:#c33;padding:1.5em .5em;font-size:.8em;margin:.3em 0;background:#fff5f5}
.badge{display:inline-block;padding:0 .5em;border-radius:3px;font-size:.8em;color:#fff}
.accept{background:#2e7d32} .reject{background:#c62828} .unfiltered{background:#777}
.tac{background:#e3ecf7;border-radius:3px;padding:0 .3em;font-size:.85em}
"""


def _question_html(question: str) -> str:
    parts = html.escape(question).split(html.escape(PLACEHOLDER))
    out = parts[0]
    for i, part in enumerate(parts[1:]):
        out += f'<span class="tac">[video {i + 1}]</span>' + part
    return out


def _sample_html(sample: CoTSample, root: str | Path | None, k: int) -> str:
    think, answer = _think_and_answer(sample)
    decision = _auto_decision(sample) or "unfiltered"
    reasons = f" ({html.escape(', '.join(sample.reject_reasons))})" if sample.reject_reasons else ""
    panels = "".join(_video_panel(i, v, sample.cues[i] if i < len(sample.cues) else {}, root, k)
                     for i, v in enumerate(sample.videos))
    stages = " → ".join(sample.stages)
    teacher = f"{sample.teacher} / {sample.model} / {sample.prompt_version}"
    return (f'<section class="sample" id="{html.escape(sample.key)}">'
            f'<h2>{html.escape(sample.task)} · {html.escape(sample.item_id)} '
            f'<span class="key">{html.escape(sample.key)}</span> '
            f'<span class="badge {decision}">auto: {decision}</span>{reasons}</h2>'
            f'<div class="row"><div class="media">{panels}</div><div class="text">'
            f'<div class="label">Question</div><p>{_question_html(sample.question)}</p>'
            f'<div class="label">Gold answer</div><p>{html.escape(sample.gold_answer)}</p>'
            f'<div class="label">Stages to cover</div><p>{html.escape(stages)}</p>'
            f'<div class="label">Reasoning</div><div class="think">{html.escape(think)}</div>'
            f'<div class="label">Answer</div><p>{html.escape(answer)}</p>'
            f'<div class="label">Teacher</div><p>{html.escape(teacher)}</p>'
            f"</div></div></section>")


def _page(samples: Sequence[CoTSample], root: str | Path | None, k: int) -> str:
    per_task = Counter(s.task for s in samples)
    rows = "".join(f"<tr><td>{html.escape(t)}</td><td>{n}</td></tr>" for t, n in sorted(per_task.items()))
    body = "".join(_sample_html(s, root, k) for s in samples)
    return (f'<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>TouchCoT review</title>'
            f"<style>{_CSS}</style></head><body><h1>TouchCoT review — {len(samples)} samples</h1>"
            f"<p>Write <b>accept</b> or <b>reject</b> (and a comment) in the <code>decision</code> column of "
            f"<code>{CSV_NAME}</code>, then import it. Curves: contact area (solid) and intensity (dashed), each "
            f"scaled to its maximum; shaded spans are the interaction stages; dotted red lines bound a segment.</p>"
            f'<table class="summary"><tr><th>task</th><th>samples</th></tr>{rows}</table>{body}</body></html>\n')


def _unimported(csv_path: Path, samples: Sequence[CoTSample]) -> int:
    """Rows of an existing sheet whose decision the samples do not hold yet (work an overwrite would lose)."""
    if not csv_path.exists():
        return 0
    reviews = {s.key: s.review or "" for s in samples}
    with csv_path.open(encoding="utf-8-sig", newline="") as f:
        return sum(1 for row in csv.DictReader(f)
                   if (row.get("decision") or "").strip()
                   and reviews.get((row.get("key") or "").strip()) != (row.get("decision") or "").strip().lower())


def export_review(samples: Sequence[CoTSample], out_dir: str | Path, *, bench_video_root: str | Path | None = None,
                  n: int | None = None, seed: int = 0, frames_per_video: int = 4) -> tuple[Path, Path]:
    """Write ``review.csv`` and ``review.html`` for (a stratified draw of ``n`` of) the samples.

    Relative video paths are resolved against ``bench_video_root``; a video that cannot be read shows
    a placeholder on the page instead of failing the export. An existing sheet holding reviewer
    decisions that were never imported is not overwritten (FileExistsError): import it first.
    """
    if frames_per_video < 1:
        raise ValueError(f"frames_per_video must be >= 1, got {frames_per_video}")
    out_dir = Path(out_dir)
    pending = _unimported(out_dir / CSV_NAME, samples)
    if pending:
        raise FileExistsError(f"{out_dir / CSV_NAME}: holds {pending} reviewer decision(s) not imported yet; "
                              f"import it with import_review (or move it away) before exporting again")
    chosen = stratified_sample(samples, n, seed)
    csv_path = _write_csv(chosen, out_dir / CSV_NAME)
    html_path = atomic_write_text(out_dir / HTML_NAME, _page(chosen, bench_video_root, frames_per_video))
    return csv_path, html_path


# ------------------------------------------------------------------------------------------------ import


@dataclass
class ReviewResult:
    csv_path: Path
    rows: int = 0
    accepted: int = 0
    """Rows with a reviewer ``accept``."""
    rejected: int = 0
    """Rows with a reviewer ``reject``."""
    blank: int = 0
    overridden: int = 0
    """Reviewer rejects of samples the filter had accepted."""
    accept_of_rejected: int = 0
    """Reviewer accepts of samples the filter had rejected (they stay rejected)."""
    per_task: dict[str, dict[str, int]] = field(default_factory=dict)

    @property
    def reviewed(self) -> int:
        return self.accepted + self.rejected

    def to_dict(self) -> dict:
        return {"csv_path": str(self.csv_path), "rows": self.rows, "reviewed": self.reviewed,
                "accepted": self.accepted, "rejected": self.rejected, "blank": self.blank,
                "overridden": self.overridden, "accept_of_rejected": self.accept_of_rejected,
                "per_task": self.per_task}


def _read_decisions(csv_path: Path, known: dict[str, CoTSample]) -> list[tuple[CoTSample, str, str]]:
    """(sample, decision, comment) per row, all validated before anything is changed."""
    with csv_path.open(encoding="utf-8-sig", newline="") as f:
        reader = csv.DictReader(f)
        missing = [c for c in ("key", "decision") if c not in (reader.fieldnames or [])]
        if missing:
            raise ValueError(f"{csv_path}: missing column(s) {missing}; found {reader.fieldnames}")
        out: list[tuple[CoTSample, str, str]] = []
        first_row: dict[str, int] = {}
        for row_no, row in enumerate(reader, start=2):
            where = f"{csv_path}: row {row_no} (line {reader.line_num})"
            key = (row.get("key") or "").strip()
            if key not in known:
                raise ValueError(f"{where}: unknown sample key {key!r}")
            if key in first_row:
                raise ValueError(f"{where}: key {key!r} already reviewed in row {first_row[key]}")
            first_row[key] = row_no
            decision = (row.get("decision") or "").strip().lower()
            if decision not in ("", *DECISIONS):
                raise ValueError(f"{where}: decision {row.get('decision')!r} must be accept, reject or blank")
            out.append((known[key], decision, (row.get("comment") or "").strip()))
    return out


def _apply(sample: CoTSample, decision: str, comment: str, result: ReviewResult) -> None:
    if comment:
        sample.meta["review_comment"] = comment
    else:
        sample.meta.pop("review_comment", None)
    sample.review = decision or None
    if decision == "reject":
        if sample.accepted:
            result.overridden += 1
        sample.accepted = False
        if "reviewer_reject" not in sample.reject_reasons:
            sample.reject_reasons.append("reviewer_reject")
        return
    if "reviewer_reject" in sample.reject_reasons:
        sample.reject_reasons.remove("reviewer_reject")
        if not sample.reject_reasons:
            # Withdrawn reject: back to the filter's verdict (it ran when it left its details in meta).
            sample.accepted = True if "filter" in sample.meta else None
    if decision == "accept" and sample.accepted is False:
        result.accept_of_rejected += 1


def import_review(csv_path: str | Path, samples: Sequence[CoTSample]) -> ReviewResult:
    """Apply reviewers' decisions from the sheet to ``samples`` (in place); see the module docstring.

    The whole sheet is validated first (unknown key, repeated key, bad decision → ValueError naming the
    row), so a bad sheet changes nothing.
    """
    csv_path = Path(csv_path)
    known = {s.key: s for s in samples}
    decisions = _read_decisions(csv_path, known)
    result = ReviewResult(csv_path)
    per_task: dict[str, Counter[str]] = defaultdict(Counter)
    for sample, decision, comment in decisions:
        _apply(sample, decision, comment, result)
        result.rows += 1
        label = decision or "blank"
        if label == "accept":
            result.accepted += 1
        elif label == "reject":
            result.rejected += 1
        else:
            result.blank += 1
        per_task[sample.task][label] += 1
    result.per_task = {t: {k: c[k] for k in ("accept", "reject", "blank")} for t, c in sorted(per_task.items())}
    return result
