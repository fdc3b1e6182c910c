"""Text rehearsal of TouchCoT's multi-video items, for the tiny LLM's pre-training.

The tiny LLM, trained from scratch, reads one video well but, given two or three, answers from the
question's wording (benchmarks/results/video_order.md): nothing taught it to find one video's tokens
by the name the reasoning gives it ("Video 2"). A rehearsal item is a TouchCoT training item with
each video written out as words after its label ("Video 2: rigid"), answered with the item's own
reasoning; reading items ask for one video's words by its label ("How does Video 2 feel in hardness?").
Pre-training on them teaches the lookup by label and the comparison on text; Stage II then swaps the
words for tactile tokens, behind the same labels (``encoder.video_labels``). Measured in
docs/training.md ("Where the tiny model stands"): it works on text, not yet on tactile tokens.

Only training items are rehearsed, and the words are the teacher's descriptors of each video's
ground-truth level (the levels the TouchCoT reasoning already states), so nothing of the test split
reaches the LLM.
"""

from __future__ import annotations

import random
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tacreasoner.cot.rulebank import RulesBank, load_bank
from tacreasoner.jsonl import iter_jsonl
from tacreasoner.model.processing import label_videos
from tacreasoner.tasks.schema import PLACEHOLDER

__all__ = ["REHEARSED_TASKS", "Rehearsal", "reading_question", "reading_word", "rehearsal_dialogues",
           "video_reading_items"]

REHEARSED_TASKS = ("SFD", "SOI", "OSC")
"""The tasks whose items hold several videos."""

Message = dict[str, str]


@dataclass
class Rehearsal:
    dialogues: list[list[Message]]
    items: int
    """Training items rehearsed (each once per pass)."""
    skipped: int
    """Multi-video items without per-video levels in the benchmark (nothing to write for their videos)."""

    def stats(self) -> dict[str, int]:
        return {"dialogues": len(self.dialogues), "items": self.items, "skipped": self.skipped}


def _feel(ranks: Any, attribute: str | None, bank: RulesBank, rng: random.Random) -> str | None:
    """One video's level(s) as descriptor words: "rigid", or "rigid, even, dead and slick" for a profile."""
    descriptors = bank.data["descriptors"]

    def word(attr: str, rank: Any) -> str | None:
        options = descriptors.get(attr, {}).get(int(rank))
        return rng.choice(options) if options else None

    if isinstance(ranks, Mapping):
        words = [word(a, r) for a, r in ranks.items()]
        if not words or None in words:
            return None
        return words[0] if len(words) == 1 else f"{', '.join(words[:-1])} and {words[-1]}"  # type: ignore[arg-type]
    return word(attribute, ranks) if attribute else None


def reading_question(n_videos: int, video: int, attribute: str) -> str:
    """A question about one video (from 1) of several: what Stage I's video readings and their rehearsal ask."""
    return "\n".join([PLACEHOLDER] * n_videos) + f"\nHow does Video {video} feel in {attribute}?"


def reading_word(attribute: str, rank: int, bank: RulesBank | None = None) -> str:
    """The answer to a reading question: the teacher's first descriptor of that level."""
    return (bank or load_bank()).data["descriptors"][attribute][int(rank)][0]


def video_reading_items(items: Sequence[Any]) -> list[tuple[Any, int]]:
    """(item, video index) for every video of every SFD/SOI item with per-video levels."""
    out = []
    for item in items:
        ranks = item.meta.get("ranks")
        if item.task in ("SFD", "SOI") and isinstance(ranks, list) and len(ranks) == len(item.videos) \
                and all(isinstance(r, int) for r in ranks) and item.meta.get("attribute"):
            out += [(item, v) for v in range(len(ranks))]
    return out


def rehearsal_dialogues(touchcot: str | Path, bench: str | Path, *, passes: int = 2, seed: int = 0,
                        bank: RulesBank | None = None) -> Rehearsal:
    """The multi-video items of a TouchCoT training file as text dialogues, ``passes`` wordings each.

    ``bench`` is the benchmark the file was built from: its training items carry each video's level.
    """
    from tacreasoner.tasks.bench import load_bench

    if passes < 1:
        raise ValueError(f"rehearsal passes must be at least 1, got {passes}")
    _, items = load_bench(bench, "train")
    levels = {item.id: item.meta for item in items}
    bank = bank or load_bank()
    rng = random.Random(f"{seed}:rehearsal")
    rows = []
    for line, record in iter_jsonl(touchcot):
        if record.get("task") not in REHEARSED_TASKS:
            continue
        for key in ("item_id", "question", "output"):
            if not isinstance(record.get(key), str):
                raise ValueError(f"{touchcot}:{line}: a TouchCoT training record needs a text field {key!r}")
        rows.append(record)
    dialogues: list[list[Message]] = []
    skipped, used = 0, 0
    for record in rows:
        meta = levels.get(record["item_id"], {})
        ranks, n_videos = meta.get("ranks"), record["question"].count(PLACEHOLDER)
        if not isinstance(ranks, list) or len(ranks) != n_videos:
            skipped += 1
            continue
        wordings = [[_feel(r, meta.get("attribute"), bank, rng) for r in ranks] for _ in range(passes)]
        if any(None in feels for feels in wordings):
            skipped += 1
            continue
        used += 1
        dialogues += [[{"role": "user", "content": label_videos(record["question"], feels)},  # type: ignore[arg-type]
                       {"role": "assistant", "content": record["output"]}] for feels in wordings]
    # reading one video by its label: the text form of Stage I's video readings (data.stage1_video_readings)
    for item, v in video_reading_items(items):
        attribute = item.meta["attribute"]
        for _ in range(passes):
            feels = [_feel(r, attribute, bank, rng) for r in item.meta["ranks"]]
            question = label_videos(reading_question(len(feels), v + 1, attribute), feels)  # type: ignore[arg-type]
            dialogues.append([{"role": "user", "content": question},
                              {"role": "assistant", "content": f"<answer>{feels[v]}</answer>"}])
    return Rehearsal(dialogues, used, skipped)
