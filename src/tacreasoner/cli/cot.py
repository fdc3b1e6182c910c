"""TouchCoT from the command line: ``build-cot`` (cues → teacher reasoning → filter → training files) and
``cot-review`` (a manual audit sheet out, reviewers' decisions in)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from tacreasoner.cli.app import Bench, Seed, Split, app, at_least_one, cli_errors, comma_list, console
from tacreasoner.progress import StageProgress

if TYPE_CHECKING:
    from tacreasoner.cot.backends import TeacherConfig

def _teacher_config(teacher: str | None, config: Path | None, model: str | None) -> TeacherConfig:
    """The teacher the options name: a config file, or a backend and model given inline."""
    from tacreasoner.cot.backends import TeacherConfig, load_teacher_config

    if config is not None:
        cfg = load_teacher_config(config)
        if teacher is not None and teacher != cfg.backend:
            raise ValueError(f"--teacher {teacher} contradicts backend {cfg.backend!r} in {config}")
    else:
        cfg = TeacherConfig(backend=teacher or "rules", model=model or ("rules-v1" if (teacher or "rules") == "rules"
                                                                         else ""))
    if model is not None:
        cfg.model = model
    cfg.validate()
    return cfg


@app.command("build-cot")
@cli_errors
def build_cot_cmd(
    bench: Bench,
    out: Annotated[Path, typer.Option("--out", help="TouchCoT output directory (re-running resumes).")],
    teacher: Annotated[str | None, typer.Option("--teacher", help="rules (offline, default), openai or hf.")] = None,
    teacher_config: Annotated[Path | None, typer.Option(
        "--teacher-config", help="YAML teacher config (see configs/teacher-*.yaml).")] = None,
    model: Annotated[str | None, typer.Option("--model", help="Teacher model (overrides the config).")] = None,
    split: Split = "train",
    tasks: Annotated[str | None, typer.Option("--tasks", help="Comma-separated tasks (default: all but TSA).")] = None,
    limit: Annotated[int | None, typer.Option("--limit", help="Only the first N items (trial runs).")] = None,
    workers: Annotated[int, typer.Option("--workers", help="Processes for cue extraction.")] = 2,
    concurrency: Annotated[int | None, typer.Option("--concurrency", help="Teacher requests in flight.")] = None,
    blind: Annotated[bool, typer.Option("--blind", help="Do not tell the teacher the gold answer.")] = False,
    seed: Seed = 0,
) -> None:
    """Build a TouchCoT dataset: cues → teacher reasoning → filter → training JSONL + stats (resumable)."""
    from tacreasoner.cot.build import build_cot

    at_least_one("--workers", workers)
    at_least_one("--concurrency", concurrency)
    cfg = _teacher_config(teacher, teacher_config, model)
    task_list = comma_list(tasks) if tasks else None
    with StageProgress() as bars:
        result = build_cot(bench, out, cfg, split=split, tasks=task_list, limit=limit, workers=workers,
                           concurrency=concurrency, reveal_answer=not blind, seed=seed, progress=bars)
    console.print(f"{result.jobs} jobs: {result.generated} generated now, {result.already_done} already done, "
                  f"{result.failed} failed (retried on the next run)")
    if result.failed:
        last = (out / "failures.jsonl").read_text(encoding="utf-8").strip().splitlines()[-1]
        console.print(f"[bold red]teacher failures[/bold red], e.g. {json.loads(last)['error']} "
                      f"(all in {out / 'failures.jsonl'})", markup=True)
    console.print(f"accepted {result.accepted}, rejected {result.rejected}; generation "
                  f"{result.samples_per_second} samples/s; stage seconds {result.seconds}")
    rates = ", ".join(f"{t} {100 * r:.0f}%" for t, r in result.acceptance_by_task.items())
    console.print(f"acceptance by task: {rates}")
    console.print(f"training files in {out / 'touchcot'}; run report {out / 'build_cot.json'}")
    if result.failed:
        raise typer.Exit(1)  # incomplete: scripts should see it; re-running retries only the failed jobs


@app.command("cot-review")
@cli_errors
def cot_review(
    cot: Annotated[Path, typer.Option("--cot", help="A build-cot output directory.")],
    export: Annotated[bool, typer.Option("--export", help="Write review.csv + review.html for reviewers.")] = False,
    import_csv: Annotated[Path | None, typer.Option("--import", help="Reviewed CSV to apply.")] = None,
    n: Annotated[int | None, typer.Option("--n", help="Samples to export (stratified by task).")] = None,
    bench: Annotated[Path | None, typer.Option("--bench", help="Benchmark directory, to show video frames.")] = None,
    seed: Seed = 0,
) -> None:
    """Manual audit: export a review sheet (CSV + self-contained HTML) or import reviewers' decisions."""
    from tacreasoner.cot.review import apply_review, export_review_sheet

    if export == (import_csv is not None):
        raise ValueError("give exactly one of --export or --import CSV")
    if export:
        csv_path, html_path = export_review_sheet(cot, bench=bench, n=n, seed=seed)
        console.print(f"review sheet: {csv_path}\nreview page: {html_path}")
        return
    applied, n_train, n_val = apply_review(cot, import_csv, seed=seed)
    console.print(f"applied {applied}; training files rewritten: {n_train} train, {n_val} val")
