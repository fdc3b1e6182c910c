"""``cot-review`` as library calls: a review sheet out of a ``build-cot`` folder, reviewers' decisions back in.

Imported decisions are kept beside the samples (``review/decisions.csv``) because ``build-cot`` re-applies them on
every later run; the training files are rewritten at once so a model trains on what the reviewers kept.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

__all__ = ["apply_review", "export_review_sheet"]


def _filtered_samples(cot: Path) -> list[Any]:
    from tacreasoner.cot.filter import filter_samples
    from tacreasoner.cot.pipeline import SAMPLES, load_samples

    samples, _ = load_samples(cot / SAMPLES)
    if not samples:
        raise FileNotFoundError(f"{cot / SAMPLES}: no samples (run `tacreasoner build-cot` first)")
    filter_samples(samples)
    return samples


def export_review_sheet(cot: Path, *, bench: Path | None = None, n: int | None = None,
                        seed: int = 0) -> tuple[Path, Path]:
    """review.csv + a self-contained review.html under ``cot/review`` (frames shown when ``bench`` is given)."""
    from tacreasoner.cot.audit import export_review

    root = None
    if bench is not None:
        root = Path(json.loads((bench / "bench.json").read_text(encoding="utf-8"))["video_root"])
    return export_review(_filtered_samples(cot), cot / "review", bench_video_root=root, n=n, seed=seed)


def apply_review(cot: Path, reviewed_csv: Path, *, seed: int = 0) -> tuple[dict[str, Any], int, int]:
    """Apply a reviewed CSV; returns what changed and the rewritten training files' (train, val) sizes."""
    from tacreasoner.cot.audit import import_review
    from tacreasoner.cot.build import REVIEW_DECISIONS
    from tacreasoner.cot.format import write_training_files

    samples = _filtered_samples(cot)
    result = import_review(reviewed_csv, samples)
    saved = cot / REVIEW_DECISIONS
    if reviewed_csv.resolve() != saved.resolve():
        saved.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(reviewed_csv, saved)  # build-cot re-applies these decisions on every later run
    formatted = write_training_files(samples, cot / "touchcot", seed=seed)
    return result.to_dict(), formatted.n_train, formatted.n_val
