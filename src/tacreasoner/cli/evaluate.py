"""Answering and scoring with a trained model: ``evaluate``, ``evaluate-physiclear``, ``task-loss`` and the
retrieval-augmented benchmark."""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Annotated

import typer

from tacreasoner.cli.app import (
    Bench,
    Dtype,
    Mode,
    Split,
    VideoCache,
    app,
    at_least_one,
    cli_errors,
    comma_list,
    console,
    needs_train_extra,
)
from tacreasoner.progress import StageProgress


@app.command("task-loss")
@cli_errors
def task_loss_cmd(
    model: Annotated[Path, typer.Option("--model", help="A trained model folder (stage2/model).")],
    bench: Bench,
    out: Annotated[Path, typer.Option("--out", help="Folder for task_loss.json and task_loss.md.")],
    splits: Annotated[str, typer.Option("--splits", help="Comma-separated splits, the reference first.")] = "train,val",
    per_task: Annotated[int, typer.Option("--per-task", help="Items per task and split (0: all).")] = 40,
    seed: Annotated[int, typer.Option("--seed", help="Draws the items of each task.")] = 0,
    video_cache: VideoCache = None,
) -> None:
    """The gold answer's teacher-forced loss per task on train items against val items: a small train loss beside
    a large val loss means the model learned the training objects by heart, both large that it under-fits."""
    from tacreasoner.evaluate.task_loss import task_losses, write_task_losses

    if per_task < 0:
        raise ValueError(f"--per-task {per_task}: expected 0 (all) or more")
    split_list = comma_list(splits)
    with StageProgress() as bars:
        losses = task_losses(model, bench, splits=split_list, per_task=per_task or None, seed=seed,
                             video_cache=video_cache, progress=functools.partial(bars, "teacher-forced answers"))
    path = write_task_losses(losses, out, model=str(model), bench=str(bench), per_task=per_task, seed=seed)
    console.print(path.read_text(encoding="utf-8"))
    console.print(f"written: {path} and {path.with_suffix('.json')}")


Encoder = Annotated[Path, typer.Option("--encoder", help="Frozen appearance encoder that embeds the clips (a "
                                                         "`tacreasoner pretrain-encoder` folder).")]


@app.command("retrieval-bench")
@cli_errors
def retrieval_bench_cmd(
    bench: Bench,
    encoder: Encoder,
    out: Annotated[Path, typer.Option("--out", help="New benchmark directory to write.")],
    k: Annotated[int, typer.Option("--k", help="Neighbours per video.")] = 3,
    video_cache: VideoCache = None,
) -> None:
    """Retrieval augmentation (Octopi-1.5): a new benchmark whose questions start with each video's k nearest train
    clips (frozen-encoder CLS cosine, never of the item's own objects) and their level words."""
    needs_train_extra("retrieval-bench")
    at_least_one("--k", k)
    from tacreasoner.evaluate.retrieval import retrieval_bench

    summary = retrieval_bench(bench, encoder, out, k, video_cache=video_cache)
    console.print(f"neighbours from {summary.reference_clips} train clips of {summary.reference_objects} objects; "
                  f"items: {', '.join(f'{s} {n}' for s, n in summary.items.items())}")
    for note in summary.notes:
        console.print(f"note: {note}")
    console.print(f"Benchmark written to {out}")




Answers = Annotated[str, typer.Option(
    "--answers", help="direct: every question in one pass; stepwise: a question over several objects is answered by "
                      "reading each video (and each named object, each scenario's needs) in a pass of its own and "
                      "concluding by the rule (evaluate/stepwise.py); its reply shows the readings; stepwise-vote: "
                      "each video read in every single-clip wording, the majority level; auto: a question in a "
                      "wording the model was trained on in one pass, any other as stepwise-vote.")]


@app.command("evaluate")
@cli_errors
def evaluate_cmd(
    model: Annotated[Path, typer.Option("--model", help="Trained model directory (e.g. runs/train/stage2/model); "
                                                        "one per run (`tacreasoner score` combines seeds' "
                                                        "predictions).")],
    bench: Bench,
    out: Annotated[Path, typer.Option("--out", help="Report directory (predictions/, report.md, plots).")],
    split: Split = "val",
    mode: Mode = "strict",
    batch_size: Annotated[int, typer.Option("--batch-size", help="Prompts per generate call.")] = 32,
    max_new_tokens: Annotated[int, typer.Option("--max-new-tokens", help="Longest reply (room for TouchCoT "
                                                                         "reasoning over 3 videos).")] = 512,
    limit: Annotated[int | None, typer.Option("--limit", help="Only the first N items (trial runs).")] = None,
    touch: Annotated[str, typer.Option("--touch", help="Removed-touch control: real (the item's videos), blank "
                                                       "(featureless clips) or shuffled (other items' videos). "
                                                       "Not real: predictions/<split>_<touch>.jsonl and the "
                                                       "report in touch_<touch>/.")] = "real",
    touch_seed: Annotated[int, typer.Option("--touch-seed", help="Seed of the shuffled videos.")] = 0,
    video_cache: VideoCache = None,
    dtype: Dtype = "float32",
    answers: Answers = "direct",
) -> None:
    """Answer a benchmark split with a trained model and score it (Wilson CIs; resumable predictions)."""
    needs_train_extra("evaluate")
    at_least_one("--batch-size", batch_size)
    from tacreasoner.evaluate.predict import check_answers, check_dtype, check_touch, cut_warning, predict_split
    from tacreasoner.evaluate.report import evaluate

    check_touch(touch)  # before the model loads: a typo fails at once
    check_dtype(dtype)
    check_answers(answers)
    items, preds = predict_split(model, bench, split, out, batch_size=batch_size, max_new_tokens=max_new_tokens,
                                 limit=limit, touch=touch, touch_seed=touch_seed, video_cache=video_cache,
                                 dtype=dtype, answers=answers)
    report_dir = out if touch == "real" else out / f"touch_{touch}"
    report = evaluate(items, [preds], mode, report_dir)
    console.print(report.to_markdown())
    if (warning := cut_warning(preds, max_new_tokens)) is not None:
        console.print(warning)
    console.print(f"scored split: {split} of {bench}; report: {report_dir / 'report.md'}; predictions: {preds}")


@app.command("evaluate-physiclear")
@cli_errors
def evaluate_physiclear_cmd(
    model: Annotated[list[Path], typer.Option("--model", help="Trained model directory; repeat for several seeds "
                                                              "(mean ± std).")],
    data: Annotated[Path, typer.Option("--data", help="A PhysiCLeAR-shaped folder: labels.json + videos/, any split "
                                                      "names (e.g. only 'test').")],
    out: Annotated[Path, typer.Option("--out", help="Output directory: bench/, predictions/, report.md, octopi.md.")],
    split: Annotated[str | None, typer.Option("--split", help="The labels.json split to score (default: val, or "
                                                              "the only labelled split: a folder of test objects "
                                                              "alone is scored on them).", show_default=False)] = None,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the items built from the folder.")] = 0,
    per_task: Annotated[int | None, typer.Option("--per-task", help="Items per task (default: each clip once).",
                                                 show_default=False)] = None,
    mode: Mode = "strict",
    batch_size: Annotated[int, typer.Option("--batch-size", help="Prompts per generate call.")] = 32,
    max_new_tokens: Annotated[int, typer.Option("--max-new-tokens", help="Longest reply (room for TouchCoT "
                                                                         "reasoning over 3 videos).")] = 512,
    retrieval: Annotated[Path | None, typer.Option(
        "--retrieval", help="Retrieval augmentation: the benchmark the model trained on; each question gets its "
                            "videos' nearest clips of that benchmark's train split (as `retrieval-bench` wrote "
                            "them).", show_default=False)] = None,
    encoder: Annotated[Path | None, typer.Option(
        "--encoder", help="With --retrieval: the appearance encoder that embeds the clips (default: the one the "
                          "--retrieval benchmark records).", show_default=False)] = None,
    retrieval_k: Annotated[int | None, typer.Option(
        "--retrieval-k", help="With --retrieval: neighbours per video (default: the --retrieval benchmark's, else "
                              "3).", show_default=False)] = None,
    wording: Annotated[str, typer.Option(
        "--wording", help="benchmark: the benchmark's question templates; heldout: the same items asked in wordings "
                          "no training used (tasks/paraphrases/heldout.yaml; tasks without one are left out); "
                          "heldout2 … heldout5: later such sets (heldout2.yaml … heldout5.yaml).")
                       ] = "benchmark",
    answers: Answers = "stepwise-vote",
) -> None:
    """Score saved models on a PhysiCLeAR-shaped folder: its items built deterministically, Octopi's table out.
    Questions over several objects are answered stepwise, each clip read in every wording, by default (the
    recommended mode, chosen on val)."""
    needs_train_extra("evaluate-physiclear")
    at_least_one("--batch-size", batch_size)
    if per_task is not None:
        at_least_one("--per-task", per_task)
    if retrieval is None and (encoder is not None or retrieval_k is not None):
        raise ValueError("--encoder and --retrieval-k only go with --retrieval REF_BENCH")
    if retrieval is not None:
        from tacreasoner.evaluate.retrieval import reference_settings

        encoder, retrieval_k = reference_settings(retrieval, encoder, retrieval_k)
    from tacreasoner.evaluate.physiclear import evaluate_folder

    with StageProgress() as bars:
        result = evaluate_folder(model, data, out, split=split, seed=seed, per_task=per_task, mode=mode,
                                 batch_size=batch_size, max_new_tokens=max_new_tokens, retrieval=retrieval,
                                 encoder=encoder, retrieval_k=retrieval_k, wording=wording, answers=answers,
                                 progress=lambda label: functools.partial(bars, label), say=console.print)
    console.print(f"scored split: {result.split} of {data}")
    console.print(f"{out / 'bench'}: {sum(result.counts.values())} items over {result.objects} objects "
                  f"({', '.join(f'{t} {n}' for t, n in result.counts.items())})")
    console.print(result.markdown)
    console.print(f"report: {out / 'report.md'}; Octopi's table: {out / 'octopi.md'}")
