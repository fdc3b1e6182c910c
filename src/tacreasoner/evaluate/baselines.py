"""Reference predictors that need no model: random guessing and the training split's majority answer.

Every reported model number sits next to these; a model that does not beat them has learned nothing
from touch. Both write predictions in the same JSONL format as a model (``{"id", "prediction"}``),
so they go through exactly the same scorer.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from itertools import permutations, product
from pathlib import Path

import numpy as np

from tacreasoner.jsonl import write_jsonl
from tacreasoner.tasks.answers import render_answer
from tacreasoner.tasks.schema import CONTACT_STATES, ORDINALS, PC_RELATIONS, QAItem
from tacreasoner.tasks.vocab import get_vocabulary

BASELINES = ("random", "majority")


def answer_space(item: QAItem) -> list[str]:
    """Every well-formed answer to ``item`` (the gold answer is one of them)."""
    task = item.task
    vocab = get_vocabulary(item.vocabulary)
    if task == "TFA-combined":
        names = list(item.gold["levels"])
        return [render_answer(task, {"levels": dict(zip(names, ranks, strict=True))}, item.vocabulary)
                for ranks in product(range(3), repeat=len(names))]
    if task.startswith("TFA-"):
        return list(vocab[task.removeprefix("TFA-")].levels)
    if task == "SFD":
        if item.gold["kind"] == "yesno":
            return ["yes", "no"]
        return [f"the {o} object" for o in ORDINALS[:2]]
    if task == "PC":
        return list(PC_RELATIONS)
    if task == "SOI":
        return [f"the {o} object" for o in ORDINALS[:3]]
    if task == "OSC":
        letters = "ABC"[: len(item.options)]
        return [", ".join(f"{v + 1}-{letter}" for v, letter in enumerate(p)) for p in permutations(letters)]
    if task == "TSA":
        return ["A", "B"]
    if task == "RFOR":
        return ["real", "fake"]
    if task == "OCSE":
        return list(item.options or CONTACT_STATES)
    raise ValueError(f"item {item.id!r}: no answer space for task {item.task!r}")


def _task_key(item: QAItem) -> tuple[str, str]:
    """Items whose answers are interchangeable share a key (SFD yes/no and which-questions differ)."""
    kind = item.gold.get("kind", "") if item.task == "SFD" else ""
    return item.task + (f":{kind}" if kind else ""), item.vocabulary


def majority_answers(train: Sequence[QAItem]) -> dict[tuple[str, str], str]:
    """Most frequent gold answer per task in the training items (ties → alphabetically first)."""
    counts: dict[tuple[str, str], Counter] = {}
    for item in train:
        counts.setdefault(_task_key(item), Counter())[item.answer] += 1
    return {key: sorted(c.items(), key=lambda kv: (-kv[1], kv[0]))[0][0] for key, c in counts.items()}


def predict(items: Sequence[QAItem], kind: str, *, train: Sequence[QAItem] = (), seed: int = 0) -> list[dict]:
    """Prediction records for ``items``. ``majority`` falls back to random for tasks absent from ``train``
    (e.g. zero-shot TSA), and says so in the record."""
    if kind not in BASELINES:
        raise ValueError(f"unknown baseline {kind!r}; choose from {', '.join(BASELINES)}")
    rng = np.random.default_rng(seed)
    majority = majority_answers(train) if kind == "majority" else {}
    out = []
    for item in items:
        space = answer_space(item)
        answer = majority.get(_task_key(item))
        source = "majority"
        if answer is None or answer not in space:
            answer, source = space[int(rng.integers(len(space)))], "random"
        out.append({"id": item.id, "prediction": f"<think>{kind} baseline</think><answer>{answer}</answer>",
                    "baseline": kind, "answer_source": source})
    return out


def write_predictions(records: Sequence[dict], path: str | Path) -> Path:
    return write_jsonl(path, records)
