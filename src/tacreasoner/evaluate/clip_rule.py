"""What reasoning could reach from what a model reads: the conclusion rule applied to its own single-clip answers.

A model that reads each clip fairly well can still answer questions over several objects at chance: it reads what
it needs and then does not use it. This measure separates the two. Each clip's levels are taken from the model's own
answers to the single-clip questions about that clip (TFA-<attribute>, else TFA-combined), and each multi-object
item's answer is derived from them by the rule of :mod:`tacreasoner.tasks.conclude`. Where the readings tie, the
rule's answers share the credit (a tie between two objects is half right when one is the gold). OSC also needs the
named objects' levels: the rule is given their gold levels (perfect knowledge of what named objects feel like), so its
figure is a ceiling for the matching step, not for the naming knowledge. The gap between the rule's accuracy and the
model's own multi-object accuracy is what its reasoning still loses.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from tacreasoner.tasks.conclude import (
    REASONED_TASKS,
    Levels,
    implied_answers,
    needed_attributes,
    option_levels,
    parsed_answer,
    stated_levels,
)
from tacreasoner.tasks.extract import split_reasoning
from tacreasoner.tasks.schema import QAItem

__all__ = ["RuleScore", "clip_readings", "rule_on_readings", "rule_on_stated"]


def clip_readings(items: Sequence[QAItem], records: Sequence[Mapping[str, Any]]) -> dict[str, Levels]:
    """clip id → the levels the model's single-clip answers gave it (``records``: scored records of ``items``, with
    ``parsed`` as the scorer read it). A property's own question wins over the combined one's reading."""
    by_id = {i.id: i for i in items}
    own: dict[str, Levels] = defaultdict(dict)
    combined: dict[str, Levels] = defaultdict(dict)
    for record in records:
        item = by_id.get(record["id"])
        parsed = record.get("parsed")
        if item is None or parsed is None or not item.task.startswith("TFA-"):
            continue
        clip = item.videos[0].clip_id
        if item.task == "TFA-combined":
            combined[clip].update({a: int(v) for a, v in parsed.items() if v is not None})
        else:
            own[clip][item.task.removeprefix("TFA-")] = int(parsed)
    return {clip: {**combined.get(clip, {}), **own.get(clip, {})} for clip in set(own) | set(combined)}


@dataclass(frozen=True)
class RuleScore:
    n: int
    """Multi-object items of the task."""
    covered: int
    """Items whose every video had a reading of each needed property (the others count as wrong)."""
    accuracy: float
    """Expected accuracy of the rule on the model's readings (ties share the credit), over all ``n`` items."""


def rule_on_readings(items: Sequence[QAItem], readings: Mapping[str, Levels]) -> dict[str, RuleScore]:
    """Per multi-object task: the rule's accuracy on ``readings`` (see the module doc)."""
    credit: dict[str, list[float]] = defaultdict(list)
    covered: dict[str, int] = defaultdict(int)
    for item in items:
        if item.task not in REASONED_TASKS:
            continue
        needed = needed_attributes(item)
        videos = [readings.get(v.clip_id, {}) for v in item.videos]
        if not all(a in levels for levels in videos for a in needed):
            credit[item.task].append(0.0)
            continue
        covered[item.task] += 1
        credit[item.task].append(_credit(item, implied_answers(
            item, [{a: levels[a] for a in needed} for levels in videos],
            option_levels(item) if item.task == "OSC" else ())))
    return _scores(credit, covered)


def rule_on_stated(items: Sequence[QAItem], records: Sequence[Mapping[str, Any]]) -> dict[str, RuleScore]:
    """Per multi-object task: accuracy when each reply's answer is replaced by the rule applied to the levels its own
    reasoning stated (ties share the credit); a reply that states no levels keeps its own answer. What the model's
    descriptions are worth once the conclusion step cannot go wrong (``covered``: replies that stated levels)."""
    by_id = {i.id: i for i in items}
    credit: dict[str, list[float]] = defaultdict(list)
    covered: dict[str, int] = defaultdict(int)
    for record in records:
        item = by_id.get(record["id"])
        if item is None or item.task not in REASONED_TASKS:
            continue
        reasoning, _ = split_reasoning(record.get("prediction") or "")
        stated = stated_levels(item, reasoning) if reasoning else None
        if stated is None:
            credit[item.task].append(float(bool(record["correct"])))
            continue
        covered[item.task] += 1
        credit[item.task].append(_credit(item, implied_answers(item, *stated)))
    return _scores(credit, covered)


def _credit(item: QAItem, implied: set[Any]) -> float:
    """The share of the rule's answers that is right: a tie between the gold and another answer is half right."""
    gold = parsed_answer(item, f"<answer>{item.answer}</answer>")
    return (gold in implied) / len(implied) if implied else 0.0


def _scores(credit: Mapping[str, list[float]], covered: Mapping[str, int]) -> dict[str, RuleScore]:
    return {task: RuleScore(len(values), covered.get(task, 0), sum(values) / len(values))
            for task, values in credit.items()}
