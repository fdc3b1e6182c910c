"""The compact reasoning style: describe each object in the benchmark's level words, then the one step that concludes.

TouchCoT as first built (~370 tokens of cue-by-cue prose, :mod:`tacreasoner.cot.rules`) cost a 135M LLM 42 points on
DynTAC-Sim. Octopi's multi-object answers carry because each object is described first ("First object: …") and the
conclusion is a comparison over those descriptions; without them its PSS and POM fall to chance. This style writes
exactly that, from train labels, in under 100 tokens for three videos::

    <think>Video 1: soft. Video 2: hard. Video 3: moderately hard. The softest is Video 1.</think>
    <answer>the first object</answer>

* SFD, PC, SOI state each video's level of the asked attribute; TSA the levels the scenario needs, then what it
  needs; OSC every attribute of each video and of each named option, then the closest match.
* Single-clip tasks (TFA, RFOR, OCSE) answer plainly: their answer *is* the description.
* The answer is always the gold answer in the asked form, and is checked to be one the stated levels imply
  (:func:`tacreasoner.tasks.conclude.implied_answers`), so training never shows a reply that contradicts itself.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from tacreasoner.tasks.building import join_words
from tacreasoner.tasks.conclude import (
    REASONED_TASKS,
    Levels,
    implied_answers,
    item_levels,
    option_levels,
    parsed_answer,
)
from tacreasoner.tasks.schema import QAItem
from tacreasoner.tasks.scoring import TSA_LETTERS
from tacreasoner.tasks.vocab import Attribute, get_vocabulary

__all__ = ["compact_reasoning", "compact_target", "conclusion_step", "describe", "needs_phrase", "scenario_step"]


def describe(levels: Levels, vocab: Mapping[str, Attribute]) -> str:
    """``hard, slightly rough, no bumps``: the level words in vocabulary order."""
    return ", ".join(vocab[a].phrase(levels[a]) for a in vocab if a in levels)


def needs_phrase(needs: Mapping[str, str], vocab: Mapping[str, Attribute]) -> str:
    """``high hardness and low roughness``, in vocabulary order."""
    return join_words([f"{level} {a}" for a in vocab for want, level in needs.items() if a == want])


def scenario_step(scenario: str, needs: Mapping[str, str], better: int, vocab: Mapping[str, Attribute]) -> str:
    """``Wiping a screen needs low hardness and low roughness: Video 2 fits better.``"""
    return f"{scenario[:1].upper()}{scenario[1:]} needs {needs_phrase(needs, vocab)}: Video {better + 1} fits better."


def conclusion_step(item: QAItem, answer: Any, vocab: Mapping[str, Attribute],
                    needs: Mapping[str, str] | None = None) -> str:
    """The one sentence that turns the stated levels into ``answer`` (the scorer's parsed form, as
    :func:`tacreasoner.tasks.conclude.parsed_answer` gives it); TSA names ``needs`` (default the gold's)."""
    gold = item.gold
    if item.task == "PC":
        attribute = gold["attribute"]
        if answer == "similar":
            return f"Video 1 and Video 2 have similar {attribute}."
        return f"Video 1 has {answer} {attribute} than Video 2."
    if item.task in ("SFD", "SOI"):
        attr = vocab[gold["attribute"]]
        if item.task == "SFD" and gold["kind"] == "yesno":
            comparative = attr.more if gold["direction"] == "more" else attr.less
            return f"So Video 1 is {'' if answer else 'not '}{comparative} than Video 2."
        if item.task == "SFD":
            word = attr.more if gold["direction"] == "more" else attr.less
        else:
            word = attr.most if gold["direction"] == "most" else attr.least
        return f"The {word} is Video {int(answer) + 1}."
    if item.task == "TSA":
        scenario = str(item.meta.get("scenario_text") or gold["scenario"])
        return scenario_step(scenario, gold["needs"] if needs is None else needs, TSA_LETTERS.index(answer), vocab)
    if item.task == "OSC":
        pairs = ", ".join(f"{v + 1}-{'ABC'[int(k)]}" for v, k in enumerate(answer))
        return f"Closest match: {pairs}."
    raise ValueError(f"item {item.id!r}: task {item.task} is not reasoned over objects")


def compact_reasoning(item: QAItem) -> str:
    """The ``<think>`` text for a multi-object item, from its gold levels."""
    vocab = get_vocabulary(item.vocabulary)
    videos = item_levels(item)
    lines = [f"Video {v + 1}: {describe(levels, vocab)}." for v, levels in enumerate(videos)]
    options: Sequence[Levels] = ()
    if item.task == "OSC":
        options = option_levels(item)
        lines += [f"({'ABC'[k]}) {name}: {describe(options[k], vocab)}." for k, name in enumerate(item.options)]
    parsed = parsed_answer(item, f"<answer>{item.answer}</answer>")
    lines.append(conclusion_step(item, parsed, vocab))
    if parsed not in implied_answers(item, videos, options):
        raise ValueError(f"item {item.id!r} ({item.task}): its gold answer {item.answer!r} does not follow from "
                         f"its labels' levels {videos}")
    return " ".join(lines)


def compact_target(item: QAItem) -> str:
    """The training target of ``item`` in the compact style: reasoning for multi-object tasks, plain otherwise."""
    if item.task not in REASONED_TASKS:
        return f"<answer>{item.answer}</answer>"
    return f"<think>{compact_reasoning(item)}</think><answer>{item.answer}</answer>"
