"""Does a reply's reasoning contradict the question or its own answer? (the benchmark's hallucination measure)

Accuracy says whether the answer is right; it cannot see a reply that reaches a right answer through reasoning
about the wrong object, or one whose reasoning concludes one thing and answers another. Two checks read the
reasoning (the ``<think>`` text, :func:`~tacreasoner.tasks.extract.split_reasoning`):

* ``other_object`` — the reasoning names a known object that the question does not mention ("Is the banana
  real or fake?" … "so this strawberry is fake"). Known objects are the simulator catalogue's
  (:func:`tacreasoner.sim.materials.catalogue`) plus any extra names passed in (the report adds the
  commonsense corpus's everyday objects). Matching is case-insensitive on whole words with simple plurals;
  "real apple"/"fake apple" count as "apple". Comparisons and analogies ("soft like a sponge", "harder than an
  apple", "not a peach"), hyphen compounds ("sponge-like") and colours ("orange tint") are not a claim about
  what the object is and are not counted.
* ``contradicts_answer`` — the reasoning's last readable conclusion names another value than the answer.
  A conclusion is a sentence with a marker ("so", "therefore", "thus", "hence", "overall", "which means",
  "answer:" …), read from the marker on (and up to "than") with the task's own lenient parser
  (:func:`~tacreasoner.tasks.scoring.score_item`), exactly as answers are read. Unmarked sentences are not
  read: "Video 2 presses in deeper" names a video without concluding anything about the question.

Both are conservative, because a false alarm makes the rate useless: negated conclusions are not read (RFOR's
parser understands negation, so RFOR's are); a yes/no conclusion must start with yes/no ("So no: …", not
"so no slip"); SFD/SOI conclusions that use the opposite comparative ("so the first is softer" when the
question asks for the harder) are not read; PC conclusions that speak of the second object ("so the second is
softer") are not read (PC's relation is the first object's); TSA conclusions must speak of choice or suitability; OCSE
conclusions with a temporal word ("after the press") are not read.

A reply is *checkable* when it has reasoning and at least one check found something to judge: a known object
name, or a conclusion and an answer that both read. Replies without reasoning, and replies with neither, are
not checkable; they are counted separately, never as consistent.
"""

from __future__ import annotations

import re
from collections.abc import Collection, Iterable, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

from tacreasoner.sim.materials import catalogue
from tacreasoner.tasks.extract import extract_answer, split_reasoning
from tacreasoner.tasks.schema import QAItem
from tacreasoner.tasks.scoring import score_item
from tacreasoner.tasks.vocab import get_vocabulary

__all__ = [
    "REASONS",
    "ConsistencyCheck",
    "ObjectVocabulary",
    "check_reasoning",
    "conclusion_of",
    "default_object_vocabulary",
    "name_forms",
    "named_objects",
    "object_vocabulary",
]

REASONS = ("other_object", "contradicts_answer")
"""Reason codes, in the order they are listed on a check."""

ObjectVocabulary = Sequence[Collection[str]]
"""Known objects: one collection of lower-case names (aliases) per kind, e.g. ``{"kitchen sponge", "sponge"}``."""


@dataclass(frozen=True)
class ConsistencyCheck:
    """Outcome of both checks on one reply; ``flag`` is what reports count (None = not checkable)."""

    checkable: bool
    hallucinated: bool
    reasons: list[str] = field(default_factory=list)
    """Codes from :data:`REASONS`."""
    detail: str = ""
    """Human-readable: which objects, which conclusion against which answer, or why not checkable."""
    other_objects: list[str] = field(default_factory=list)
    """Names the reasoning uses for objects the question does not mention, as written in the reasoning."""
    conclusion: str | None = None
    """The conclusion clause that was compared with the answer, when both were readable."""
    concluded: Any = None
    answered: Any = None

    @property
    def flag(self) -> bool | None:
        """True/False when checkable, None when not (so a rate can leave it out of the denominator)."""
        return self.hallucinated if self.checkable else None

    def to_dict(self) -> dict:
        return {"checkable": self.checkable, "hallucinated": self.hallucinated, "reasons": list(self.reasons),
                "detail": self.detail, "other_objects": list(self.other_objects), "conclusion": self.conclusion,
                "concluded": self.concluded, "answered": self.answered}


# ----------------------------------------------------------------------------------------------- object names

_ARTICLE = re.compile(r"^(?:a|an|the|some)\s+", re.IGNORECASE)
_VARIANT = re.compile(r"\s*\(variant \d+\)\s*$")
_REAL_FAKE = re.compile(r"^(?:real|fake)\s+")


def name_forms(name: str) -> list[str]:
    """The lower-case names one display name is known by: ``"a fake apple"`` → ``["apple"]``.

    The article, a simulator ``(variant N)`` suffix and a leading real/fake are dropped (real/fake is the RFOR
    verdict, not another object); a measure phrase also yields its substance (``"a sheet of sandpaper"`` →
    ``sheet of sandpaper``, ``sandpaper``).
    """
    bare = _REAL_FAKE.sub("", _ARTICLE.sub("", _VARIANT.sub("", " ".join(name.lower().split()))))
    forms = [bare] if bare else []
    if " of " in bare:
        forms.append(bare.rsplit(" of ", 1)[1])
    return forms


def object_vocabulary(extra_names: Iterable[str] = ()) -> tuple[frozenset[str], ...]:
    """Known objects: the simulator catalogue's, then ``extra_names`` (display names with or without article).

    A catalogue object is also known by its category when that is its display name's head noun ("a kitchen
    sponge" → sponge), never by a material word ("a rubber ball" is not "rubber": "springy like rubber" is a
    material, not an object). Objects sharing a name are one kind (real and fake apple → apple).
    """
    groups: list[set[str]] = []
    for m in catalogue():
        forms = name_forms(m.display_name)
        if forms and forms[0].split()[-1] == m.category.lower():
            forms.append(m.category.lower())
        groups.append(set(forms))
    groups += [set(name_forms(n)) for n in extra_names]
    merged: list[set[str]] = []
    for g in (g for g in groups if g):
        overlapping = [m for m in merged if m & g]
        for m in overlapping:
            merged.remove(m)
            g |= m
        merged.append(g)
    return tuple(frozenset(g) for g in merged)


@lru_cache(maxsize=1)
def default_object_vocabulary() -> tuple[frozenset[str], ...]:
    """The simulator catalogue's objects (what the ``tasks`` layer can know; callers may pass more)."""
    return object_vocabulary()


@lru_cache(maxsize=4096)
def _name_regex(name: str) -> re.Pattern[str]:
    """Whole-word, case-insensitive pattern for a name with a simple plural (peach/peaches, berry/berries)."""
    words = name.split()
    last = words[-1]
    if len(last) > 2 and last.endswith("y") and last[-2] not in "aeiou":
        tail = re.escape(last[:-1]) + "(?:y|ies)"
    else:
        tail = re.escape(last) + "(?:e?s)?"
    body = r"[\s-]+".join([*(re.escape(w) for w in words[:-1]), tail])
    return re.compile(r"(?<![\w-])" + body + r"(?![\w-])", re.IGNORECASE)


_NOT_A_CLAIM_BEFORE = re.compile(
    r"(?:\b(?:like|unlike|than|resembl\w*|similar\s+to|compared\s+(?:to|with)|such\s+as|akin\s+to|(?:kind|sort|type)"
    r"\s+of|instead\s+of|not|never|nor|neither)\s+(?:(?:a|an|the|some|any)\s+)?(?:[\w-]+\s+){0,2}"
    r"|\bas\s+(?:a|an)\s+(?:[\w-]+\s+)?)$",
    re.IGNORECASE)
"""An analogy, comparison or negation just before a name: "like a ripe peach", "as a sponge", "not an apple"
("as the banana yields" is a claim: only "as a/an" is read as an analogy)."""
_NOT_A_CLAIM_AFTER = re.compile(r"^\s*(?:colou?r\w*|tint\w*|hue\w*|shade\w*|tone\w*|glow\w*)\b", re.IGNORECASE)
"""A colour after a name: "orange tint"."""


def _mentions(text: str, vocabulary: ObjectVocabulary, claims_only: bool) -> list[tuple[int, str]]:
    """(object index, name as written) of each mention in ``text``; longer names claim their span first."""
    names = sorted(((n, i) for i, group in enumerate(vocabulary) for n in group), key=lambda p: (-len(p[0]), p[0]))
    claimed: list[tuple[int, int]] = []
    found: list[tuple[int, int, str]] = []
    for name, index in names:
        for m in _name_regex(name).finditer(text):
            if any(m.start() < end and start < m.end() for start, end in claimed):
                continue
            claimed.append((m.start(), m.end()))
            if claims_only and (_NOT_A_CLAIM_BEFORE.search(text[: m.start()])
                                or _NOT_A_CLAIM_AFTER.match(text[m.end():])):
                continue
            found.append((m.start(), index, m.group(0)))
    return [(index, written) for _, index, written in sorted(found)]


def named_objects(text: str, vocabulary: ObjectVocabulary | None = None, claims_only: bool = True) -> list[str]:
    """The names of known objects ``text`` mentions, as written, in text order (analogies left out by default)."""
    vocabulary = default_object_vocabulary() if vocabulary is None else vocabulary
    return [written for _, written in _mentions(text, vocabulary, claims_only)]


def _question_text(item: QAItem) -> str:
    return " ".join([item.question, *item.options])


def _other_objects(item: QAItem, think: str, vocabulary: ObjectVocabulary) -> tuple[list[str], bool]:
    """(names of objects the reasoning claims that the question never mentions, whether any object was named)."""
    in_question = {i for i, _ in _mentions(_question_text(item), vocabulary, claims_only=False)}
    mentioned = _mentions(think, vocabulary, claims_only=True)
    others = list(dict.fromkeys(written.lower() for i, written in mentioned if i not in in_question))
    return others, bool(mentioned)


# ------------------------------------------------------------------------------------------------ conclusions

_SENTENCE_END = re.compile(r"(?<=[.!?])\s+|\n+")
_MARKER = re.compile(
    r"^\W*overall\b|\boverall\s*,"  # "the overall area …" is an adjective, not a conclusion
    r"|\b(?:therefore|thus|hence|consequently|in conclusion|in summary|all in all|which means|this means|"
    r"i conclude|so(?!\s+(?:far|that|much|many|little|long|on|quickly|slowly|strongly|weakly)\b))\b"
    r"|\banswer\s*(?:is\b|:)",
    re.IGNORECASE)
_THAN = re.compile(r"\bthan\b", re.IGNORECASE)
_NEGATION = re.compile(r"\b(?:not|never|neither|nor|cannot|no\s+longer)\b|n't\b", re.IGNORECASE)
_YES_NO_LEAD = re.compile(r"^\W*(?:the\s+answer\s+is\s+)?(yes|no)\b(?=\s*(?:[,:;.!—–-]|$))", re.IGNORECASE)
_LOW_WORDS = re.compile(r"\b(?:less|least|lower|lowest|fewer|fewest)\b", re.IGNORECASE)
_HIGH_WORDS = re.compile(r"\b(?:more|most|higher|highest|greater|greatest)\b", re.IGNORECASE)
_TSA_CHOICE = re.compile(r"\b(?:better|best|suit\w*|choos\w*|chose\w*|choice|pick\w*|prefer\w*|option|fits?|"
                         r"ideal|answer)\b", re.IGNORECASE)
_TSA_AGAINST = re.compile(r"\b(?:worse|worst|less|least|poor\w*|unsuit\w*|bad|too)\b", re.IGNORECASE)
_TSA_BARE = re.compile(r"^\W*(?:it\s+is\s+)?(?:\(?[ab]\)?|(?:the\s+)?(?:first|second)(?:\s+(?:object|one))?)\W*$",
                       re.IGNORECASE)
_OCSE_TEMPORAL = re.compile(r"\b(?:after|before|then|next|previous\w*|following|followed|until|once|earlier|later|"
                            r"transition\w*|preced\w*|prior)\b", re.IGNORECASE)


_PC_OTHER = re.compile(r"\b(?:second|2nd|(?:video|object|clip)\s*2)\b", re.IGNORECASE)
"""PC reads a relation as the first object's: a clause about the second object is left unread."""


def _clauses(think: str) -> list[str]:
    """Conclusion clauses, last sentence first; within a sentence, from its last marker to its first."""
    sentences = [s.strip() for s in _SENTENCE_END.split(think) if s.strip()]
    out = []
    for sentence in reversed(sentences):
        for m in reversed(list(_MARKER.finditer(sentence))):
            out.append(sentence[m.end():].strip(" ,:;—–-"))
    return out


def _is_yes_no(item: QAItem) -> bool:
    return item.task == "SFD" and item.gold.get("kind") == "yesno"


def _opposite_direction(item: QAItem, clause: str) -> bool | None:
    """SFD "which"/SOI: does the clause speak of the opposite direction to the question's? None = cannot tell."""
    attribute, direction = item.gold.get("attribute"), item.gold.get("direction")
    try:
        attr = get_vocabulary(item.vocabulary)[attribute]
    except (KeyError, ValueError, TypeError):
        return None
    if direction in ("more", "most"):
        opposite, generic = (attr.less, attr.least), _LOW_WORDS
    elif direction in ("less", "least"):
        opposite, generic = (attr.more, attr.most), _HIGH_WORDS
    else:
        return None
    asked = {attr.more, attr.most} if direction in ("more", "most") else {attr.less, attr.least}
    low = clause.lower()
    # The question's own comparative may contain a generic word ("less elastic"): blank it before looking.
    for phrase in asked:
        low = re.sub(r"\b" + re.escape(phrase.lower()) + r"\b", " ", low)
    return any(re.search(r"\b" + re.escape(p.lower()) + r"\b", low) for p in opposite) or bool(generic.search(low))


def _readable_clause(item: QAItem, clause: str) -> str | None:
    """The part of a conclusion clause that may be read for ``item``'s task, or None when it must not be."""
    if _is_yes_no(item):
        m = _YES_NO_LEAD.match(clause)
        return m.group(1) if m else None
    than = _THAN.search(clause)
    text = clause[: than.start()] if than else clause
    if not text.strip():
        return None
    if item.task != "RFOR" and _NEGATION.search(text):
        return None
    if item.task in ("SFD", "SOI"):
        return None if _opposite_direction(item, text) in (True, None) else text
    if item.task == "PC" and _PC_OTHER.search(text):  # "the second is softer" means "more": not read
        return None
    if item.task == "TSA" and (_TSA_AGAINST.search(text) or not (_TSA_CHOICE.search(text) or _TSA_BARE.match(text))):
        return None
    if item.task == "OCSE" and _OCSE_TEMPORAL.search(text):
        return None
    return text


def _read(item: QAItem, text: str | None) -> Any:
    """The value ``text`` names in the gold's terms (the task's lenient parser), or None."""
    if not text or not text.strip():
        return None
    value = score_item(item, f"<answer>{text}</answer>", "lenient").parsed
    if isinstance(value, dict) and all(v is None for v in value.values()):
        return None
    return value


def conclusion_of(item: QAItem, think: str) -> tuple[str, Any] | None:
    """(clause, value) of the reasoning's last readable conclusion for ``item``, or None when it states none."""
    for clause in _clauses(think):
        value = _read(item, _readable_clause(item, clause))
        if value is not None:
            return clause, value
    return None


def _disagrees(concluded: Any, answered: Any) -> bool:
    """Values differ; for TFA-combined only attributes read on both sides count."""
    if isinstance(concluded, dict) and isinstance(answered, dict):
        return any(v is not None and answered.get(k) is not None and v != answered[k] for k, v in concluded.items())
    return concluded != answered


def _answer_text(prediction: str) -> str | None:
    """The reply's answer: its last closed answer block, else (after a closed think block) the lenient reading."""
    _, answer = split_reasoning(prediction)
    if answer is None and re.search(r"</think>", prediction, re.IGNORECASE):
        answer = extract_answer(prediction, "lenient")
    return answer


# ------------------------------------------------------------------------------------------------ the check


def check_reasoning(item: QAItem, prediction: str, objects: ObjectVocabulary | None = None) -> ConsistencyCheck:
    """Both consistency checks on one reply (full text, tags included) to ``item`` (see the module doc).

    ``objects`` is the known-object vocabulary (:func:`object_vocabulary`); default: the simulator catalogue.
    """
    vocabulary = default_object_vocabulary() if objects is None else objects
    think, _ = split_reasoning(prediction)
    if not think:
        return ConsistencyCheck(False, False, detail="no reasoning (<think>) to check")
    reasons: list[str] = []
    notes: list[str] = []
    others, named_any = _other_objects(item, think, vocabulary)
    if others:
        reasons.append("other_object")
        notes.append(f"reasoning names {', '.join(repr(o) for o in others)}, which the question does not mention")
    answer = _answer_text(prediction)
    answered = _read(item, answer)
    found = conclusion_of(item, think) if answered is not None else None
    compared = found is not None
    clause, concluded = found if found is not None else (None, None)
    if found is not None and _disagrees(concluded, answered):
        reasons.append("contradicts_answer")
        notes.append(f"reasoning concludes {clause!r} ({concluded!r}) but answers {answer!r} ({answered!r})")
    checkable = named_any or compared
    if not checkable:
        why = "no readable answer" if answered is None else "no readable conclusion"
        notes.append(f"not checkable: no known object named and {why}")
    elif not reasons:
        notes.append("consistent" + (f": concludes {clause!r}" if compared else ""))
    return ConsistencyCheck(checkable=checkable, hallucinated=bool(reasons), reasons=reasons, detail="; ".join(notes),
                            other_objects=others, conclusion=clause, concluded=concluded,
                            answered=answered if compared else None)
