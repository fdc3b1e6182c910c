"""What the clip reader (``encoder.clip_reader``) reads and its labels: the benchmark's vocabulary, kept out of the
model package.

The reader is fitted when Stage II starts (``train.heads``) against the gold the benchmark's train split gives each
clip: TFA levels, real or fake, the contact state of a segment. Only train items give labels, so nothing of the
test split reaches the reader.
"""

from __future__ import annotations

from pathlib import Path

from tacreasoner.tasks.schema import CONTACT_STATES, QAItem
from tacreasoner.train.data import VideoKey, train_items, video_key
from tacreasoner.train.head_settings import READER_TRAITS

__all__ = ["clip_labels", "item_traits"]


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
