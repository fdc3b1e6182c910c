"""Teacher-forced answer loss per task and split: does a trained model know the train objects' answers much better
than those of objects it never saw?

A model that scores far below its encoder's linear probe on held-out objects either never learned to read the touch
tokens or learned the training objects by heart. The loss of the gold answer (``<answer>…</answer>``, the Stage II
plain target) per task on train items against val items tells them apart: a small train loss beside a large val
loss is memorisation; both large is under-fitting. Nothing here trains or chooses anything.
"""

from __future__ import annotations

import json
import random
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import torch

__all__ = ["task_loss_markdown", "task_losses", "write_task_losses"]


def task_losses(model_dir: str | Path, bench_dir: str | Path, *, splits: Sequence[str] = ("train", "val"),
                per_task: int | None = 40, seed: int = 0, video_cache: str | Path | None = None,
                max_length: int = 1024, progress: Callable[[int, int], None] | None = None) -> dict[str, Any]:
    """``{split: {task: {"loss": mean answer-token loss, "n": items}}}`` for ``model_dir`` on ``bench_dir``'s
    ``splits`` (TSA left out: it has no training target); ``per_task`` items per task and split (None: all),
    drawn with ``seed``."""
    from tacreasoner.evaluate.predict import load_trained
    from tacreasoner.tasks.bench import load_bench
    from tacreasoner.train.data import (
        VideoBank,
        _answer_only,
        _from_items,
        bench_video_root,
        collate,
        tokenize_examples,
    )

    bench_dir = Path(bench_dir)
    model, processor = load_trained(model_dir)
    chosen: dict[str, list] = {}
    for split in splits:
        info, items = load_bench(bench_dir, split)
        by_task: dict[str, list] = {}
        for item in items:
            if item.task != "TSA":
                by_task.setdefault(item.task, []).append(item)
        rng = random.Random(seed)
        picked = [i for task in sorted(by_task) for i in
                  (rng.sample(by_task[task], per_task) if per_task and len(by_task[task]) > per_task
                   else by_task[task])]
        examples = _from_items(picked, bench_video_root(bench_dir, info), _answer_only)
        chosen[split], dropped = tokenize_examples(processor, examples, max_length)
        if dropped:
            raise ValueError(f"{bench_dir}: {len(dropped)} {split} items are longer than {max_length} tokens "
                             f"(first: {dropped[0].key}, {dropped[0].length} tokens)")
    bank = VideoBank(processor.video_config, processor.sensor_types)
    bank.build([k for tokenized in chosen.values() for e in tokenized for k in e.videos], cache_dir=video_cache)
    base = model.get_base_model() if hasattr(model, "get_base_model") else model
    bank.cache_appearance(base.tactile_encoder, cache_dir=video_cache)
    device = next(model.parameters()).device
    total, done = sum(len(t) for t in chosen.values()), 0
    sums: dict[str, dict[str, list[float]]] = {}
    with torch.no_grad():
        for split, tokenized in chosen.items():
            for example in tokenized:
                batch = {k: v.to(device) if torch.is_tensor(v) else v
                         for k, v in collate(processor, [example], bank).items()}
                loss = model(**batch, loss_only=True).loss
                sums.setdefault(split, {}).setdefault(example.task, []).append(float(loss))
                done += 1
                if progress is not None:
                    progress(done, total)
    return {split: {task: {"loss": sum(v) / len(v), "n": len(v)} for task, v in sorted(tasks.items())}
            for split, tasks in sums.items()}


def task_loss_markdown(losses: dict[str, Any], title: str = "Answer loss per task") -> str:
    """One row per task, one column per split, and the ratio of the last split's loss to the first's."""
    splits = list(losses)
    tasks = sorted({t for s in splits for t in losses[s]})
    header = "| task | " + " | ".join(f"{s} loss (n)" for s in splits) + (
        f" | {splits[-1]} / {splits[0]} |" if len(splits) > 1 else " |")
    lines = [f"## {title}", "", header, "|---|" + "---|" * (len(splits) + (len(splits) > 1))]
    for task in tasks:
        cells = [f"{losses[s][task]['loss']:.3f} ({losses[s][task]['n']})" if task in losses[s] else "–"
                 for s in splits]
        ratio = ""
        if len(splits) > 1:
            first, last = losses[splits[0]].get(task), losses[splits[-1]].get(task)
            ratio = " | " + (f"{last['loss'] / first['loss']:.1f}×" if first and last and first["loss"] > 0 else "–")
        lines.append(f"| {task} | " + " | ".join(cells) + ratio + " |")
    return "\n".join(lines) + "\n"


def write_task_losses(losses: dict[str, Any], out: str | Path, **meta: Any) -> Path:
    """``out/task_loss.json`` (with ``meta``) and ``out/task_loss.md``; returns the markdown's path."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "task_loss.json").write_text(json.dumps({**meta, "losses": losses}, indent=2) + "\n")
    path = out / "task_loss.md"
    path.write_text(task_loss_markdown(losses), encoding="utf-8")
    return path
