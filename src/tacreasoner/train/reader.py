"""Fit the clip reader (``encoder.clip_reader``) when Stage II starts.

The tactile encoder is frozen in Stage II, so each training video's encoder output is fixed: the reader is fitted
on those outputs against the gold the benchmark's train split gives each clip (TFA levels, real or fake, the contact
state of a segment), then frozen, and Stage II's LoRA and projector learn to read its level vectors from the tokens.
Only train items give labels, so nothing of the test split reaches the reader. Fitting is deterministic, so a
resumed Stage II fits the same reader again.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import torch

from tacreasoner.model.clip_reader import READER_TRAITS
from tacreasoner.tasks.schema import CONTACT_STATES, QAItem
from tacreasoner.train.comparator import encoder_outputs
from tacreasoner.train.data import Tokenized, VideoBank, VideoKey, train_items, video_key

__all__ = ["clip_labels", "fit_clip_reader", "item_traits", "labelled"]


def item_traits(item: QAItem) -> dict[str, int]:
    """What a single-clip item's gold says of its clip, as reader levels (empty for other tasks)."""
    if item.task == "TFA-combined":
        return {a: int(level) for a, level in item.gold["levels"].items() if a in READER_TRAITS}
    if item.task.startswith("TFA-") and item.gold.get("attribute") in READER_TRAITS:
        return {item.gold["attribute"]: int(item.gold["level"])}
    if item.task == "RFOR":
        return {"real": int(bool(item.gold["real"]))}
    if item.task == "OCSE":
        return {"state": CONTACT_STATES.index(item.gold["state"])}
    return {}


def clip_labels(bench: str | Path) -> dict[VideoKey, list[int]]:
    """Per video (clip or segment) of the benchmark's train split the level of each trait in ``READER_TRAITS``
    order (−1: no item says). Two items that disagree on a clip are an error in the benchmark."""
    root, items = train_items(Path(bench))
    labels: dict[VideoKey, list[int]] = {}
    for item in items:
        traits = item_traits(item) if len(item.videos) == 1 else {}
        if not traits:
            continue
        key = video_key(item.videos[0], root, f"item {item.id!r}")
        row = labels.setdefault(key, [-1] * len(READER_TRAITS))
        for trait, level in traits.items():
            t = READER_TRAITS.index(trait)
            if row[t] not in (-1, level):
                raise ValueError(f"{bench}: item {item.id!r} gives {item.videos[0].clip_id!r} {trait} level {level}, "
                                 f"another train item {row[t]}")
            row[t] = level
    return labels


def labelled(examples: Sequence[Tokenized], labels: dict[VideoKey, list[int]]) -> list[Tokenized]:
    """The examples holding at least one video with a label: what the reader is fitted on."""
    return [e for e in examples if any(k in labels for k in e.videos)]


def fit_clip_reader(model: Any, processor: Any, examples: Sequence[Tokenized], bank: VideoBank,
                    labels: dict[VideoKey, list[int]], seed: int,
                    progress: Callable[[int, int], None] | None = None, batch_size: int = 16) -> dict[str, Any]:
    """Fit ``model``'s clip reader on every labelled video of ``examples``, read in its own prompt (the temporal
    branch hears the question), and freeze its read-out. Returns per trait the videos and the share read right."""
    reader = model.projector.clip_reader
    if reader is None:
        raise ValueError("the model has no clip reader (encoder.clip_reader is false)")
    chosen = labelled(examples, labels)
    if not chosen:
        raise ValueError("no training video has a label for the clip reader (the train split has no TFA, RFOR or "
                         "OCSE items on these videos)")
    was_training = model.training
    model.eval()
    videos, _, _ = encoder_outputs(model, processor, chosen, bank, batch_size, progress)
    model.train(was_training)
    rows, targets = [], []
    for example, outputs in zip(chosen, videos, strict=True):
        for key, output in zip(example.videos, outputs, strict=True):
            if key in labels:
                rows.append(output)
                targets.append(labels[key])
    return {"videos": len(rows), **reader.fit(torch.stack(rows), torch.tensor(targets), seed=seed)}
