"""Benchmarks from the command line: build one, re-word it, and score predictions with model-free baselines beside."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from tacreasoner.cli.app import Bench, Mode, Seed, Split, app, at_least_one, cli_errors, comma_list, console


@app.command("build-bench")
@cli_errors
def build_bench_cmd(
    source: Annotated[str, typer.Option("--source", help="sim, physiclear or vtv150k.")],
    out: Annotated[Path, typer.Option("--out", help="Benchmark directory to write.")],
    data: Annotated[Path | None, typer.Option(
        "--data", help="Source data: a simulator dataset, a PhysiCLeAR folder (default: ../shared/data/physiclear) "
                       "or a VTV-150K video folder.")] = None,
    ranks: Annotated[Path | None, typer.Option("--ranks", help="VTV-150K per-object rank table (JSON/CSV).")] = None,
    seed: Seed = 0,
    heldout_sensor: Annotated[str | None, typer.Option(
        "--heldout-sensor", help="Sensor kept out of train/val/test (sim; default: the last of several).")] = None,
    per_task: Annotated[int | None, typer.Option("--per-task", help="Items per task and split (default: "
                                                                    "about one per clip).")] = None,
    vocabulary: Annotated[str | None, typer.Option(
        "--vocabulary", help="Answer phrases: the source's own by default; physiclear for simulated clips asks them "
                             "in PhysiCLeAR's words and tasks (to train a real-data model beside them).",
        show_default=False)] = None,
    fractions: Annotated[str, typer.Option(
        "--fractions", help="Shares of the objects in train,val,test (an evaluation-only corpus can give val "
                            "and test more).")] = "0.7,0.15,0.15",
    keep_train_of: Annotated[Path | None, typer.Option(
        "--keep-train-of", help="A model's own benchmark: its train objects stay in train here, never in val or "
                                "test (a second simulated corpus starts with the same named objects).")] = None,
) -> None:
    """Build a benchmark directory: object-level splits, QA items per task, bench.json with counts."""
    from tacreasoner.data.readers import default_physiclear_dir
    from tacreasoner.tasks.bench import build_bench, train_objects_of

    at_least_one("--per-task", per_task)
    shares = _fractions(fractions)
    train_objects = train_objects_of(keep_train_of) if keep_train_of is not None else set()
    if data is None:
        if source != "physiclear":
            raise ValueError(f"--source {source} needs --data")
        data = default_physiclear_dir()
        if data is None:
            raise ValueError("PhysiCLeAR data not found: pass --data or set TACREASONER_PHYSICLEAR")
    if not data.exists():
        raise FileNotFoundError(f"{data}: no such directory")
    summary = build_bench(source, data, out, seed=seed, ranks=ranks, heldout_sensor=heldout_sensor,
                          per_task=per_task, vocabulary=vocabulary, fractions=shares, train_objects=train_objects)
    console.print(summary.table())
    for note in summary.notes:
        console.print(f"note: {note}")
    console.print(f"Benchmark written to {out}")


def _fractions(text: str) -> tuple[float, float, float]:
    try:
        shares = tuple(float(x) for x in comma_list(text))
    except ValueError:
        shares = ()
    if len(shares) != 3 or any(x < 0 for x in shares) or abs(sum(shares) - 1) > 1e-6:
        raise ValueError(f"--fractions {text!r}: expected three shares >= 0 for train,val,test summing to 1, "
                         f"e.g. 0.5,0.25,0.25")
    return shares  # type: ignore[return-value]


@app.command("paraphrase-bench")
@cli_errors
def paraphrase_bench_cmd(
    bench: Annotated[Path, typer.Option("--bench", help="A benchmark directory (build-bench).")],
    out: Annotated[Path, typer.Option("--out", help="The new benchmark directory.")],
    splits: Annotated[str, typer.Option("--splits", help="Comma-separated evaluation splits to re-word.")] = "val,test",
    wording: Annotated[str, typer.Option("--wording", help="heldout, heldout2 … heldout5 (sets written "
                                                          "later: tasks/paraphrases/heldout2.yaml … heldout5.yaml)."
                                                          )] = "heldout",
) -> None:
    """A copy of a benchmark's evaluation splits asked in held-out wordings (never used in training), to score how a
    model answers questions worded as a user would: `tacreasoner evaluate --bench OUT`."""
    from tacreasoner.tasks.bench import reword_bench
    from tacreasoner.tasks.paraphrase import HELDOUT_WORDINGS

    if wording not in HELDOUT_WORDINGS:
        raise ValueError(f"--wording must be one of {', '.join(HELDOUT_WORDINGS)}, got {wording!r}")
    counts = reword_bench(bench, out, wording=wording, splits=comma_list(splits))
    for split, tasks in counts.items():
        console.print(f"{split}: {sum(tasks.values())} items ({', '.join(f'{t} {n}' for t, n in tasks.items())})")
    console.print(f"held-out wordings: {out}")


@app.command()
@cli_errors
def baseline(
    bench: Bench,
    out: Annotated[Path, typer.Option("--out", help="Predictions JSONL to write.")],
    kind: Annotated[str, typer.Option("--kind", help="random or majority (of the train split's answers).")],
    split: Split = "val",
    seed: Seed = 0,
) -> None:
    """Write predictions of a model-free baseline, in the same format a model writes."""
    from tacreasoner.evaluate.baselines import predict, write_predictions
    from tacreasoner.tasks.bench import load_bench

    _, items = load_bench(bench, split)
    train = load_bench(bench, "train")[1] if kind == "majority" else []
    path = write_predictions(predict(items, kind, train=train, seed=seed), out)
    console.print(f"{len(items)} {kind} predictions of split {split} → {path}")


@app.command()
@cli_errors
def score(
    predictions: Annotated[list[Path], typer.Argument(help="Prediction JSONL file(s); several = several seeds.")],
    bench: Bench,
    split: Split = "val",
    mode: Mode = "strict",
    out: Annotated[Path | None, typer.Option("--out", help="Report directory (default: next to the "
                                                           "first predictions file).")] = None,
) -> None:
    """Score predictions: per-task accuracy, Wilson 95% CIs, parse failures, chance, Average (MD/CSV/JSON/PNG)."""
    from tacreasoner.evaluate.report import evaluate
    from tacreasoner.tasks.bench import load_bench

    _, items = load_bench(bench, split)
    out_dir = out or predictions[0].parent / f"{predictions[0].stem}_report"
    report = evaluate(items, predictions, mode, out_dir)
    console.print(report.to_markdown())
    console.print(f"scored split: {split} of {bench}; report files in {out_dir}")


@app.command()
@cli_errors
def compare(
    a: Annotated[Path, typer.Argument(help="Predictions JSONL of model A.")],
    b: Annotated[Path, typer.Argument(help="Predictions JSONL of model B.")],
    bench: Bench,
    split: Split = "val",
    mode: Mode = "strict",
    out: Annotated[Path | None, typer.Option("--out", help="Directory for comparison.md/json.")] = None,
) -> None:
    """Paired exact McNemar test between two prediction files on the same benchmark items."""
    from tacreasoner.evaluate.report import compare_prediction_files, write_comparison

    comparison = compare_prediction_files(a, b, bench, split, mode)
    console.print(f"split: {split} of {bench}")
    console.print(comparison.to_markdown())
    if out is not None:
        paths = write_comparison(comparison, out)
        console.print("wrote " + ", ".join(str(p) for p in paths.values()))
