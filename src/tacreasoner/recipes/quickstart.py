"""``tacreasoner quickstart``: the recommended DynTAC-Sim model, trained and scored from nothing on this machine.

simulate → preview → benchmark → baselines → LLM → encoder (→ gel swap) → Stage I + II per seed → held-out test
objects answered and scored → report → one question asked. The settings are package data: ``quickstart.yaml``
(simulation, encoder, evaluation) and the training config it names (``quickstart-smollm2-cpu.yaml``), so the
command works from any directory and the documented recipe is the one that runs. Every stage is safe to re-run:
finished work is skipped, interrupted training resumes.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tacreasoner.recipes.quickstart_parts import QuickstartPaths
from tacreasoner.yamlfile import read_yaml

__all__ = ["GEL_REFERENCES", "QUICKSTART_DIR", "QUICKSTART_SETTINGS", "QuickstartPaths", "QuickstartRun",
           "QuickstartSettings", "Stage",
           "quickstart_config", "quickstart_stages", "run_quickstart", "run_stages"]

QUICKSTART_DIR = Path("runs/quickstart")
"""Where the quickstart writes by default (and where ``ask``/``serve``/``demo`` look for its model)."""
QUICKSTART_SETTINGS = Path(__file__).with_name("quickstart.yaml")
"""The quickstart's own settings (shipped with the package)."""
GEL_REFERENCES = ("train", "none")
"""``quickstart.yaml``'s ``encoder.gel_reference``: measured on the run's train clips, or no colour map."""
GEL_SWAPS = ("imprint", "gate", "none")
"""``quickstart.yaml``'s ``encoder.gel_swap``: every clip's gel at rest swapped for the train clips' in training and
answering, another sensor's only when answering, or never."""

Say = Callable[[str], None]
Progress = Callable[[str], Callable[[int, int], None]]


@dataclass(frozen=True)
class QuickstartSettings:
    """``quickstart.yaml``: what to simulate, the encoder's frame preparation, the training config, evaluation."""

    objects: int
    repeats: int
    sensors: list[str]
    encoder: dict[str, Any]
    train_config: str
    llm: str
    eval_batch_size: int
    max_new_tokens: int
    eval_dtype: str = "float32"
    answers: str = "direct"
    """How ``ask``/``serve``/``demo`` answer the published model by default (recorded in its folder)."""
    gel_reference: str = "none"
    """``train``: after training, each model records its sensor's gel at rest measured on train clips
    (``video.gel_reference``), so the clips it answers are colour-mapped to it; ``none``: frames as trained."""
    gel_swap: str = "none"
    """``gate`` (with ``gel_reference: train``): each model also records the train clips' average gel at rest and
    swaps it in for a clip lit unlike any train clip, another sensor's (``video.gel_image``, ``gel_swap_above``).
    ``imprint``: that average is swapped into every clip's frames before training too (a ``swap`` stage), and each
    model answers with the clip's change from its own rest added at its own scale (``video.gel_swap: imprint``)."""

    @classmethod
    def load(cls, path: Path = QUICKSTART_SETTINGS) -> QuickstartSettings:
        from tacreasoner.evaluate.predict import check_answers, check_dtype

        data, _ = read_yaml(path)
        try:
            sim, train, evaluate = data["simulate"], data["train"], data["evaluate"]
            encoder = dict(data["encoder"])
            gel = str(encoder.pop("gel_reference", "none"))
            if gel not in GEL_REFERENCES:
                raise ValueError(f"encoder.gel_reference must be one of {', '.join(GEL_REFERENCES)}, got {gel!r}")
            if gel == "train" and encoder.get("background", "keep") != "keep":
                raise ValueError("encoder.gel_reference 'train' needs background 'keep' (a subtracted frame has no "
                                 "gel colours left to map)")
            swap = str(encoder.pop("gel_swap", "none"))
            if swap not in GEL_SWAPS:
                raise ValueError(f"encoder.gel_swap must be one of {', '.join(GEL_SWAPS)}, got {swap!r}")
            if swap != "none" and gel != "train":
                raise ValueError(f"encoder.gel_swap {swap!r} needs gel_reference 'train' (the gel at rest is swapped "
                                 "after the colours are mapped)")
            return cls(objects=int(sim["objects"]), repeats=int(sim["repeats"]), sensors=list(sim["sensors"]),
                       encoder=encoder, gel_reference=gel, gel_swap=swap, train_config=str(train["config"]),
                       llm=str(train["llm"]),
                       eval_batch_size=int(evaluate["batch_size"]), max_new_tokens=int(evaluate["max_new_tokens"]),
                       eval_dtype=str(check_dtype(evaluate.get("dtype", "float32"))),
                       answers=check_answers(str((data.get("serve") or {}).get("answers", "direct"))))
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"{path}: not a quickstart settings file ({exc})") from None


def quickstart_config(paths: QuickstartPaths, seed: int, config: str | Path | None = None,
                      overrides: dict[str, Any] | None = None) -> Any:
    """The training config of one seed (the shipped one, or ``config``) pointed at this run folder's parts."""
    return paths.train_config(seed, config or QuickstartSettings.load().train_config, overrides)


@dataclass(frozen=True)
class Stage:
    """One named step; ``run`` returns the lines that say what it produced."""

    name: str
    purpose: str
    run: Callable[[], list[str]]


def run_stages(stages: list[Stage], say: Say = print) -> None:
    """Run stages in order, announcing and timing each."""
    for number, stage in enumerate(stages, 1):
        say(f"[{number}/{len(stages)}] {stage.name}: {stage.purpose}")
        start = time.perf_counter()
        for line in stage.run():
            say(f"    {line}")
        say(f"    done in {time.perf_counter() - start:.1f} s")


@dataclass
class QuickstartRun:
    """The options of one ``tacreasoner quickstart`` (None: quickstart.yaml's value)."""

    out: Path
    objects: int | None = None
    repeats: int | None = None
    seed: int = 0
    seeds: int = 1
    workers: int | None = None
    overwrite: bool = False
    train: bool = True
    processes: int = 1
    llm: Path | None = None
    config: str | Path | None = None
    overrides: dict[str, Any] = field(default_factory=dict)

    def check(self) -> None:
        for option, value in (("--objects", self.objects), ("--repeats", self.repeats), ("--workers", self.workers),
                              ("--seeds", self.seeds), ("--processes", self.processes)):
            if value is not None and value < 1:
                raise ValueError(f"{option} must be at least 1, got {value}")
        if self.llm is not None and not (self.llm / "config.json").is_file():
            raise FileNotFoundError(f"--llm {self.llm}: not a Hugging Face model folder (no config.json)")


def quickstart_stages(run: QuickstartRun, settings: QuickstartSettings | None = None, *,
                      progress: Progress | None = None) -> list[Stage]:
    """The quickstart's stages for ``run`` (data stages only when ``run.train`` is off)."""
    from tacreasoner.recipes import quickstart_parts as parts

    settings = settings or QuickstartSettings.load()
    paths = QuickstartPaths(run.out, run.llm)
    objects, repeats = run.objects or settings.objects, run.repeats or settings.repeats
    stages = [
        Stage("simulate", f"DynTAC-Sim: {objects} objects x {repeats} clips → {paths.sim}",
              lambda: parts.simulate(paths, objects, repeats, settings.sensors, run.seed, run.workers,
                                     run.overwrite)),
        Stage("preview", f"contact sheets + ground-truth plots → {paths.preview}", lambda: parts.preview(paths)),
        Stage("benchmark", f"DynTAC-Sim-Bench QA items, split by object → {paths.bench}",
              lambda: parts.bench(paths, run.seed)),
        Stage("baselines", f"random and majority answers scored on the test split → {paths.baselines}",
              lambda: parts.baselines(paths, run.seed)),
    ]
    if not run.train:
        return stages
    seeds = [run.seed + k for k in range(run.seeds)]
    from tacreasoner.train.precision import describe_precision  # imports torch: only where training follows

    precision = describe_precision(quickstart_config(paths, seeds[0], run.config or settings.train_config,
                                                     run.overrides).runtime.mixed_precision)
    trained: dict[int, Path] = {}
    timings: dict[str, Any] = {}

    def train_all() -> list[str]:
        from tacreasoner.train.run import train_stages

        lines = []
        for seed in seeds:
            config = quickstart_config(paths, seed, run.config or settings.train_config, run.overrides)
            info = train_stages(config, run.processes)
            trained[seed] = Path(info["model"])
            timings[f"seed{seed}"] = info["seconds"]
            took = ", ".join(f"{k} {v:.0f} s" for k, v in info["seconds"].items()) or "already trained"
            lines.append(f"seed {seed}: {took} → {info['model']}")
        return lines

    def evaluate_all() -> list[str]:
        from tacreasoner.recipes.quickstart_report import evaluate_and_report

        report = evaluate_and_report(paths, trained, timings, batch_size=settings.eval_batch_size,
                                     max_new_tokens=settings.max_new_tokens, dtype=settings.eval_dtype,
                                     progress=progress, answers=settings.answers,
                                     gel_reference=settings.gel_reference, gel_swap=settings.gel_swap)
        return [*report.summary_lines, f"report: {report.path}"]

    def ask() -> list[str]:
        from tacreasoner.recipes.quickstart_report import ask_one_test_clip

        return ask_one_test_clip(paths, settings.max_new_tokens)

    llm_source = f"{paths.llm} (given)" if run.llm else f"SmolLM2-135M-Instruct from its package → {paths.llm}"
    return [
        *stages,
        Stage("llm", llm_source, lambda: parts.llm(paths, settings.llm, given=run.llm is not None)),
        Stage("encoder", f"appearance encoder: EfficientNet-Lite0's ImageNet weights (frozen) → {paths.encoder}",
              lambda: parts.encoder(paths, settings.encoder)),
        *([Stage("swap", "colour map + the train clips' average gel at rest into the frames training reads → "
                 f"{paths.encoder / 'video_processing.json'}", lambda: parts.swap_in_training(paths))]
          if settings.gel_swap == "imprint" else []),
        Stage("train", f"Stage I (alignment) + Stage II (LoRA SFT), seeds {seeds}, {precision} → {run.out / 'train'}",
              train_all),
        Stage("evaluate", f"held-out test objects, strict answer extraction → {paths.evaluation}", evaluate_all),
        Stage("ask", "one held-out test clip, answered by the trained model", ask),
    ]


def run_quickstart(run: QuickstartRun, *, say: Say = print, progress: Progress | None = None) -> float:
    """Run every stage of ``run``; returns the minutes it took."""
    run.check()
    started = time.perf_counter()
    run_stages(quickstart_stages(run, progress=progress), say)
    return (time.perf_counter() - started) / 60
