"""The training half of ``tacreasoner quickstart``: Stage I → Stage II per seed → evaluation → report.

The quickstart's earlier stages (simulate, benchmark, TouchCoT, pre-training) leave everything in one
run directory; this module trains on it with ``configs/tiny-cpu.yaml``'s settings (embedded here so the
command works from any directory), answers the held-out test objects (and the held-out sensor when the
benchmark has one) with each seed's model, and writes one report with mean ± std over seeds.
Every step resumes: a finished stage or prediction file is not redone.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from tacreasoner.train.config import TrainConfig

__all__ = ["QuickstartPaths", "distributed_config", "evaluate_seeds", "quickstart_config", "train_seed"]

TINY_SETTINGS: dict[str, Any] = {
    "model": {"encoder": {"use_temporal": True, "question_conditioning": True, "tokens_per_video": 5,
                          "cross_video": 3, "clip_reader": True},
              "attn_implementation": "eager"},
    "stage1": {"steps": 1800, "batch_size": 16, "lr": 1e-3, "warmup_ratio": 0.05},
    "stage2": {"steps": 1000, "batch_size": 8, "lr": 2e-3, "projector_lr": 1e-3, "warmup_ratio": 0.05},
    "lora": {"r": 128, "alpha": 256, "dropout": 0.05},
    "data": {"max_length": 768, "group_by_length": False,
             "repeat": {"OSC": 4, "SFD": 2, "SOI": 2, "RFOR": 2, "OCSE": 2, "TFA-combined": 2}},
    "runtime": {"mixed_precision": "auto", "log_with": "tensorboard", "log_every": 10, "checkpoint_every": 50},
}
"""The tiny default (the same values as configs/tiny-cpu.yaml; a test keeps the two in step)."""


@dataclass(frozen=True)
class QuickstartPaths:
    root: Path

    @property
    def bench(self) -> Path:
        return self.root / "bench"

    @property
    def touchcot(self) -> Path:
        return self.root / "touchcot" / "touchcot" / "touchcot_train.jsonl"

    @property
    def llm(self) -> Path:
        return self.root / "llm"

    @property
    def encoder(self) -> Path:
        return self.root / "encoder"

    def train(self, seed: int) -> Path:
        return self.root / "train" / f"seed{seed}"

    @property
    def evaluation(self) -> Path:
        return self.root / "eval"

    @property
    def model(self) -> Path:
        return self.root / "model"

    @property
    def video_cache(self) -> Path:
        return self.root / "video_cache"


def quickstart_config(paths: QuickstartPaths, seed: int, overrides: dict[str, dict[str, Any]] | None = None,
                      output_dir: Path | None = None) -> TrainConfig:
    """The tiny-CPU config pointed at a quickstart run directory (``overrides`` per section: ablations)."""
    data: dict[str, Any] = {"output_dir": str(output_dir or paths.train(seed)), "seed": seed,
                            "model": {"llm": str(paths.llm), "appearance": str(paths.encoder)},
                            "data": {"bench": str(paths.bench), "touchcot": str(paths.touchcot),
                                     "video_cache": str(paths.video_cache)}}
    for section, values in [*TINY_SETTINGS.items(), *(overrides or {}).items()]:
        if not isinstance(values, dict):
            data[section] = values
            continue
        merged = {**data.get(section, {}), **values}
        if section == "model" and "encoder" in values:  # an encoder switch keeps the other encoder settings
            merged["encoder"] = {**data.get("model", {}).get("encoder", {}), **values["encoder"]}
        data[section] = merged
    return TrainConfig.from_dict(data, source="quickstart settings")


def _stage_done(config: TrainConfig, stage: int) -> bool:
    run = config.stage_dir(stage) / "run.json"
    return run.is_file() and "steps_done" in json.loads(run.read_text(encoding="utf-8"))


def train_seed(config: TrainConfig, processes: int = 1) -> dict[str, Any]:
    """Stage I then Stage II of one config, each skipped when done and resumed when interrupted.

    ``processes > 1`` runs each stage as CPU DDP under ``torch.distributed.run`` with the same global batch:
    for CPUs with more cores than one process's threads use well (on 2 cores it gains nothing, docs/training.md).
    """
    from tacreasoner.train.trainer import MODEL_DIR, train_stage

    if processes < 1:
        raise ValueError(f"processes must be at least 1, got {processes}")
    seconds: dict[str, float] = {}
    for stage in (1, 2):
        if config.stage(stage).skip or _stage_done(config, stage):
            continue
        start = time.perf_counter()
        if processes > 1:
            _train_stage_distributed(config, stage, processes)
        else:
            train_stage(config, stage, resume=True)
        seconds[f"stage{stage}"] = round(time.perf_counter() - start, 1)
    final = 2 if not config.stage2.skip else 1
    return {"model": str(config.stage_dir(final) / MODEL_DIR), "seconds": seconds}


def distributed_config(config: TrainConfig, stage: int, processes: int) -> TrainConfig:
    """``config`` split over ``processes`` ranks: the same global batch, one thread each."""
    settings = config.stage(stage)
    data = config.to_dict()
    data[f"stage{stage}"]["global_batch"] = settings.global_batch or settings.batch_size * settings.grad_accum
    data["runtime"]["threads"] = 1
    split = TrainConfig.from_dict(data, source=f"quickstart settings over {processes} processes")
    split.stage(stage).micro_batch(f"stage{stage}", processes)  # refuses a batch that does not split evenly
    return split


def _train_stage_distributed(config: TrainConfig, stage: int, processes: int) -> None:
    split = distributed_config(config, stage, processes)
    launch = config.stage_dir(stage).with_name(f"stage{stage}.launch.yaml")
    launch.parent.mkdir(parents=True, exist_ok=True)
    launch.write_text(yaml.safe_dump(split.to_dict(), sort_keys=False), encoding="utf-8")
    # --standalone: a local rendezvous on a free port, so no port is chosen (or raced for) here
    cmd = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node", str(processes),
           "-m", "tacreasoner", "train", "--stage", str(stage), "--config", str(launch), "--resume"]
    env = {**os.environ, "OMP_NUM_THREADS": "1", "TOKENIZERS_PARALLELISM": "false"}
    done = subprocess.run(cmd, env=env)
    if done.returncode != 0:
        raise RuntimeError(f"stage {stage} over {processes} processes failed (exit code {done.returncode}); "
                           f"its output is above. Re-run to resume, or use --processes 1")


def evaluate_seeds(models: dict[int, Path], bench: Path, out: Path, splits: tuple[str, ...] = ("test",), *,
                   batch_size: int = 48, max_new_tokens: int = 256, video_cache: Path | None = None,
                   progress: Callable[[str], Callable[[int, int], None]] | None = None) -> dict[str, Any]:
    """Answer each split with each seed's model; one report per split (mean ± std over seeds)."""
    from tacreasoner.evaluate.predict import answerer_id, load_trained, predict_items, set_aside_stale
    from tacreasoner.evaluate.report import evaluate
    from tacreasoner.tasks.bench import load_bench
    from tacreasoner.train.data import bench_video_root

    reports: dict[str, Any] = {}
    for split in splits:
        info, items = load_bench(bench, split)
        files = []
        for seed, model_dir in sorted(models.items()):
            path = out / split / "predictions" / f"seed{seed}.jsonl"
            who = answerer_id(model_dir, bench)
            set_aside_stale(path, who)
            if not _complete(path, len(items)):
                model, processor = load_trained(model_dir)
                predict_items(model, processor, items, bench_video_root(bench, info), path, batch_size=batch_size,
                              max_new_tokens=max_new_tokens, video_cache=video_cache, answered_by=who,
                              progress=None if progress is None else progress(f"{split}, seed {seed}"))
            files.append(path)
        reports[split] = evaluate(items, files, "strict", out / split)
    return reports


def _complete(path: Path, n: int) -> bool:
    return path.is_file() and sum(1 for line in path.open(encoding="utf-8") if line.strip()) >= n


def publish_model(model_dir: Path, target: Path) -> Path:
    """Copy the seed-0 model to ``target`` (what ``tacreasoner ask`` uses by default)."""
    if target.exists():
        shutil.rmtree(target)
    shutil.copytree(model_dir, target)
    return target


@dataclass
class QuickstartReport:
    path: Path
    summary_lines: list[str]
    beats_chance: dict[str, dict[str, bool]]


def _baseline_accuracy(root: Path, kind: str) -> dict[str, float]:
    path = root / "baselines" / kind / "report.json"
    if not path.is_file():
        return {}
    return {t["task"]: t["accuracy"] for t in json.loads(path.read_text(encoding="utf-8"))["tasks"]}


def results_table(report: Any, baselines: dict[str, dict[str, float]]) -> tuple[list[str], dict[str, bool]]:
    """Markdown rows: per task, the model (mean ± std over seeds, Wilson CI), baselines, chance, verdict.

    "Beats chance" means the Wilson 95% lower bound is above the task's chance level.
    """
    head = ["Task", "n", "Model (mean ± std)", "95% CI", "Parse fail", *[f"{k.capitalize()}" for k in baselines],
            "Chance", "Beats chance"]
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join(["---"] + ["---:"] * (len(head) - 1)) + "|"]
    verdict = {}
    for r in report.tasks:
        verdict[r.task] = bool(r.ci_low > r.chance)
        std = "" if r.std is None or r.std != r.std else f" ± {100 * r.std:.1f}"
        cells = [r.task, str(r.n), f"{100 * r.mean:.1f}{std}", f"{100 * r.ci_low:.1f}–{100 * r.ci_high:.1f}",
                 f"{100 * r.parse_failure_rate:.1f}",
                 *[f"{100 * b[r.task]:.1f}" if r.task in b else "–" for b in baselines.values()],
                 f"{100 * r.chance:.1f}", "yes" if verdict[r.task] else "**no**"]
        lines.append("| " + " | ".join(cells) + " |")
    avg = report.average
    std = "" if avg.get("std") is None or avg["std"] != avg["std"] else f" ± {100 * avg['std']:.1f}"
    lines.append(f"| **Average** | | **{100 * avg['value']:.1f}{std}** | | | " + " | ".join("" for _ in baselines)
                 + " | | |")
    return lines, verdict


def _what_training_saw(paths: QuickstartPaths) -> str:
    """The report's claim about test objects, read from what the encoder's pre-training recorded it read."""
    from tacreasoner.train.pretrain_encoder import splits_seen

    if (paths.encoder / "source.json").is_file():
        return ("No val or test clip was seen in any training: the appearance encoder holds ImageNet weights "
                "(EfficientNet-Lite0), trained on no tactile clip.")
    seen = splits_seen(paths.encoder)
    if seen is None:
        return ("Stages I and II never saw a test object; the encoder's pre-training did not record which splits it "
                "read.")
    text = ", ".join(f"{split} {n}" for split, n in seen.items())
    evaluation = sorted(set(seen) - {"train", "unlabelled"})
    if evaluation:
        return (f"Stages I and II never saw a test object, but the encoder's pre-training read "
                f"{' and '.join(evaluation)} clips (clips per split: {text}).")
    return (f"No val or test clip was seen in any training, the encoder's pre-training included (clips per split: "
            f"{text}).")


def evaluate_and_report(paths: QuickstartPaths, models: dict[int, Path], timings: dict[str, Any], *,
                        progress: Callable[[str], Callable[[int, int], None]] | None = None) -> QuickstartReport:
    """Evaluate every seed's model on the test split(s) and write ``report.md`` + ``report.json``."""
    import platform
    from datetime import datetime, timezone

    splits = ("test", "test_heldout_sensor") if (paths.bench / "test_heldout_sensor.jsonl").is_file() else ("test",)
    started = time.perf_counter()
    reports = evaluate_seeds(models, paths.bench, paths.evaluation, splits, progress=progress,
                             video_cache=paths.video_cache)
    eval_seconds = round(time.perf_counter() - started, 1)
    baselines = {k: _baseline_accuracy(paths.root, k) for k in ("random", "majority")}
    baselines = {k: v for k, v in baselines.items() if v}
    lines = ["# Quickstart results: TacReasoner (tiny) on DynTAC-Sim-Bench", "",
             f"- Date: {datetime.now(timezone.utc).strftime('%Y-%m-%d %H:%M UTC')}",
             f"- Machine: {platform.processor() or platform.machine()}, {_cores()} cores, Python "
             f"{platform.python_version()}",
             "- Command: `tacreasoner quickstart`",
             f"- Seeds: {sorted(models)} (Stage I + Stage II trained per seed); training seconds per seed: "
             f"{json.dumps(timings)}; evaluation {eval_seconds} s",
             "", "DynTAC-Sim-Bench is simulated: the project's stand-in for the paper's DynTAC-Bench, not its data. "
             f"{_what_training_saw(paths)} TSA (scenario choice) is zero-shot: never trained on. "
             "Strict answer extraction: a reply not in `<think>…</think><answer>…</answer>` form counts as wrong.", ""]
    summary, verdicts = [], {}
    for split, report in reports.items():
        rows, verdict = results_table(report, baselines if split == "test" else {})
        verdicts[split] = verdict
        title = "Held-out test objects" if split == "test" else "Held-out test objects, held-out sensor style"
        lines += [f"## {title} (`{split}`)", "", *rows, ""]
        weak = [t for t, ok in verdict.items() if not ok]
        summary.append(f"{split}: Average {100 * report.average['value']:.1f}% over {len(report.tasks)} tasks; "
                       + ("every task above chance (Wilson lower bound)" if not weak else
                          f"not above chance: {', '.join(weak)}"))
    lines += ["Per-item predictions: `eval/<split>/predictions/seed*.jsonl`; full reports with plots: "
              "`eval/<split>/report.md`.", ""]
    path = paths.root / "report.md"
    path.write_text("\n".join(lines), encoding="utf-8")
    (paths.root / "report.json").write_text(json.dumps(
        {"splits": {s: r.to_dict() for s, r in reports.items()}, "beats_chance": verdicts, "timings": timings,
         "eval_seconds": eval_seconds, "seeds": sorted(models)}, indent=2, default=str) + "\n", encoding="utf-8")
    if models:
        publish_model(Path(models[min(models)]), paths.model)
    return QuickstartReport(path, summary, verdicts)


def _cores() -> int:
    import os

    return os.cpu_count() or 1


def _as_typed(path: Path) -> str:
    """The path as a user in this directory would type it, so the printed command can be pasted."""
    try:
        return str(Path(path).resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def ask_one_test_clip(paths: QuickstartPaths) -> list[str]:
    """Ask the published model one real-or-fake question about a held-out test clip."""
    from tacreasoner.evaluate.predict import load_trained
    from tacreasoner.tasks.bench import load_bench
    from tacreasoner.train.data import bench_video_root

    info, items = load_bench(paths.bench, "test")
    item = next((i for i in items if i.task == "RFOR"), items[0])
    video = bench_video_root(paths.bench, info) / str(item.videos[0].path)
    model, processor = load_trained(paths.model)
    reply = model.answer(processor, item.question, [str(video)])
    return [f"$ tacreasoner ask --model {_as_typed(paths.model)} {json.dumps(item.question)} "
            f"--video {_as_typed(video)}",
            f"think:  {reply.think}", f"answer: {reply.answer}   (gold: {item.answer})"]
