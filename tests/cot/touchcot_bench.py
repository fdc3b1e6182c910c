"""A small DynTAC-Sim benchmark prepared once per test session for the prepare/prompt/rules tests."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from tacreasoner.cot.prepare import PrepareStats, prepare_jobs
from tacreasoner.cot.schema import CoTJob
from tacreasoner.tasks.bench import build_bench

_BUILT: dict[Path, tuple[Path, list[CoTJob], PrepareStats]] = {}


def prepared(dataset: Path, workdir: Path) -> tuple[Path, list[CoTJob], PrepareStats]:
    """(bench dir, train jobs, stats of the first, uncached preparation), built once per dataset."""
    if dataset not in _BUILT:
        bench = workdir / "bench"
        build_bench("sim", dataset, bench, seed=0, heldout_sensor="digit")
        stats = PrepareStats()
        jobs = prepare_jobs(bench, "train", cache_dir=workdir / "cues", stats=stats)
        _BUILT[dataset] = (bench, jobs, stats)
    return _BUILT[dataset]


def variants(jobs: list[CoTJob], n: int, task: str | None = None) -> list[CoTJob]:
    """``n`` jobs cycling over ``jobs`` (of one task if given), each with its own item id and key."""
    pool = [j for j in jobs if task is None or j.item.task == task]
    out = []
    for i in range(n):
        job = pool[i % len(pool)]
        item = dataclasses.replace(job.item, id=f"{job.item.id}-v{i}")
        new = CoTJob(item=item, stages=list(job.stages), videos=list(job.videos))
        new.compute_key("touchcot-v1", "rules:rules-v1")
        out.append(new)
    return out
