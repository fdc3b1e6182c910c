"""Score saved models on a PhysiCLeAR-shaped folder (``labels.json`` + ``videos/``), in Octopi's columns.

What ``tacreasoner evaluate-physiclear`` and the real-data recipe run: the folder's split is built into items
deterministically (:func:`tacreasoner.tasks.bench.build_folder_bench`), optionally asked with retrieval augmentation
or in held-out wordings, answered by each model (resumable by item id), scored, and written as the project's report
plus Octopi's table (``octopi.md`` / ``octopi.json``). An output folder answered with other settings is refused
rather than resumed into a mix of two runs.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tacreasoner.evaluate.octopi import octopi_markdown, octopi_table
from tacreasoner.tasks.paraphrase import HELDOUT_WORDINGS

__all__ = ["RECOMMENDED_ANSWERS", "WORDINGS", "FolderEvaluation", "evaluate_folder", "same_settings_as_before"]

WORDINGS = ("benchmark", *HELDOUT_WORDINGS)
RECOMMENDED_ANSWERS = "stepwise-vote"
"""How the recommended PhysiCLeAR model answers questions over several objects: each video read in a pass of its own,
in every single-clip wording with the majority level, and the conclusion drawn by the rule (``evaluate/stepwise.py``).
Chosen on val by rules fixed before measuring (experiments/2026-11-29_stepwise): stepwise beat one pass in every seed
pair of the shipped recipe, then the vote beat one wording on PC and PSS in every seed pair."""


@dataclass
class FolderEvaluation:
    report: Any
    table: dict[str, Any]
    markdown: str
    counts: dict[str, int]
    objects: int
    split: str


def same_settings_as_before(out: Path, settings: dict) -> None:
    """Answers resume by item id, and ids do not change with retrieval or another model: refuse an ``out`` that was
    answered with other settings rather than silently mixing the two runs' answers. More models after the same
    first ones (seeds added to a recipe) is not a change: model k answers into ``model<k>/`` as before."""
    path = out / "settings.json"
    if path.is_file():
        before = json.loads(path.read_text())
        models_before = before.get("models") or []
        added_models = settings.get("models", [])[:len(models_before)] == models_before
        changed = [key for key in settings if before.get(key) != settings[key]
                   and not (key == "models" and added_models)]
        if changed:
            raise ValueError(f"{out} holds answers made with other settings ({', '.join(changed)} changed; see "
                             f"{path}): give a fresh --out")
    out.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(settings, indent=2) + "\n")


def evaluate_folder(models: Sequence[Path], data: Path, out: Path, *, split: str | None = None, seed: int = 0,
                    per_task: int | None = None, mode: str = "strict", batch_size: int = 32,
                    max_new_tokens: int = 512, retrieval: Path | None = None, encoder: Path | None = None,
                    retrieval_k: int | None = None, wording: str = "benchmark", answers: str = RECOMMENDED_ANSWERS,
                    progress: Callable[[str], Callable[[int, int], None] | None] | None = None,
                    say: Callable[[str], None] = print) -> FolderEvaluation:
    """Every model answers the folder's ``split`` (default: val, or the only labelled split, as in a folder of test
    objects alone); see the module doc.
    ``answers``: how questions over several objects are answered (``evaluate.predict.ANSWER_MODES``).
    ``progress(label)`` gives a per-model progress callback."""
    from tacreasoner.evaluate.predict import (
        answerer_id,
        check_answers,
        cut_warning,
        load_trained,
        predict_items,
        predictions_path,
    )
    from tacreasoner.evaluate.report import evaluate
    from tacreasoner.tasks.bench import build_folder_bench, load_bench, reword_bench
    from tacreasoner.train.data import bench_video_root

    if wording not in WORDINGS:
        raise ValueError(f"wording must be one of {', '.join(WORDINGS)}, got {wording!r}")
    check_answers(answers)
    for path in models:
        if not (Path(path) / "config.json").is_file():
            raise FileNotFoundError(f"--model {path}: not a saved model (no config.json)")
    same_settings_as_before(out, {"models": [str(m) for m in models], "data": str(data), "split": split, "seed": seed,
                                  "per_task": per_task, "retrieval": None if retrieval is None else str(retrieval),
                                  "encoder": None if encoder is None else str(encoder), "retrieval_k": retrieval_k,
                                  "wording": wording} | ({} if answers == "direct" else {"answers": answers}))
    summary, name = build_folder_bench(data, out / "bench", split=split, seed=seed, per_task=per_task)
    if wording != "benchmark":
        summary.counts.update(reword_bench(summary.out_dir, wording=wording, splits=(name,)))
    if retrieval is not None and encoder is not None and retrieval_k is not None:
        from tacreasoner.evaluate.retrieval import augment_bench

        found = augment_bench(summary.out_dir, retrieval, encoder, retrieval_k)
        say(f"retrieval: {retrieval_k} neighbours per video from {found.reference_clips} train clips of "
            f"{found.reference_objects} objects ({retrieval})")
    info, items = load_bench(summary.out_dir, name)
    paths = []  # model k answers into <out>/model<k>/predictions/<split>.jsonl (resumable)
    for k, model_dir in enumerate(models):
        model, processor = load_trained(model_dir)
        path = predictions_path(out / f"model{k}", name)
        bar = progress(f"answering {name}, model {k + 1} of {len(models)}") if progress else None
        predict_items(model, processor, items, bench_video_root(summary.out_dir, info), path, batch_size=batch_size,
                      max_new_tokens=max_new_tokens, progress=bar, answers=answers,
                      answered_by=answerer_id(model_dir, summary.out_dir, answers=answers))
        if (warning := cut_warning(path, max_new_tokens)) is not None:
            say(warning)
        paths.append(path)
        del model
    report = evaluate(items, paths, mode, out)
    folder_split = json.loads((summary.out_dir / "bench.json").read_text())["folder_split"]
    table = octopi_table(report)
    label = ", ".join(str(m) for m in models) + ("" if wording == "benchmark" else f" ({wording} wordings)") + \
        ("" if answers == "direct" else f" ({answers} answers)")
    text = octopi_markdown(table, label=label, split=f"{data} · {folder_split}")
    (out / "octopi.md").write_text(f"# Octopi's PhysiCLeAR table\n\n{text}")
    (out / "octopi.json").write_text(json.dumps({"data": str(data), "split": folder_split, "wording": wording,
                                                 "answers": answers,
                                                 "models": [str(m) for m in models], "mode": mode, "seed": seed,
                                                 "table": table}, indent=2))
    return FolderEvaluation(report, table, text, summary.counts[name], summary.objects[name], folder_split)
