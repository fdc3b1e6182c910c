"""``build-cot`` end to end: prepare → generate → filter → format, with a run report.

Each step is safe to re-run: cues are cached per clip, generation resumes from ``samples.jsonl``,
filtering and formatting are recomputed from the samples (cheap) every time.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from tacreasoner.jsonl import atomic_write_text

REPORT = "build_cot.json"
REVIEW_DECISIONS = "review/decisions.csv"
"""Reviewers' decisions as last imported; applied again on every run."""


def apply_saved_review(out: Path, samples: list) -> dict | None:
    """Re-apply the reviewers' decisions saved by ``cot-review --import`` (they outlive re-runs).

    ``samples`` must be every sample of the directory (the sheet may name any of them).
    """
    from tacreasoner.cot.audit import import_review

    saved = out / REVIEW_DECISIONS
    return import_review(saved, samples).to_dict() if saved.exists() else None


@dataclass
class BuildCotResult:
    out_dir: Path
    jobs: int
    generated: int
    already_done: int
    failed: int
    accepted: int
    rejected: int
    seconds: dict[str, float]
    samples_per_second: float
    """New samples generated per second of generation wall time."""
    acceptance_by_task: dict[str, float]
    files: dict[str, str] = field(default_factory=dict)
    usage: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(self).items()}


def build_cot(bench_dir: str | Path, out_dir: str | Path, teacher_config, *, split: str = "train",
              tasks: Sequence[str] | None = None, limit: int | None = None, workers: int = 2,
              concurrency: int | None = None, reveal_answer: bool = True, filter_config=None, val_fraction: float = 0.1,
              seed: int = 0, on_stage: Callable[[str], None] | None = None,
              progress: Callable[[str, int, int], None] | None = None) -> BuildCotResult:
    """Build a TouchCoT dataset from a benchmark split with one teacher; returns counts and timings."""
    from tacreasoner.cot.backends import make_teacher
    from tacreasoner.cot.filter import FilterConfig, filter_samples
    from tacreasoner.cot.format import write_training_files
    from tacreasoner.cot.pipeline import SAMPLES, generate, load_samples
    from tacreasoner.cot.prepare import prepare_jobs
    from tacreasoner.cot.prompts import build_prompt, load_prompts, prompt_version
    from tacreasoner.cot.rules import BRIEF_STYLES

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    teacher = make_teacher(teacher_config)  # fails fast on bad configuration, before any work
    seconds: dict[str, float] = {}

    def stage(name: str) -> float:
        if on_stage:
            on_stage(name)
        return time.perf_counter()

    t = stage("prepare")
    jobs = prepare_jobs(bench_dir, split, cache_dir=out / "cue_cache", tasks=tasks, limit=limit, workers=workers,
                        progress=(lambda d, n: progress("prepare", d, n)) if progress else None)
    prompts = load_prompts()
    version, teacher_id = prompt_version(reveal_answer, prompts), f"{teacher.name}:{teacher.model}"
    for job in jobs:
        job.compute_key(version, teacher_id)
    seconds["prepare"] = time.perf_counter() - t

    t = stage("generate")
    gen = generate(jobs, teacher, lambda job: build_prompt(job, reveal_answer, prompts), out,
                   concurrency=concurrency or getattr(teacher_config, "concurrency", 8) or 8,
                   progress=(lambda d, n: progress("generate", d, n)) if progress else None)
    seconds["generate"] = time.perf_counter() - t

    t = stage("filter")
    keys = {j.key for j in jobs}
    everything = load_samples(out / SAMPLES)[0]
    samples = [s for s in everything if s.key in keys]
    # the rules teacher's brief styles repeat themselves by design: dedup would drop most short-task samples
    brief = getattr(teacher, "style", None) in BRIEF_STYLES
    result = filter_samples(samples, filter_config or FilterConfig(dedup=not brief))
    review = apply_saved_review(out, everything)
    seconds["filter"] = time.perf_counter() - t

    t = stage("format")
    formatted = write_training_files(samples, out / "touchcot", val_fraction=val_fraction, seed=seed)
    seconds["format"] = time.perf_counter() - t

    accepted = sum(1 for s in samples if s.accepted)
    by_task: dict[str, list[int]] = {}
    for s in samples:
        by_task.setdefault(s.task, [0, 0])
        by_task[s.task][0] += 1
        by_task[s.task][1] += bool(s.accepted)
    usage = {key: sum(float(s.usage.get(key, 0) or 0) for s in samples)
             for key in ("prompt_tokens", "completion_tokens", "cost_usd")}
    res = BuildCotResult(
        out_dir=out, jobs=len(jobs), generated=gen.generated, already_done=gen.already_done, failed=gen.failed,
        accepted=accepted, rejected=len(samples) - accepted, seconds={k: round(v, 2) for k, v in seconds.items()},
        samples_per_second=round(gen.samples_per_second, 1),
        acceptance_by_task={t: round(a / n, 4) for t, (n, a) in sorted(by_task.items())},
        files={"samples": str(out / SAMPLES), **{k: str(v) for k, v in formatted.files.items()}},
        usage=usage,
    )
    report = {**res.to_dict(), "filter": result.stats, "review": review, "generation_failures": gen.failures[:50],
              "dropped_partial_line": gen.dropped_partial_line}
    atomic_write_text(out / REPORT, json.dumps(report, indent=2, default=str))
    return res
