"""What named objects feel like, as text-only training examples: the knowledge POM (OSC) needs and a 135M LLM lacks.

Matching three videos to three named objects needs to know what "a lemon" feels like. SmolLM2-135M knows little of
it, and a benchmark's train split teaches only its own objects' names. ``tasks/everyday_objects.yaml`` holds a broad
set of everyday objects with their typical ranks (our own general judgement, written without any evaluation object
in mind); this module turns them into text-only examples in the compact style's own words, so what the model learns
here is what it writes in OSC's reasoning (``(A) pine cone: hard, rough, big bumps.``)::

    How do these objects usually feel to the touch? (A) pine cone (B) glass marble (C) wool sweater
    <answer>(A) pine cone: hard, rough, big bumps. (B) glass marble: hard, smooth, no bumps. (C) …</answer>

Honesty controls: :func:`without_names` removes every entry that shares a content word with a given list of object
names (the benchmark's val and test objects), so a figure trained on the rest shows what carries over to names the
model never saw; entries named like a train object are always left out (the train labels teach those).
"""

from __future__ import annotations

import random
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from tacreasoner.cot.compact import describe, needs_phrase, scenario_step
from tacreasoner.tasks.everyday_objects import EverydayObject, everyday_objects
from tacreasoner.tasks.scenarios import Scenario, load_scenarios, scenarios_for
from tacreasoner.tasks.vocab import get_vocabulary

__all__ = ["KNOWLEDGE", "SCENARIO_FILE", "KnowledgeExample", "bare_name", "content_words", "knowledge_examples",
           "scenario_examples", "without_names"]

SCENARIO_FILE = Path(__file__).resolve().parents[1] / "tasks" / "scenarios_train.yaml"
"""Training scenarios: disjoint from the evaluation bank ``tasks/scenarios.yaml`` (TSA stays zero-shot; a test checks
that no training scenario is an evaluation one)."""
SCENARIO_QUESTION = "You need an object for {scenario}. What should it feel like?"
SCENARIO_CHOICE = ("First object: {first}.\nSecond object: {second}.\nYou need an object for {scenario}. Which of the "
                   "two objects is the better choice? (A) the first object (B) the second object")
KNOWLEDGE = ("none", "all", "without_eval_names")
"""``data.knowledge``: no object knowledge, every entry, or every entry sharing no word with a val/test object name."""

_RANK_OF = {"bumpiness": "protrusion"}
"""A vocabulary attribute → the everyday-object rank it reads (bumpiness is the protrusion rank, as in the sim)."""
_ARTICLE = re.compile(r"^(a|an|the|some)\s+", re.IGNORECASE)
_STOP = frozenset({"a", "an", "the", "some", "of", "on", "in", "with", "and", "for", "s"})
QUESTION_GROUP = "How do these objects usually feel to the touch? {options}"
QUESTION_ONE = "How does {name} usually feel to the touch?"


@dataclass(frozen=True)
class KnowledgeExample:
    key: str
    question: str
    target: str


def bare_name(name: str) -> str:
    """``a sheet of sandpaper`` → ``sheet of sandpaper`` (OSC lists its options without the article)."""
    return _ARTICLE.sub("", name.strip())


def content_words(name: str) -> set[str]:
    """Lower-case words of a name without articles and small words, plurals folded (``jeans`` → ``jean``)."""
    words = re.findall(r"[a-z]+", name.lower())
    return {w[:-1] if len(w) > 3 and w.endswith("s") else w for w in words if w not in _STOP}


def without_names(objects: Iterable[EverydayObject], names: Iterable[str]) -> list[EverydayObject]:
    """``objects`` less every one sharing a content word with any of ``names``."""
    banned = set().union(*(content_words(n) for n in names))
    return [o for o in objects if not content_words(o.name) & banned]


def _levels(obj: EverydayObject, vocabulary: str) -> dict[str, int]:
    return {a: int(obj.ranks[_RANK_OF.get(a, a)]) for a in get_vocabulary(vocabulary)}


def knowledge_examples(vocabulary: str, *, exclude: Sequence[str] = (), train_names: Sequence[str] = (),
                       seed: int = 0, objects: Sequence[EverydayObject] | None = None) -> list[KnowledgeExample]:
    """One single-object example per entry and groups of three (each entry in one group), in ``vocabulary``'s level
    words; ``exclude``: object names whose words no entry may share (:func:`without_names`); ``train_names``: the
    benchmark's own train objects, whose labels win over an entry of the same name."""
    vocab = get_vocabulary(vocabulary)
    pool = list(everyday_objects() if objects is None else objects)
    pool = without_names(pool, exclude) if exclude else pool
    trained = {bare_name(n).lower() for n in train_names}
    pool = [o for o in pool if bare_name(o.name).lower() not in trained]
    out = [KnowledgeExample(f"knowledge-{k}", QUESTION_ONE.format(name=o.name),
                            f"<answer>{describe(_levels(o, vocabulary), vocab)}</answer>") for k, o in enumerate(pool)]
    order = list(range(len(pool)))
    random.Random(seed).shuffle(order)
    for g in range(len(order) // 3):
        group = [pool[i] for i in order[3 * g: 3 * g + 3]]
        options = " ".join(f"({'ABC'[k]}) {bare_name(o.name)}" for k, o in enumerate(group))
        said = " ".join(f"({'ABC'[k]}) {bare_name(o.name)}: {describe(_levels(o, vocabulary), vocab)}."
                        for k, o in enumerate(group))
        out.append(KnowledgeExample(f"knowledge-group-{g}", QUESTION_GROUP.format(options=options),
                                    f"<answer>{said}</answer>"))
    return out


def scenario_examples(vocabulary: str, *, scenarios: Sequence[Scenario] | None = None, seed: int = 0,
                      choices_per_scenario: int = 4) -> list[KnowledgeExample]:
    """Text-only examples of what a scenario needs, over *training* scenarios (never the evaluation bank's):
    ``You need an object for … What should it feel like?`` → ``… needs high hardness and low roughness.``, and
    choices between two objects described in words, reasoned in the compact style's TSA steps (the levels, what
    the scenario needs, which fits better), so zero-shot TSA on videos only has to read the clips."""
    vocab = get_vocabulary(vocabulary)
    bank = scenarios_for(vocabulary, tuple(load_scenarios(SCENARIO_FILE) if scenarios is None else scenarios))
    rng = random.Random(seed)
    out: list[KnowledgeExample] = []
    for s in bank:
        text = f"{s.text[:1].upper()}{s.text[1:]}"
        out.append(KnowledgeExample(f"scenario-{s.id}", SCENARIO_QUESTION.format(scenario=s.text),
                                    f"<answer>{text} needs {needs_phrase(s.needs, vocab)}.</answer>"))
        made = 0
        for _ in range(50 * choices_per_scenario):
            if made == choices_per_scenario:
                break
            pair = [{a: rng.randrange(3) for a in vocab} for _ in range(2)]
            scores = [s.score(levels) for levels in pair]
            if scores[0] == scores[1]:
                continue
            better = int(scores[1] > scores[0])
            shown = [{a: levels[a] for a in vocab if a in s.needs} for levels in pair]
            think = " ".join(f"Video {v + 1}: {describe(shown[v], vocab)}." for v in range(2))
            think += " " + scenario_step(s.text, s.needs, better, vocab)
            question = SCENARIO_CHOICE.format(first=describe(pair[0], vocab), second=describe(pair[1], vocab),
                                              scenario=s.text)
            out.append(KnowledgeExample(f"scenario-{s.id}-choice-{made}", question,
                                        f"<think>{think}</think><answer>{'AB'[better]}</answer>"))
            made += 1
    return out
