"""Describe, then conclude: what a multi-object answer follows from, and whether a reply's answer follows from it.

Octopi answers every multi-object question by first stating each object's levels and then concluding; the answer
then reduces to a comparison, an arg-max, a match or a scenario's needs over the stated levels. This module holds
that reduction, for three users:

* the compact reasoning style (:mod:`tacreasoner.cot.compact`) writes the levels and the conclusion from train labels;
* the evaluation's consistency measure (:func:`consistency`) reads the levels a reply stated and checks that its
  answer is one those levels imply — a reply that contradicts itself is a defect, not noise;
* the rule applied to a model's own single-clip answers (:func:`implied_answers` with per-clip readings) says what
  reasoning could reach from what the model reads, beside what its multi-object answers reach.

Answers are compared in the scorer's parsed form (:func:`tacreasoner.tasks.scoring.score_item`): PC a relation word,
SFD an index (``which``) or a bool (``yesno``), SOI an index, OSC a tuple of option indices, TSA a letter. Where the
levels tie (three coarse levels make ties common), every answer the tie allows is implied: "the hardest of hard,
hard, soft" may be either hard one.
"""

from __future__ import annotations

import itertools
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

from tacreasoner.tasks.analogy import analogy_properties
from tacreasoner.tasks.extract import extract_answer, split_reasoning
from tacreasoner.tasks.scenarios import suitability
from tacreasoner.tasks.schema import PC_RELATIONS, PLACEHOLDER, QAItem
from tacreasoner.tasks.scoring import TSA_LETTERS, _find_phrases, score_item
from tacreasoner.tasks.vocab import Attribute, get_vocabulary

__all__ = [
    "BEYOND_TOUCH",
    "FRUIT_WORDS",
    "PROPERTY_WORDS",
    "REASONED_TASKS",
    "Consistency",
    "Levels",
    "PropertyFallback",
    "asked",
    "asked_fruit",
    "asked_properties",
    "beyond_touch",
    "consistency",
    "implied_answers",
    "item_levels",
    "labelled_levels",
    "needed_attributes",
    "option_levels",
    "parsed_answer",
    "read_levels",
    "read_needs",
    "stated_levels",
]

REASONED_TASKS = ("SFD", "PC", "SOI", "OSC", "TSA")
"""Tasks over several objects whose answer follows from per-object levels."""

Levels = dict[str, int]
"""attribute → rank (0, 1, 2)."""

_VIDEO = re.compile(r"\bvideo\s+([1-3])\s*:\s*([^.\n]*)", re.IGNORECASE)
_OBJECT_LETTERS = "ABC"
_OPTION = re.compile(r"\(([A-C])\)[^:\n(]*:\s*([^.\n]*)")
_NEED = re.compile(r"\b(high|low)\s+([a-z]+)", re.IGNORECASE)


def asked(task: str, question: str, vocabulary: str) -> dict[str, Any] | None:
    """What a comparison question asks, read from its words alone: ``attribute``, and for SFD and SOI ``direction``
    (SFD more | less, SOI most | least) and for SFD ``kind`` (which | yesno); None when the words do not say it once.

    SFD and SOI name the property by its comparative or superlative ("softer", "the roughest"), PC by its name ("more,
    less or similar hardness"); SFD asks "which"/"pick" one, or yes or no. This lets the stepwise answering mode work
    from the question, never from an item's gold."""
    text = question.replace(PLACEHOLDER, " ")
    vocab = get_vocabulary(vocabulary)
    if task == "PC":
        found = {a for _, a in _find_phrases(text, {a: a for a in vocab})}
        return {"attribute": found.pop()} if len(found) == 1 else None
    if task not in ("SFD", "SOI"):
        raise ValueError(f"asked() reads SFD, PC and SOI questions, not {task}")
    words = ("more", "less") if task == "SFD" else ("most", "least")
    table = {getattr(attr, w): (a, w) for a, attr in vocab.items() for w in words}
    found_pairs = {pair for _, pair in _find_phrases(text, table)}
    if len(found_pairs) != 1:
        return None
    attribute, direction = found_pairs.pop()
    out: dict[str, Any] = {"attribute": attribute, "direction": direction}
    if task == "SFD":
        # "yes or no" said outright wins over a "which"/"pick" in the context (sixth version)
        says_yes_no = re.search(r"\byes\s*(?:or|/)\s*no\b", text, re.IGNORECASE) is not None
        # "identify", "choose" or "select" the one that is softer ask which as well (tenth version)
        picks = re.search(r"\b(which|pick|identify|choose|select)\b", text, re.IGNORECASE)
        out["kind"] = "which" if not says_yes_no and picks else "yesno"
    return out


STANDS_PROUD: tuple[str, ...] = ("stand proud", "stands proud", "standing proud", "stood proud", "sit proud",
                                  "sits proud", "sitting proud", "proud of the", "flush")
"""A machinist's and carpenter's words for a raised feature: it "stands proud of" the surface, or "sits flush"."""
PROPERTY_WORDS: dict[str, tuple[str, ...]] = {
    "hardness": ("hard", "soft", "firm", "stiff", "rigid", "squish", "squash", "spongy", "yield", "give way",
                 "compress", "squeez", "pliab", "mushy", "solid", "tough", "deform",
                 # second version (2026-11-29, a thesaurus pass before the third held-out set was read):
                 "dent", "it give", "it gives", "give when", "gives when", "give under", "gives under", "any give",
                 "press in", "presses in", "push in", "pushes in", "sink in", "sinks in", "cave", "cushiony",
                 "cushy", "plush", "squidg", "malleab", "crush", "dense", "unyield", "flimsy", "sturdy", "doughy",
                 "pillow",
                 # sixth version (after the seventh held-out set was read): inflections and resisting a press
                 "gives way", "giving way", "gave way", "resist being", "resists being", "resisted being",
                 "resist pressure", "resists pressure", "resist press", "resists press"),
    "roughness": ("rough", "smooth", "coarse", "grit", "grain", "textur", "sandpaper", "scratchy", "abrasiv",
                  "polish", "silk",
                  "rasp", "sandy", "scratch", "scrap", "prickl", "sleek", "gloss", "velvet", "satin", "fuzz", "harsh"),
    "bumpiness": ("bump", "lump", "ridge", "flat", "uneven", "knob", "nubb", "bobbl", "raised", "dimpl", "pimpl",
                  "stud",
                  "pebbl", "nodul", "wart", "hump", "ribbed", "corrugat", "wavy", "pitted", "pock", "bulg",
                  "stick up", "sticks up", "poke up", "pokes up", "stand out", "stands out",
                  # fourth version (2026-11-29, after the fifth held-out set was read, before the sixth was):
                  "sticking up", "poking up", "standing out",
                  # seventh version: a feature standing proud of a surface, or sitting flush with it
                  *STANDS_PROUD),
    "protrusion": ("protru", "stick out", "sticks out", "bump", "lump", "ridge", "flat", "uneven", "knob", "raised",
                   "stick up", "sticks up", "jut", "bulg", "stand out", "stands out", "spike", "nub", "hump",
                   "pointy",
                   "sticking out", "sticking up", "standing out",
                   # sixth version: poking something is no protrusion; something poking out is
                   "poke out", "pokes out", "poked out", "poke up", "pokes up", "poking out", "poking up",
                   "poking through", "pokes through",
                   # seventh version (after the ninth held-out set was read, as the eighth had: measured on the tenth)
                   *STANDS_PROUD),
    "elasticity": ("elastic", "spring", "bounc", "rebound", "stretch", "resilien",
                   "snap back", "snaps back", "come back", "comes back", "recover", "rubber", "flexib", "jiggl",
                   "wobbl", "original shape", "its shape",
                   # third version (2026-11-29, after the third held-out set was read, before the fourth was):
                   "into shape", "back to shape", "back in shape", "pop back", "pops back", "spring back",
                   "return to", "returns to", "regain", "reform", "bounce back"),
    "friction": ("friction", "slip", "grip", "sticky", "slick", "slid", "tacky", "traction",
                 "glide", "glid", "drag", "greas", "oily", "skid", "cling", "grab"),
}
"""Words (stems: a word starting with one counts) a person uses for each property, from general English, written
before any evaluation wording was run through it (experiments/2026-11-29_read_single_clip/criteria.md); the second
version's words (a thesaurus pass) before the third held-out set, written by someone who had not read this list, was
read (experiments/2026-11-29_person_words); the third version's (elasticity's "back into shape" and kin) after that
set was read and before the fourth was (experiments/2026-11-29_reask); the fourth version's (-ing forms of the
protrusion phrases) and :func:`asked_properties`' handling of analogies and of springing back after the fifth set
was read and before the sixth was (experiments/2026-11-29_lexicon_v4); the fifth version's (a gripper is no grip, a
cushion no cushiony feel, the robot's action words count only alone) after the sixth set was read and before the
seventh was (the same experiment's addendum); the sixth version's (poking is no protrusion, something poking out is;
keeping a fingerprint; resisting a press) after the seventh set was read, measured on the eighth; the seventh
version's (standing proud, sitting flush: :data:`STANDS_PROUD`) after the eighth and ninth sets were read (each
missed it once), measured on the tenth (experiments/2026-11-29_lexicon_v6_again); the eighth version's (holding a
dent, deforming for good, self-restoring: :data:`_SPRINGS_BACK`, :data:`RECOVERY_WORDS`) after the tenth and eleventh
were read, measured on the twelfth; :func:`asked_properties`' tenth to twelfth versions (an analogy naming a
property keeps it; "hard to" a difficulty; a story's words are background) each after the thirteenth to fifteenth
sets were read, measured on the next (experiments/2026-11-29_hybrid_reader); the thirteenth (two things offered
instead of a property, "like a cobblestone street or a paved road?": :mod:`tacreasoner.tasks.analogy`) after the
seventeenth was read, measured on the eighteenth (experiments/2026-11-30_analogy_reader). Where a
vocabulary has no roughness, its friction takes the roughness words (VTV-150K words friction as rough/smooth)."""
_ANALOGY = re.compile(r"\b(?:like|the\s+way)\b(?!\s+(?:to|it|this|that|they|you|i|in\s+terms|with\s+respect)\b)"
                      r"[^,;:?.!\n]*?"
                      r"(?=\s+or\b|\s+and\b|[,;:?.!\n]|$)", re.IGNORECASE)
"""An analogy ("sticky like a rubber mat", "the way a ball would"): the things it names are examples, not the
property asked ("rubber" is no elasticity question there). "What's it like in terms of hardness, …" is no analogy
(a fix after the twelfth held-out set was read: it had dropped the first property named)."""
_SPRINGS_BACK = re.compile(r"\b(?:pops?|popping|springs?|springing|bounces?|bouncing|snaps?|snapping|comes?|coming|"
                           r"go|goes|going|jumps?|jumping|returns?|returning)\s+(?:\w+\s+)?back\b(?!\s+and\b)|"
                           r"\b(?:dent|dents|dip|mark|imprint)\s+(?:\w+\s+)?stays?\b|"
                           r"\bstays?\s+(?:\w+\s+)?(?:dented|squashed|squished|pressed|deformed|flattened)\b|"
                           r"\b(?:keeps?|keeping|holds?|holding|retains?|retaining)\s+(?:the|a|my|your|its|an)\s+"
                           r"(?:\w+\s+)?(?:dent|mark|imprint|fingerprint|print|impression)\b|"
                           # eighth version: staying deformed for good
                           r"\b(?:deform(?:s|ed|ing)?|dent(?:s|ed)?|squash(?:es|ed)?)\s+(?:\w+\s+)?(?:permanently|for\s+good)\b|"
                           r"\bpermanently\s+(?:deform|dent|squash|flatten)", re.IGNORECASE)
"""Whether the shape comes back after a press ("does it pop right back out", "does the dent stay"): elasticity."""
RECOVERY_WORDS: tuple[str, ...] = ("rebound", "recover", "resilien", "snap back", "snaps back", "come back",
                                   "comes back", "original shape", "its shape", "into shape", "back to shape",
                                   "back in shape", "pop back", "pops back", "spring back", "return to", "returns to",
                                   "regain", "reform", "bounce back",
                                   # eighth version
                                   "self-restor", "self restor")
"""Elasticity words that ask whether the shape comes back (as :data:`_SPRINGS_BACK`), not what it is made of."""
PRESSING_WORDS: tuple[str, ...] = ("dent", "press in", "presses in", "push in", "pushes in", "sink in", "sinks in",
                                   "deform", "squish", "squash", "compress", "squeez", "crush", "it give", "it gives",
                                   "give when", "gives when", "give under", "gives under", "any give")
"""Hardness words that also describe the press an elasticity question asks about ("if I push in and the dent
stays…"): beside a springing-back phrase they do not make it a hardness question too."""
ACTION_WORDS: tuple[str, ...] = ("slid", "press in", "presses in", "push in", "pushes in")
"""Words for what the robot did ("the sensor slid along it", "pushed in"): they name a property only when the
question names no other (fifth version)."""
NOT_PROPERTY_WORDS = re.compile(r"\b(grippers?|sliders?)\b|\bhardly\b|"
                                r"\bhard(?:er)?\s+(?:to|for)\b(?!\s+(?:the\s+)?touch)", re.IGNORECASE)
"""Words that start like a property word but name a thing (the robot's gripper) or a difficulty ("hard to hold onto
with wet hands", "hardly": eleventh version, after the fourteenth set was read; "hard to the touch" is still
hardness, and "hard to squeeze" is by its verb): not read as the property."""
_WHOLE_OBJECT = re.compile(r"\b(feels?\s+like|profile|properties|describe\s+(what|how|this|the)|how\s+does\s+(it|this)"
                           r"\s+(\w+\s+)?feel|what\s+do\s+you\s+feel)\b", re.IGNORECASE)


@lru_cache(maxsize=64)
def _stems_pattern(stems: tuple[str, ...]) -> re.Pattern[str]:
    return re.compile(r"\b(" + "|".join(re.escape(w) for w in stems) + ")", re.IGNORECASE)


def _names_a_stem(text: str, stems: tuple[str, ...]) -> bool:
    """Whether a word of ``text`` starts with one of ``stems`` (or is one of its phrases)."""
    return _stems_pattern(stems).search(text) is not None


PropertyFallback = Callable[[str, str], "str | None"]
"""(question, vocabulary) → the one property a question asks, for what the word list does not read (the answering
modes pass ``model.sentence_reader.PropertyReader``: a sentence embedding's nearest property)."""


def asked_properties(question: str, vocabulary: str, fallback: PropertyFallback | None = None) -> list[str] | None:
    """The properties a question about one clip asks for, read from its words (:data:`PROPERTY_WORDS`), in
    vocabulary order: the ones it names; else the one two things offered differ on ("like a brick or a marshmallow?":
    :func:`tacreasoner.tasks.analogy.analogy_properties`); else every one for a question about how the object feels
    as a whole ("What does this feel like?"); None when it asks about none of them ("Is this a real orange?").
    ``fallback`` reads a question the words name no property of, unless it asks whether a thing is real or what
    touch cannot tell (:func:`asked_fruit`, :data:`BEYOND_TOUCH`: those have replies of their own)."""
    text = NOT_PROPERTY_WORDS.sub(" ", question.replace(PLACEHOLDER, " "))
    vocab = get_vocabulary(vocabulary)
    found = _read_words(text, vocab)
    if len(found) > 1:  # a story's words are background: the property asked is the one its question names
        asked_in_questions = {a for sentence in _QUESTION_SENTENCE.findall(text) for a in _read_words(sentence, vocab)}
        if len(asked_in_questions) == 1:
            return list(asked_in_questions)
    if found:
        return found
    offered = analogy_properties(text, vocab)  # "like a cobblestone street or a paved road?" (thirteenth version)
    if len(offered) == 1:
        return list(offered)
    may_fall_back = fallback is not None and not _asks_real(text) and _thing_beyond_touch(text) is None
    if offered and may_fall_back and (read := fallback(question, vocabulary)) in offered:
        return [read]
    if _WHOLE_OBJECT.search(text):
        return list(vocab)
    if not may_fall_back:
        return None
    read = fallback(question, vocabulary)
    return [read] if read in vocab else None


_QUESTION_SENTENCE = re.compile(r"[^.!?\n]*\?")
"""A sentence that asks (ends in a question mark): "Working on a grip-texture study. Is the surface uneven with
bumps, or flat?" asks bumpiness, not roughness (twelfth version, after the fifteenth set was read)."""


def _read_words(text: str, vocab: Mapping[str, Attribute]) -> list[str]:
    """The properties ``text``'s words name (:func:`_named_properties`). An analogy's things are examples ("slick
    like wet soap or sticky like a rubber mat?" asks friction), unless the analogy is all it says ("Is it more like
    sandpaper or glass?")."""
    return _named_properties(_drop_analogies(text, vocab), vocab) or _named_properties(text, vocab)


def _drop_analogies(text: str, vocab: Mapping[str, Attribute]) -> str:
    """``text`` without its analogies (:data:`_ANALOGY`); a span that names a property by its name ("what it felt
    like - tell us its hardness, …") is no analogy and stays (tenth version, after the thirteenth set was read)."""
    names = tuple(vocab)
    return _ANALOGY.sub(lambda m: m.group(0) if _names_a_stem(m.group(0), names) else " ", text)


def _named_properties(text: str, vocab: Mapping[str, Attribute]) -> list[str]:
    """The properties of ``vocab`` whose words ``text`` uses, in vocabulary order (see :func:`asked_properties`)."""
    springs_back = "elasticity" in vocab and (_SPRINGS_BACK.search(text) is not None
                                              or _names_a_stem(text, RECOVERY_WORDS))
    found, by_action = [], []
    for attribute in vocab:
        words = (*PROPERTY_WORDS.get(attribute, ()), attribute)
        if attribute == "friction" and "roughness" not in vocab:
            words += PROPERTY_WORDS["roughness"]
        if springs_back and attribute == "hardness":  # the press is part of the elasticity question
            words = tuple(w for w in words if w not in PRESSING_WORDS)
        if _names_a_stem(text, tuple(w for w in words if w not in ACTION_WORDS)) or \
                (springs_back and attribute == "elasticity"):
            found.append(attribute)
        elif _names_a_stem(text, words):
            by_action.append(attribute)
    return found or by_action


BEYOND_TOUCH: dict[str, tuple[str, ...]] = {
    "colour": ("colour", "color"),
    "smell": ("smell", "odour", "odor", "scent"),
    "taste": ("taste", "flavour", "flavor"),
    "weight": ("weigh", "heavy", "heavi", "how light"),
    "temperature": ("temperature", "hot", "cold", "warm"),
    "sound": ("sound", "noise", "loud"),
    "price": ("price", "cost", "expensive", "cheap"),
    "brand": ("brand", "who made", "manufactur"),
}
"""What a person may ask about an object that a vision-based tactile sensor does not sense (its gel images show
contact geometry and shear, not colour, smell, weight or heat): stems, as :data:`PROPERTY_WORDS`."""
_REAL_OR_FAKE = re.compile(r"\b(real|fake|artificial|plastic|genuine)\b", re.IGNORECASE)
_ASKS_REAL = re.compile(r"\b(real|fake|artificial|genuine|imitation|replica|faux|fakes|reals)\b", re.IGNORECASE)
_ASKS_REAL_IF_FRUIT = re.compile(r"\b(plastic|toy|decoration|decorative|prop)\b", re.IGNORECASE)
FRUIT_WORDS: tuple[str, ...] = (
    "apple", "apricot", "avocado", "banana", "blackberry", "blueberry", "cherry", "clementine", "coconut", "fig",
    "grape", "grapefruit", "guava", "kiwi", "lemon", "lime", "lychee", "mandarin", "mango", "melon", "nectarine",
    "orange", "papaya", "passion fruit", "peach", "pear", "persimmon", "pineapple", "plum", "pomegranate", "raspberry",
    "strawberry", "tangerine", "tomato", "watermelon")
"""Common fruit (general English, not the simulator's list), for reading which fruit a real-or-fake question is
about."""
_FRUIT = re.compile(r"\b(" + "|".join(
    re.escape(f[:-1]) + "(?:y|ies)" if f.endswith("y") else re.escape(f) + "(?:e?s)?"
    for f in sorted(FRUIT_WORDS, key=len, reverse=True)) + r")\b", re.IGNORECASE)


_REAL_CHOICE = re.compile(r"\b(real|genuine|fake)\s+(one\s+)?or\b|\bor\s+(an?\s+)?(fake|real|artificial|plastic|"
                          r"imitation|genuine|toy)\b", re.IGNORECASE)


def asked_fruit(question: str, names_property: bool = False) -> str | None:
    """The fruit a question about one clip asks real-or-fake about, read from its words ("Is this strawberry a
    fake?" → ``strawberry``; ``fruit`` where none is named); None when it does not ask whether the thing is real
    ("plastic" or "toy" count only beside a fruit). ``names_property``: the question also names a property
    (:func:`asked_properties`); it then asks real-or-fake only where it offers the two as choices ("Judging by how
    squishy it is, is this peach real or fake?", not "Is this fake orange soft?")."""
    text = question.replace(PLACEHOLDER, " ")
    named = _FRUIT.search(text)
    if not (_ASKS_REAL.search(text) or (named and _ASKS_REAL_IF_FRUIT.search(text))):
        return None
    if names_property and not _REAL_CHOICE.search(text):
        return None
    if named is None:
        return "fruit"
    word = named.group(1).lower()
    return next(f for f in FRUIT_WORDS if word in (f, f + "s", f + "es", f[:-1] + "ies"))


def beyond_touch(question: str, vocabulary: str) -> str | None:
    """What a question asks that touch cannot tell (:data:`BEYOND_TOUCH`: "What colour is this?" → ``colour``), when
    it asks for none of the properties (:func:`asked_properties`) and not whether the object is real
    (:func:`asked_fruit`); else None."""
    text = question.replace(PLACEHOLDER, " ")
    if asked_properties(text, vocabulary) is not None or _asks_real(text):
        return None
    return _thing_beyond_touch(text)


def _asks_real(text: str) -> bool:
    """Whether ``text`` asks if the object is real (real/fake words, or :func:`asked_fruit`)."""
    return _REAL_OR_FAKE.search(text) is not None or asked_fruit(text) is not None


def _thing_beyond_touch(text: str) -> str | None:
    """The first :data:`BEYOND_TOUCH` thing ``text`` names ("colour"), else None."""
    return next((thing for thing, words in BEYOND_TOUCH.items() if _names_a_stem(text, words)), None)


def needed_attributes(item: QAItem) -> list[str]:
    """The attributes an item's answer depends on, in vocabulary order."""
    vocab = get_vocabulary(item.vocabulary)
    if item.task in ("SFD", "PC", "SOI"):
        return [str(item.gold["attribute"])]
    if item.task == "TSA":
        return [a for a in vocab if a in item.gold["needs"]]
    if item.task == "OSC":
        return list(vocab)
    raise ValueError(f"item {item.id!r}: task {item.task} is not reasoned over objects ({', '.join(REASONED_TASKS)})")


def item_levels(item: QAItem) -> list[Levels]:
    """Each video's gold levels of the attributes the item needs, from the labels the builder kept in ``meta``."""
    ranks = item.meta.get("ranks")
    if not isinstance(ranks, list) or len(ranks) != len(item.videos):
        raise ValueError(f"item {item.id!r} ({item.task}): meta 'ranks' must give every video's levels "
                         f"(rebuild the benchmark with this version)")
    needed = needed_attributes(item)
    if item.task in ("SFD", "PC", "SOI"):
        return [{needed[0]: int(r)} for r in ranks]
    return [{a: int(r[a]) for a in needed} for r in ranks]


def option_levels(item: QAItem) -> list[Levels]:
    """OSC: each named option's gold levels (the levels of the video recorded on it)."""
    if item.task != "OSC":
        raise ValueError(f"item {item.id!r}: only OSC items name objects as options")
    videos = item_levels(item)
    out: list[Levels] = [{} for _ in item.options]
    for video, option in enumerate(item.gold["assignment"]):
        out[int(option)] = videos[video]
    return out


def read_levels(text: str, attributes: Sequence[str], vocab: Mapping[str, Attribute]) -> Levels | None:
    """The one level of each attribute named in ``text``; None when an attribute is missing or named twice."""
    table = {phrase: (a, rank) for a in attributes for rank, phrase in enumerate(vocab[a].levels)}
    found = _find_phrases(text, table)
    out: Levels = {}
    for attribute in attributes:
        ranks = {rank for _, (a, rank) in found if a == attribute}
        if len(ranks) != 1:
            return None
        out[attribute] = ranks.pop()
    return out


def read_needs(text: str, attributes: Sequence[str]) -> dict[str, str]:
    """``… needs high hardness and low roughness.`` → {hardness: high, roughness: low}: what a text says a scenario
    needs (known ``attributes`` only; the first mention of an attribute wins)."""
    out: dict[str, str] = {}
    for level, attribute in _NEED.findall(text):
        if attribute.lower() in attributes and attribute.lower() not in out:
            out[attribute.lower()] = level.lower()
    return out


def labelled_levels(pattern: re.Pattern[str], text: str, labels: Sequence[str], attributes: Sequence[str],
                    vocab: Mapping[str, Attribute]) -> list[Levels | None]:
    """Per label (``1``, ``A`` …), the levels of ``attributes`` that ``text`` states after it (``pattern``: group 1
    the label, group 2 the span read; the first statement of a label wins); None where it states them not once."""
    spans = {m.group(1).upper(): m.group(2) for m in reversed(list(pattern.finditer(text)))}
    return [read_levels(spans[k], attributes, vocab) if k in spans else None for k in labels]


def stated_levels(item: QAItem, reasoning: str, needs: Mapping[str, str] | None = None,
                  ) -> tuple[list[Levels], list[Levels]] | None:
    """(per video, per option) levels a reply's reasoning states (``Video 1: hard, rough.`` …; OSC also
    ``(A) a lemon: moderately hard, …``); None when any video's (or option's) needed levels are not stated once.
    TSA: the levels of what ``needs`` names (default the scenario's true needs)."""
    vocab = get_vocabulary(item.vocabulary)
    needed = [a for a in vocab if a in needs] if item.task == "TSA" and needs else needed_attributes(item)

    def read(pattern: re.Pattern[str], keys: Sequence[str]) -> list[Levels] | None:
        levels = labelled_levels(pattern, reasoning, keys, needed, vocab)
        return None if any(v is None for v in levels) else levels  # type: ignore[return-value]

    videos = read(_VIDEO, [str(v + 1) for v in range(len(item.videos))])
    if videos is None:
        return None
    if item.task != "OSC":
        return videos, []
    options = read(_OPTION, list("ABC"[: len(item.options)]))
    return None if options is None else (videos, options)


def _extremes(values: Sequence[int], highest: bool) -> set[int]:
    best = max(values) if highest else min(values)
    return {i for i, v in enumerate(values) if v == best}


def _distance(a: Levels, b: Levels) -> int:
    return sum(abs(a[k] - b[k]) for k in a)


def implied_answers(item: QAItem, videos: Sequence[Levels], options: Sequence[Levels] = (),
                    needs: Mapping[str, str] | None = None) -> set[Any]:
    """Every answer (scorer's parsed form) that these levels imply for ``item``'s question; TSA weighs the levels by
    ``needs`` (attribute → high | low; default the item's gold needs)."""
    if item.task in ("SFD", "PC", "SOI"):
        attribute = str(item.gold["attribute"])
        ranks = [int(v[attribute]) for v in videos]
    if item.task == "PC":
        return {PC_RELATIONS[0] if ranks[0] > ranks[1] else PC_RELATIONS[1] if ranks[0] < ranks[1]
                else PC_RELATIONS[2]}
    if item.task == "SOI":
        return _extremes(ranks, item.gold["direction"] == "most")
    if item.task == "SFD":
        more = item.gold["direction"] == "more"
        if item.gold["kind"] == "which":  # a tie allows either object
            return _extremes(ranks, more)
        return {ranks[0] > ranks[1] if more else ranks[0] < ranks[1]}  # "is the first harder?" no when equal
    if item.task == "TSA":
        scores = [suitability(item.gold["needs"] if needs is None else needs, v) for v in videos]
        return {TSA_LETTERS[i] for i in _extremes(scores, True)}
    if item.task == "OSC":
        if len(options) != len(videos):
            raise ValueError(f"item {item.id!r} (OSC): needs every option's levels to match videos to names")
        costs = {perm: sum(_distance(videos[v], options[k]) for v, k in enumerate(perm))
                 for perm in itertools.permutations(range(len(options)))}
        best = min(costs.values())
        return {perm for perm, cost in costs.items() if cost == best}
    raise ValueError(f"item {item.id!r}: task {item.task} is not reasoned over objects ({', '.join(REASONED_TASKS)})")


def parsed_answer(item: QAItem, reply: str) -> Any:
    """The reply's answer in the form :func:`implied_answers` gives (strict extraction; None when unreadable):
    an OSC assignment as a tuple, a lettered SFD/SOI wording's letter as the object's index."""
    if item.meta.get("answer_form") == "letter":  # a training wording that letters the objects
        answer = (extract_answer(reply, "strict") or "").strip().rstrip(".").upper()
        return _OBJECT_LETTERS.index(answer) if len(answer) == 1 and answer in _OBJECT_LETTERS else None
    parsed = score_item(item, reply, "strict").parsed
    return tuple(parsed) if isinstance(parsed, list) else parsed


@dataclass(frozen=True)
class Consistency:
    """Whether one reply's answer follows from the levels its reasoning stated."""

    status: str
    """``consistent`` | ``inconsistent`` | ``no levels`` (no reasoning, or a video's levels not stated once) |
    ``no answer`` (levels stated, answer unreadable)."""
    implied: tuple[Any, ...] = ()

    @property
    def consistent(self) -> bool:
        return self.status == "consistent"


def consistency(item: QAItem, reply: str) -> Consistency:
    """Read the levels ``reply`` states for ``item`` and check its answer against what they imply. TSA: weighed by the
    needs the reply says the scenario has (``… needs high hardness …``), else by its true needs."""
    reasoning, _ = split_reasoning(reply)
    needs = read_needs(reasoning, list(get_vocabulary(item.vocabulary))) if reasoning and item.task == "TSA" else {}
    stated = stated_levels(item, reasoning, needs) if reasoning else None
    if stated is None:
        return Consistency("no levels")
    implied = implied_answers(item, *stated, needs=needs or None)
    parsed = parsed_answer(item, reply)
    if parsed is None:
        return Consistency("no answer", tuple(sorted(implied, key=str)))
    return Consistency("consistent" if parsed in implied else "inconsistent", tuple(sorted(implied, key=str)))
