"""Training from the command line: ``train`` (Stage I or II of a config) and ``memory-plan`` (will it fit)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from tacreasoner.cli.app import Overrides, app, at_least_one, cli_errors, console, needs_train_extra, parse_overrides


@app.command()
@cli_errors
def train(
    stage: Annotated[int, typer.Option("--stage", help="1 = alignment (LLM frozen), 2 = LoRA SFT on TouchCoT.")],
    config: Annotated[Path, typer.Option("--config", help="YAML training config, or the name of a shipped one "
                                                          "(quickstart-smollm2-cpu, physiclear-smollm2-cpu).")],
    overrides: Overrides = None,
    resume: Annotated[bool, typer.Option("--resume", help="Continue from the newest checkpoint.")] = False,
) -> None:
    """Train Stage I or II (Accelerate: CPU, GPU, DDP/FSDP/DeepSpeed via `accelerate launch`); resumable."""
    needs_train_extra("train")
    from tacreasoner.train.config import load_train_config
    from tacreasoner.train.trainer import check_inputs, train_stage

    cfg = load_train_config(config, parse_overrides(overrides))
    check_inputs(cfg, stage)
    result = train_stage(cfg, stage, resume=resume)
    loss = "–" if result.final_loss is None else f"{result.final_loss:.4f}"
    console.print(f"stage {stage}: {result.steps} steps on {result.examples} examples, final loss {loss}, "
                  f"{result.train_seconds:.0f} s training; model: {result.model_dir}")


@app.command("memory-plan")
@cli_errors
def memory_plan_cmd(
    config: Annotated[Path, typer.Option("--config", help="YAML training config (e.g. configs/qwen2.5-7b.yaml) or a "
                                                          "shipped one's name.")],
    stage: Annotated[int, typer.Option("--stage", help="1 = alignment (LLM frozen), 2 = LoRA SFT.")] = 2,
    world_size: Annotated[list[int] | None, typer.Option(
        "--world-size", help="GPUs training together (repeatable: one column each, e.g. 1, 2, 8).",
        show_default="1")] = None,
    engine: Annotated[str, typer.Option("--engine", help="ddp, fsdp, deepspeed-zero2 or deepspeed-zero3.")] = "ddp",
    gpu_gb: Annotated[float, typer.Option("--gpu-gb", help="Memory of one GPU in GB.")] = 80.0,
    llm: Annotated[str | None, typer.Option(
        "--llm", help="The LLM's shape: qwen2.5-7b, qwen2.5-14b or a local model directory with config.json "
                      "(default: the config's model.llm).", show_default=False)] = None,
    answer_fraction: Annotated[float, typer.Option(
        "--answer-fraction", help="Share of positions that are answer tokens, where the loss computes logits "
                                  "(1 = the worst case).")] = 1.0,
    overrides: Overrides = None,
) -> None:
    """Per-GPU memory of a training stage (weights, gradients, AdamW, activations) against the GPU; no download."""
    from tacreasoner.train.memory_plan import ENGINES

    sizes = world_size or [1]
    for n in sizes:
        at_least_one("--world-size", n)
    if engine not in ENGINES:
        raise ValueError(f"--engine {engine!r} is not one of {', '.join(ENGINES)}")
    if stage not in (1, 2):
        raise ValueError(f"--stage must be 1 or 2, got {stage}")
    if not gpu_gb > 0:
        raise ValueError(f"--gpu-gb must be a positive number, got {gpu_gb}")
    if not 0 < answer_fraction <= 1:
        raise ValueError(f"--answer-fraction must be in (0, 1], got {answer_fraction}")
    needs_train_extra("memory-plan")
    from tacreasoner.train.config import load_train_config
    from tacreasoner.train.memory_plan import plan_for_config, render_plans

    cfg = load_train_config(config, parse_overrides(overrides))
    plans = plan_for_config(cfg, stage=stage, engine=engine, world_sizes=sizes, llm=llm, gpu_gb=gpu_gb,
                            answer_fraction=answer_fraction)
    console.print(render_plans(plans), markup=False)
