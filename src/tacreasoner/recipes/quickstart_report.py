"""The quickstart's last stages: every seed's model answers the held-out test objects, one report with mean ± std
over seeds beside the model-free baselines, and one question asked the way a user would ask it."""

from __future__ import annotations

import json
import shutil
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tacreasoner.recipes.machine import machine_line
from tacreasoner.recipes.quickstart_parts import QuickstartPaths

__all__ = ["QuickstartReport", "ask_one_test_clip", "evaluate_and_report", "evaluate_seeds", "results_table"]


def evaluate_seeds(models: dict[int, Path], bench: Path, out: Path, splits: tuple[str, ...] = ("test",), *,
                   batch_size: int = 48, max_new_tokens: int = 512, video_cache: Path | None = None,
                   dtype: str | None = None,
                   progress: Callable[[str], Callable[[int, int], None]] | None = None) -> dict[str, Any]:
    """Answer each split with each seed's model (weights cast to ``dtype``); one report per split (mean ± std over
    seeds)."""
    from tacreasoner.evaluate.predict import answer_with_model, answerer_id, set_aside_stale
    from tacreasoner.evaluate.report import evaluate
    from tacreasoner.tasks.bench import load_bench

    reports: dict[str, Any] = {}
    for split in splits:
        info, items = load_bench(bench, split)
        files = []
        for seed, model_dir in sorted(models.items()):
            path = out / split / "predictions" / f"seed{seed}.jsonl"
            set_aside_stale(path, answerer_id(model_dir, bench, dtype))  # the quickstart owns its folder
            answer_with_model(model_dir, bench, info, items, path, batch_size=batch_size,
                              max_new_tokens=max_new_tokens, video_cache=video_cache, dtype=dtype,
                              progress=None if progress is None else progress(f"{split}, seed {seed}"))
            files.append(path)
        reports[split] = evaluate(items, files, "strict", out / split)
    return reports


def publish_model(model_dir: Path, target: Path, answers: str | None = None) -> Path:
    """Copy the seed-0 model to ``target`` (what ``tacreasoner ask`` uses by default), recording ``answers`` in it
    as its recommended answering mode."""
    from tacreasoner.model.processing import record_answers

    if target.exists():
        shutil.rmtree(target)
    shutil.copytree(model_dir, target)
    if answers is not None:
        record_answers(target, answers)
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


def _cut_lines(evaluation: Path, splits: Iterable[str], seeds: Sequence[int], max_new_tokens: int) -> list[str]:
    """A warning line per split whose replies the reply budget stopped (scored wrong as written); none when none.
    Only the seeds' current files are read (not the ``.stale`` ones set aside)."""
    from tacreasoner.evaluate.predict import cut_replies

    lines = []
    for split in splits:
        counts: dict[str, int] = {}
        for seed in seeds:
            for task, n in cut_replies(evaluation / split / "predictions" / f"seed{seed}.jsonl").items():
                counts[task] = counts.get(task, 0) + n
        if counts:
            lines += [f"**Warning** (`{split}`): {sum(counts.values())} replies stopped at the {max_new_tokens}-token "
                      f"budget (`evaluate.max_new_tokens`) before the model ended them, scored wrong as written: "
                      + ", ".join(f"{t} {n}" for t, n in sorted(counts.items())) + ".", ""]
    return lines


def _precision_note(models: dict[int, Path]) -> str:
    """How the seeds trained (each final stage's run.json): timings are not comparable across precisions."""
    from tacreasoner.train.precision import PRECISION_NAMES  # imports torch: only when a report is written

    found = set()
    for model in models.values():
        try:
            found.add(json.loads((Path(model).parent / "run.json").read_text(encoding="utf-8"))["mixed_precision"])
        except (OSError, ValueError, KeyError, TypeError):
            return ""  # not recorded (a model trained elsewhere): say nothing rather than guess
    return f", trained in {' and '.join(PRECISION_NAMES.get(p, str(p)) for p in sorted(found))}" if found else ""


def _trained_gel_image(models: dict[int, Path]) -> dict[str, Any]:
    """The average gel at rest the models trained with (their recorded ``video.gel_image``), to answer with
    ``gel_swap: imprint``; one image for every seed, or a one-line error."""
    from tacreasoner.model.processing import saved_processor_config

    images = {str(m): (saved_processor_config(m).get("video") or {}).get("gel_image") for m in models.values()}
    missing = [m for m, image in images.items() if image is None]
    if missing:
        raise ValueError(f"{missing[0]}: trained without a gel swap (no video.gel_image); gel_swap 'imprint' answers "
                         "only models trained by the quickstart's swap stage")
    if len({json.dumps(image) for image in images.values()}) > 1:
        raise ValueError(f"{', '.join(images)}: trained with different gel images; one run folder trains with one")
    return {"image": next(iter(images.values())), "mode": "imprint"}


def evaluate_and_report(paths: QuickstartPaths, models: dict[int, Path], timings: dict[str, Any], *,
                        batch_size: int = 48, max_new_tokens: int = 64, dtype: str | None = None,
                        progress: Callable[[str], Callable[[int, int], None]] | None = None,
                        answers: str = "direct", gel_reference: str = "none",
                        gel_swap: str = "none") -> QuickstartReport:
    """Evaluate every seed's model on the test split(s), write ``report.md`` + ``report.json`` and publish seed 0's
    model with ``answers`` recorded as how ``ask``/``serve``/``demo`` answer it by default. ``gel_reference``
    ``train``: each model first records the gel at rest of the run's train clips and answers colour-mapped to it
    (``none``: a recorded one is removed); ``gel_swap`` ``gate`` also records the train clips' average gel at rest,
    swapped in for a clip lit unlike any of them (another sensor's); ``imprint`` keeps the one the models trained
    with swapped into every clip and answers with the change from rest unmapped."""
    from datetime import datetime, timezone

    from tacreasoner.model.processing import record_gel_reference, saved_processor_config
    from tacreasoner.recipes import quickstart_parts as parts

    reference, gel_line, measured = None, "each clip's frames as in training (no colour map)", ""
    swap, swapped = None, ""
    if gel_reference == "train":
        reference, measured = parts.train_gel_reference(paths)
        gel_line = ("each clip's colours mapped to the gel at rest of the run's train clips "
                    f"(`video.gel_reference`, {paths.gel_reference.name}; training read them "
                    f"{'mapped too' if gel_swap == 'imprint' else 'unmapped'})")
    if gel_swap == "gate" and reference is not None and models:  # measured for the frames the models prepare
        video = saved_processor_config(next(iter(models.values()))).get("video") or {}
        swap, swapped = parts.train_gel_swap(paths, {**video, "gel_reference": reference})
        gel_line += ("; a clip lit unlike every train clip (another sensor's) has its gel at rest swapped for their "
                     f"average (`video.gel_image`, `gel_swap_above`, {paths.gel_swap.name})")
    if gel_swap == "imprint" and reference is not None and models:  # the image the models trained with
        swap, swapped = _trained_gel_image(models), f"the one the models trained with ({paths.gel_image.name})"
        gel_line += ("; every clip's gel at rest swapped for the train clips' average, as in training, its change "
                     "from its own rest added at its own scale (`video.gel_image`, `gel_swap: imprint`, "
                     f"{paths.gel_image.name})")
    for model in models.values():
        record_gel_reference(model, reference, swap)
    calibration = ""
    if gel_swap == "imprint" and swap is not None:
        calibration = parts.record_train_sensor_reference(paths, [Path(m) for m in models.values()])

    splits = ("test", "test_heldout_sensor") if (paths.bench / "test_heldout_sensor.jsonl").is_file() else ("test",)
    started = time.perf_counter()
    reports = evaluate_seeds(models, paths.bench, paths.evaluation, splits, batch_size=batch_size,
                             max_new_tokens=max_new_tokens, progress=progress, video_cache=paths.video_cache,
                             dtype=dtype)
    eval_seconds = round(time.perf_counter() - started, 1)
    baselines = {k: _baseline_accuracy(paths.root, k) for k in ("random", "majority")}
    baselines = {k: v for k, v in baselines.items() if v}
    lines = ["# Quickstart results: TacReasoner (SmolLM2-135M-Instruct) on DynTAC-Sim-Bench", "",
             f"- Date: {datetime.now(timezone.utc).strftime('%Y-%m-%d %H:%M UTC')}",
             f"- Machine: {machine_line()}",
             "- Command: `tacreasoner quickstart`",
             f"- Seeds: {sorted(models)} (Stage I + Stage II trained per seed); training seconds per seed: "
             f"{json.dumps(timings)}{_precision_note(models)}; evaluation {eval_seconds} s",
             f"- Answering: {gel_line}",
             "", "DynTAC-Sim-Bench is simulated: the project's stand-in for the paper's DynTAC-Bench, not its data. "
             "No val or test clip was seen in any training: the appearance encoder holds ImageNet weights "
             "(EfficientNet-Lite0) and trained on no tactile clip; Stages I and II read only train objects. "
             "The model carries the optional read-out heads (benchmark-specific, fitted out of fold on the training "
             "clips' gold labels); the project reports the paper's core model without them beside it "
             "(benchmarks/results/smollm2_heads_test.md). "
             "TSA (scenario choice) is zero-shot: never trained on. Strict answer extraction: a reply not in the "
             "asked `<answer>…</answer>` form counts as wrong.", ""]
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
    if reference is not None:
        summary.append(f"colour map (video.gel_reference): {measured}")
    if swap is not None:
        summary.append(f"gel swap in training and answering (video.gel_image, gel_swap imprint): {swapped}"
                       if gel_swap == "imprint" else f"gel swap for another sensor (video.gel_image): {swapped}")
    if calibration:
        summary.append(f"another sensor's imprint strength: {calibration}")
    cut = _cut_lines(paths.evaluation, reports, sorted(models), max_new_tokens)
    lines += [*cut, "Per-item predictions: `eval/<split>/predictions/seed*.jsonl`; full reports with plots: "
              "`eval/<split>/report.md`.", ""]
    path = paths.root / "report.md"
    path.write_text("\n".join(lines), encoding="utf-8")
    (paths.root / "report.json").write_text(json.dumps(
        {"splits": {s: r.to_dict() for s, r in reports.items()}, "beats_chance": verdicts, "timings": timings,
         "eval_seconds": eval_seconds, "seeds": sorted(models)}, indent=2, default=str) + "\n", encoding="utf-8")
    if models:
        publish_model(Path(models[min(models)]), paths.model, answers)
    return QuickstartReport(path, summary, verdicts)


def _as_typed(path: Path) -> str:
    """The path as a user in this directory would type it, so the printed command can be pasted."""
    try:
        return str(Path(path).resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def ask_one_test_clip(paths: QuickstartPaths, max_new_tokens: int = 64) -> list[str]:
    """Ask the published model one real-or-fake question about a held-out test clip."""
    from tacreasoner.evaluate.predict import load_trained
    from tacreasoner.tasks.bench import load_bench
    from tacreasoner.train.data import bench_video_root

    info, items = load_bench(paths.bench, "test")
    item = next((i for i in items if i.task == "RFOR"), items[0])
    video = bench_video_root(paths.bench, info) / str(item.videos[0].path)
    model, processor = load_trained(paths.model)
    reply = model.answer(processor, item.question, [str(video)], max_new_tokens=max_new_tokens)
    return [f"$ tacreasoner ask --model {_as_typed(paths.model)} {json.dumps(item.question)} "
            f"--video {_as_typed(video)}",
            *([f"think:  {reply.think}"] if reply.think else []), f"answer: {reply.answer}   (gold: {item.answer})"]
