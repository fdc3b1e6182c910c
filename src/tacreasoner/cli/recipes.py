"""Whole workflows in one command: ``quickstart`` (the recommended DynTAC-Sim model from nothing) and
``recipe physiclear`` (the recommended real-data model on a PhysiCLeAR-shaped folder)."""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Annotated

import typer

from tacreasoner.cli.app import (
    Overrides,
    Workers,
    app,
    at_least_one,
    cli_errors,
    console,
    needs_train_extra,
    parse_overrides,
)
from tacreasoner.progress import StageProgress
from tacreasoner.recipes.quickstart import QUICKSTART_DIR


@app.command()
@cli_errors
def quickstart(
    out: Annotated[Path, typer.Option("--out", help="Run directory (re-running resumes).")] = QUICKSTART_DIR,
    objects: Annotated[int | None, typer.Option("--objects", help="Simulated objects (default: quickstart.yaml's).",
                                                show_default=False)] = None,
    repeats: Annotated[int | None, typer.Option("--repeats", help="Clips per object (default: quickstart.yaml's).",
                                                show_default=False)] = None,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the simulation, the splits and the first training.")] = 0,
    workers: Workers = None,
    overwrite: Annotated[bool, typer.Option("--overwrite", help="Simulate again instead of resuming.")] = False,
    seeds: Annotated[int, typer.Option("--seeds", help="Training seeds (Stage I + II each); the report gives mean ± "
                                                       "std over them.")] = 1,
    train_model: Annotated[bool, typer.Option("--train/--no-train", help="Train Stage I + II, evaluate and ask (off: "
                                                                          "data stages only).")] = True,
    processes: Annotated[int, typer.Option("--processes", help="Training processes (CPU DDP via torch.distributed."
                                                               "run, same global batch), for machines with more "
                                                               "cores: one process already uses 2 cores.")] = 1,
    llm: Annotated[Path | None, typer.Option("--llm", help="An LLM folder to use instead of getting SmolLM2.",
                                             show_default=False)] = None,
    config: Annotated[Path | None, typer.Option("--config", help="Training config (default: the shipped "
                                                "quickstart-smollm2-cpu).", show_default=False)] = None,
    overrides: Overrides = None,
) -> None:
    """The recommended DynTAC-Sim model from nothing, on this machine: simulate → benchmark → baselines → SmolLM2 →
    EfficientNet-Lite0 encoder → gel swap → Stage I → Stage II → held-out test objects scored → report → ask (resumable:
    re-running skips finished work). Settings: the package's recipes/quickstart.yaml."""
    from tacreasoner.recipes.quickstart import QuickstartRun, run_quickstart

    if train_model:
        needs_train_extra("quickstart")
        from transformers.utils import logging as hf_logging

        hf_logging.disable_progress_bar()  # the stages print their own progress; no tqdm bars in a piped log
    run = QuickstartRun(out, objects=objects, repeats=repeats, seed=seed, seeds=seeds, workers=workers,
                        overwrite=overwrite, train=train_model, processes=processes, llm=llm, config=config,
                        overrides=parse_overrides(overrides))
    with StageProgress() as bars:
        minutes = run_quickstart(run, say=functools.partial(console.print, markup=False),
                                 progress=lambda label: functools.partial(bars, label))
    if not train_model:
        console.print(f"\nQuickstart data stages finished in {out} ({minutes:.1f} min).")
        return
    console.print(f"\nQuickstart finished in {minutes:.1f} min: {out}/report.md (results), {out}/model (trained "
                  f"model), eval/ (per-item predictions). Ask it yourself:\n  tacreasoner ask --model {out / 'model'} "
                  f"\"Is <tactile> real or fake?\" --video <clip.mp4>")


recipe_app = typer.Typer(help="Whole workflows in one command.", no_args_is_help=True)
app.add_typer(recipe_app, name="recipe")


@recipe_app.command("physiclear")
@cli_errors
def recipe_physiclear_cmd(
    data: Annotated[Path | None, typer.Option("--data", help="A PhysiCLeAR-shaped folder (labels.json + videos/) with "
                                              "train objects (default: the shared PhysiCLeAR copy).",
                                              show_default=False)] = None,
    out: Annotated[Path, typer.Option("--out", help="Run folder (resumable).")] = Path("runs/physiclear-recipe"),
    seeds: Annotated[int, typer.Option("--seeds", help="Seeds to train (0, 1, ...); val is scored over all.")] = 1,
    seed: Annotated[int, typer.Option("--seed", help="The first seed.")] = 0,
    llm: Annotated[Path | None, typer.Option("--llm", help="An LLM folder to use instead of getting SmolLM2 "
                                             "(e.g. runs/smollm2).", show_default=False)] = None,
    config: Annotated[Path | None, typer.Option("--config", help="Training config (default: the shipped "
                                                "physiclear-smollm2-cpu).", show_default=False)] = None,
    overrides: Overrides = None,
    evaluate: Annotated[bool, typer.Option("--evaluate/--no-evaluate", help="Score the folder's val objects.")] = True,
) -> None:
    """The recommended real-data recipe, end to end: SmolLM2 + EfficientNet-Lite0 encoder, Octopi's task set, Stage I
    and II, val scored in the benchmark's and in held-out wordings (as shipped about 47 minutes per seed on a
    2-core Intel Xeon without bf16, under 4 on one H100; docs/real-data.md, "Measured")."""
    needs_train_extra("recipe physiclear")
    at_least_one("--seeds", seeds)
    from tacreasoner.data.readers import default_physiclear_dir
    from tacreasoner.recipes.physiclear import run_recipe

    if data is None:
        data = default_physiclear_dir()
        if data is None:
            raise ValueError("no --data given and no PhysiCLeAR copy found (set TACREASONER_PHYSICLEAR)")
    with StageProgress() as bars:
        record = run_recipe(data, out, seeds=[seed + k for k in range(seeds)], llm=llm, config=config,
                            overrides=parse_overrides(overrides), evaluate=evaluate, say=console.print,
                            progress=lambda label: functools.partial(bars, label))
    console.print((out / "report.md").read_text(encoding="utf-8"))
    console.print(f"{record['minutes_total']} minutes; report {out / 'report.md'}; models under {out / 'train'}")
