"""Task scorers: is a model's answer to a QA item right?

Scorers are small pure functions over the extracted answer text (see :mod:`tacreasoner.tasks.extract`)
and the item's machine-readable ``gold`` (conventions in :mod:`tacreasoner.tasks.schema`). Each
``parse_*`` function turns an answer into a value in the gold's own terms (level rank, 0-based index,
bool, letter, …) or ``None`` when it cannot be read; ``score_item`` compares that value with the gold.

Modes:

* ``strict`` accepts the canonical answer texts the builders write (modulo case, whitespace and a
  trailing period), so a trained model is held to its output format.
* ``lenient`` first tries the strict reading, then looks for the answer inside free text (for
  baselines that answer in sentences). Because it tries strict first, and strict extraction is a
  subset of lenient extraction, lenient never scores an item lower than strict.

An answer that cannot be read is wrong and is also counted as a parse failure, so reports can show
how much of a score is format compliance. An answer that names two different choices (e.g. two
hardness levels) is unreadable, never "right by luck".
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from tacreasoner.tasks.extract import MODES, Mode, extract_answer
from tacreasoner.tasks.schema import CONTACT_STATES, ORDINALS, PC_RELATIONS, QAItem
from tacreasoner.tasks.vocab import Attribute, get_vocabulary

__all__ = [
    "OSC_LETTERS",
    "TSA_LETTERS",
    "ItemScore",
    "check_gold",
    "parse_assignment",
    "parse_combined",
    "parse_contact_state",
    "parse_letter",
    "parse_level",
    "parse_ordinal",
    "parse_real_fake",
    "parse_relation",
    "parse_yes_no",
    "score_item",
    "score_predictions",
    "task_attributes",
]

OSC_LETTERS = "ABC"
TSA_LETTERS = "AB"


@dataclass(frozen=True)
class ItemScore:
    """Outcome of scoring one prediction; ``parsed`` is in the gold's own terms (JSON-serialisable)."""

    correct: bool
    parsed: object | None
    parse_failed: bool
    detail: dict = field(default_factory=dict)


# --------------------------------------------------------------------------------------------- text helpers


def _canon(text: str) -> str:
    """Strict comparison form: lower case, single spaces, no trailing period."""
    return " ".join(text.lower().split()).rstrip(".").rstrip()


def _loose(text: str) -> str:
    """Lenient search form: lower case, hyphens/underscores between words as spaces, single spaces."""
    return " ".join(re.sub(r"(?<=\w)[-_](?=\w)", " ", text.lower()).split())


def _phrase_regex(phrase: str) -> re.Pattern[str]:
    words = [re.escape(w) for w in _loose(phrase).split()]
    return re.compile(r"(?<![\w])" + r"\s+".join(words) + r"(?![\w])")


def _find_phrases(text: str, phrases: Mapping[str, Any]) -> list[tuple[int, Any]]:
    """Whole-phrase matches of ``phrases`` (phrase → value) in ``text`` as (position, value), in text order.

    Longer phrases claim their span first, so "moderately hard" is not also read as "hard" and
    "no elasticity" not as some shorter phrase inside it.
    """
    loose = _loose(text)
    claimed: list[tuple[int, int]] = []
    found: list[tuple[int, Any]] = []
    for phrase in sorted(phrases, key=lambda p: (-len(_loose(p)), p)):
        for m in _phrase_regex(phrase).finditer(loose):
            if any(m.start() < end and start < m.end() for start, end in claimed):
                continue
            claimed.append((m.start(), m.end()))
            found.append((m.start(), phrases[phrase]))
    return sorted(found, key=lambda f: f[0])


def _single(values: Sequence[Any]) -> Any | None:
    """The one distinct value in ``values``; ``None`` when there are none or several."""
    distinct = list(dict.fromkeys(values))
    return distinct[0] if len(distinct) == 1 else None


# ------------------------------------------------------------------------------------------------ parsers


def parse_level(text: str, attribute: Attribute, lenient: bool = False) -> int | None:
    """Level rank (0–2) named by ``text`` for one attribute.

    Strict: ``text`` is one of the attribute's level phrases. Lenient: exactly one of its level phrases
    occurs as a whole phrase (several mentions of the same phrase are fine; two levels are not).
    """
    canon = _canon(text)
    for rank, phrase in enumerate(attribute.levels):
        if canon == _canon(phrase):
            return rank
    if not lenient:
        return None
    return _single([v for _, v in _find_phrases(text, {p: r for r, p in enumerate(attribute.levels)})])


def parse_combined(text: str, attributes: Mapping[str, Attribute], lenient: bool = False) -> dict[str, int | None]:
    """Level rank per attribute (``None`` where unreadable) for a combined answer.

    Strict: ``"attr: phrase"`` pairs separated by ``;`` (any order, optional trailing ``;``/``.``),
    each attribute exactly once and nothing else. Lenient: strict, else per attribute exactly one of
    its level phrases anywhere in the text.
    """
    strict = _parse_combined_strict(text, attributes)
    if strict is not None or not lenient:
        return strict if strict is not None else dict.fromkeys(attributes)
    table = {phrase: (name, rank) for name, attr in attributes.items() for rank, phrase in enumerate(attr.levels)}
    found = _find_phrases(text, table)
    return {name: _single([rank for _, (n, rank) in found if n == name]) for name in attributes}


def _parse_combined_strict(text: str, attributes: Mapping[str, Attribute]) -> dict[str, int | None] | None:
    parts = [p.strip() for p in _canon(text).rstrip(";").split(";")]
    out: dict[str, int | None] = {}
    for part in parts:
        name, sep, value = part.partition(":")
        name = name.strip()
        if not sep or name not in attributes or name in out:
            return None
        rank = parse_level(value, attributes[name])
        if rank is None:
            return None
        out[name] = rank
    if set(out) != set(attributes):
        return None
    return {name: out[name] for name in attributes}


_ORDINAL_WORDS = {word: i for i, word in enumerate(ORDINALS)}
_STRICT_ORDINAL = re.compile(r"(?:the )?(first|second|third)(?: object)?")
_LENIENT_ORDINALS = (
    re.compile(r"\b(first|second|third)\b"),
    re.compile(r"\b([123])(?:st|nd|rd)\b"),
    re.compile(r"\b(?:object|video|clip|sample|item)\s*(?:no\.?\s*|number\s*|#\s*)?([123])\b"),
    re.compile(r"#\s*([123])\b"),
    re.compile(r"^\(?([123])\)?$"),
)
_THAN = re.compile(r"\bthan\b")


def _ordinal_index(token: str) -> int:
    return _ORDINAL_WORDS[token] if token in _ORDINAL_WORDS else int(token) - 1


def parse_ordinal(text: str, lenient: bool = False, *, asked: str | None = None, opposite: str | None = None,
                  n_objects: int = 2) -> int | None:
    """0-based object index named by ``text`` (SFD "which", SOI).

    Strict: "the first object", "first", "the first" or "first object" (likewise second/third).
    Lenient: strict, else every ordinal mention in the text — "first", "2nd", "object 2", "video 3",
    "#1", or a bare "2" as the whole answer — must name the same object. In a comparison the part
    after "than" is ignored ("the first object is harder than the second" → first), unless it uses the
    ``opposite`` of the ``asked`` comparative: asked "which is harder?", "the first is softer than the second"
    names the second of two objects (and none of three). Letters such as "(A)" are not read: SFD/SOI questions do
    not letter their objects, so a letter has no meaning.
    """
    canon = _canon(text)
    m = _STRICT_ORDINAL.fullmatch(canon)
    if m:
        return _ORDINAL_WORDS[m.group(1)]
    if not lenient:
        return None
    loose = _loose(text).strip(" .!")
    than = _THAN.search(loose)
    if than and opposite and _says(loose[: than.start()], opposite) and not \
            (asked and _says(loose[: than.start()], asked)):
        after = _ordinal_hits(loose[than.end():])
        return _single(after) if n_objects == 2 and after else None
    scopes = [loose[: than.start()], loose] if than else [loose]
    for scope in scopes:
        hits = _ordinal_hits(scope)
        if hits:
            return _single(hits)
    return None


def _ordinal_hits(text: str) -> list[int]:
    return [_ordinal_index(m.group(1)) for pattern in _LENIENT_ORDINALS for m in pattern.finditer(text.strip())]


def _says(text: str, word: str) -> bool:
    return _phrase_regex(word).search(text) is not None


_RELATION_WORDS = {
    "more": "more", "higher": "more", "greater": "more", "stronger": "more",
    "less": "less", "lower": "less", "fewer": "less", "weaker": "less",
    "similar": "similar", "the same": "similar", "same": "similar", "equal": "similar", "comparable": "similar",
}


def parse_relation(text: str, attribute: Attribute | None = None, lenient: bool = False) -> str | None:
    """``more`` / ``less`` / ``similar`` (PC: the first object against the second).

    Strict: exactly one of the three words. Lenient: every relation word in the text ("higher", "the same", …,
    and the attribute's own comparatives, "harder" / "softer") must say the same thing; "more or less" is read
    as nothing."""
    canon = _canon(text)
    if canon in PC_RELATIONS:
        return canon
    if not lenient:
        return None
    words = dict(_RELATION_WORDS)
    if attribute is not None:
        words |= {attribute.more: "more", attribute.less: "less"}
    loose = re.sub(r"\bmore or less\b", " ", _loose(text))
    return _single([v for _, v in _find_phrases(loose, words)])


_YES_NO = re.compile(r"\b(yes|no)\b")


def parse_yes_no(text: str, lenient: bool = False) -> bool | None:
    """True for yes, False for no. Strict: exactly "yes"/"no". Lenient: every yes/no word in the text must say the
    same ("No doubt: yes" says both, so nothing is read)."""
    canon = _canon(text)
    if canon in ("yes", "no"):
        return canon == "yes"
    if not lenient:
        return None
    return _single([m.group(1) == "yes" for m in _YES_NO.finditer(_loose(text))])


_OSC_PAIR = re.compile(r"([123])\s*-\s*([abc])")
_OSC_MARKER = re.compile(
    r"\b(?:video|clip|object|sample|item)\s*(?:no\.?\s*|number\s*|#\s*)?([123])\b"
    r"|(?:^|(?<=[\s,;(]))([123])\s*(?=\)|-|–|—|:|=|→|->|=>|↔)",
    re.IGNORECASE,
)
_OSC_SEP = re.compile(r"^[\s\-–—:=)→>↔]*(?:(?:is|matches|corresponds\s+to|goes\s+with|shows)\s+)?", re.IGNORECASE)
_OSC_LETTER = re.compile(r"^(?:(?i:option)\s*\(?([A-Ca-c])\)?|\(?([ABC])\)?)(?![A-Za-z])")
_OSC_SEQUENCE = re.compile(r"^\W*([ABC])\W+([ABC])\W+([ABC])\W*$")


def parse_assignment(text: str, options: Sequence[str] = (), lenient: bool = False) -> list[int] | None:
    """Option index (0=A, 1=B, 2=C) per video, in video order (OSC), or ``None``.

    Strict: three comma-separated ``N-L`` pairs, e.g. "1-B, 2-A, 3-C" (videos 1–3 each once, any
    order). Lenient: strict; else video markers followed by a letter or an option name ("video 1: B",
    "1 → B", "Video 2: the sponge"; conflicting letters for one video → unreadable); else the three
    option names in video order ("sponge, stone, tangerine"); else three bare letters ("B, A, C").
    """
    strict = _parse_assignment_strict(text)
    if strict is not None or not lenient:
        return strict
    names = {name: i for i, name in enumerate(options)}
    by_video: dict[int, int] = {}
    markers = list(_OSC_MARKER.finditer(text))
    for i, m in enumerate(markers):
        video = int(m.group(1) or m.group(2)) - 1
        segment = text[m.end(): markers[i + 1].start() if i + 1 < len(markers) else len(text)]
        segment = _OSC_SEP.sub("", segment, count=1)
        letter = _OSC_LETTER.match(segment)
        if letter:
            choice = OSC_LETTERS.index((letter.group(1) or letter.group(2)).upper())
        else:
            named = _find_phrases(segment, names) if names else []
            if not named:
                continue
            choice = named[0][1]
        if by_video.get(video, choice) != choice:
            return None
        by_video[video] = choice
    if len(by_video) == 3:
        return [by_video[v] for v in range(3)]
    if len(names) == 3:
        first_seen: dict[int, int] = {}
        for pos, choice in _find_phrases(text, names):
            first_seen.setdefault(choice, pos)
        if len(first_seen) == 3:
            return sorted(first_seen, key=first_seen.__getitem__)
    seq = _OSC_SEQUENCE.match(text.strip())
    if seq:
        return [OSC_LETTERS.index(g) for g in seq.groups()]
    return None


def _parse_assignment_strict(text: str) -> list[int] | None:
    parts = [p.strip() for p in _canon(text).split(",")]
    pairs = [_OSC_PAIR.fullmatch(p) for p in parts]
    if len(pairs) != 3 or not all(pairs):
        return None
    mapping = {int(m.group(1)) - 1: "abc".index(m.group(2)) for m in pairs if m}
    if set(mapping) != {0, 1, 2}:
        return None
    return [mapping[v] for v in range(3)]


_TSA_STRICT = re.compile(r"\(([ab])\)|([ab])")
_TSA_LENIENT = (
    re.compile(r"\b(?:option|choice|answer\s*(?:is|:))\s*\(?([ab])\)?(?![a-z])", re.IGNORECASE),
    re.compile(r"\(([AB])\)"),
    re.compile(r"^\s*([AB])\s*(?:[.):,\-]|$)"),
    re.compile(r"^\s*([AB])\s+(?:is|would|will|should|fits|suits|or|and)\b"),
    re.compile(r"(?<![\w'’])([AB])\s*[.!]?\s*$"),
)


def parse_letter(text: str, options: Sequence[str] = (), lenient: bool = False) -> str | None:
    """Option letter "A"/"B" (TSA).

    Strict: "A", "(A)" or "A." (any case). Lenient: strict, else every letter form — "option A",
    "answer is A", "(A)", a leading "A)"/"A:"/"A is …", a final "… A." — and every option text found
    in the answer must name the same option.
    When the options are "the first object"/"the second object" (the builders' wording), option
    texts are read as ordinals, as for SFD ("first", "object 2", "the first one is better than …").
    A bare capital "A" inside a sentence is not read (it is an article).
    """
    m = _TSA_STRICT.fullmatch(_canon(text))
    if m:
        return (m.group(1) or m.group(2)).upper()
    if not lenient:
        return None
    hits = [m.group(1).upper() for pattern in _TSA_LENIENT for m in pattern.finditer(text)]
    if [_canon(o) for o in options[:2]] == [f"the {o} object" for o in ORDINALS[:2]]:
        # Options are "the first/second object": read ordinals as for SFD ("the first one is better than …").
        index = parse_ordinal(text, lenient=True)
        hits += [TSA_LETTERS[index]] if index is not None and index < 2 else []
    else:
        hits += [TSA_LETTERS[i] for _, i in _find_phrases(text, {o: i for i, o in enumerate(options[:2])})]
    return _single(hits)


_REAL_WORDS = {"real": True, "genuine": True, "authentic": True, "fake": False, "artificial": False,
               "imitation": False, "replica": False}
_NEGATED = re.compile(r"(?:\bnot|n't|\bnever)\s+(?:a\s+|an\s+)?(?:really\s+)?(" + "|".join(_REAL_WORDS) + r")\b")
_REAL_WORD = re.compile(r"\b(" + "|".join(_REAL_WORDS) + r")\b")


def parse_real_fake(text: str, lenient: bool = False) -> bool | None:
    """True for real, False for fake (RFOR).

    Strict: exactly "real"/"fake". Lenient: strict, else "real"/"genuine"/"authentic" vs
    "fake"/"artificial"/"imitation"/"replica" anywhere, with negation flipping ("not real" → fake,
    "isn't fake" → real); both verdicts present → unreadable.
    """
    canon = _canon(text)
    if canon in ("real", "fake"):
        return canon == "real"
    if not lenient:
        return None
    loose = _loose(text).replace("’", "'")
    verdicts = [not _REAL_WORDS[m.group(1)] for m in _NEGATED.finditer(loose)]
    verdicts += [_REAL_WORDS[m.group(1)] for m in _REAL_WORD.finditer(_NEGATED.sub(" ", loose))]
    return _single(verdicts)


_STATE_FORMS: dict[str, tuple[str, ...]] = {
    "pressing": ("press", "presses", "pressed", "pressing"),
    "holding": ("hold", "holds", "held", "holding"),
    "sliding": ("slide", "slides", "slid", "sliding"),
    "rotating": ("rotate", "rotates", "rotated", "rotating", "rotation"),
    "releasing": ("release", "releases", "released", "releasing"),
}


def parse_contact_state(text: str, lenient: bool = False) -> str | None:
    """Contact state (OCSE), one of ``schema.CONTACT_STATES``.

    Strict: exactly the state phrase ("sliding"). Lenient: strict, else exactly one state named by any
    of its verb forms ("slides", "slid", "pressed", "rotation", …); two states → unreadable.
    """
    canon = _canon(text)
    if canon in CONTACT_STATES:
        return canon
    if not lenient:
        return None
    forms = {form: state for state, all_forms in _STATE_FORMS.items() if state in CONTACT_STATES
             for form in all_forms}
    return _single([state for _, state in _find_phrases(text, forms)])


# ------------------------------------------------------------------------------------------------ scoring


def _gold(item: QAItem, key: str, allowed: Sequence[Any] | None = None) -> Any:
    """Field ``key`` of ``item.gold``, with an error naming the item when it is missing or invalid."""
    if key not in item.gold:
        raise ValueError(f"item {item.id!r} ({item.task}): gold has no {key!r} field; gold = {item.gold!r}")
    value = item.gold[key]
    # bool is an int in Python: True must not pass as rank/index 1, nor 1 as True.
    bad_type = allowed is not None and any(isinstance(a, bool) for a in allowed) != isinstance(value, bool)
    if allowed is not None and (bad_type or value not in allowed):
        raise ValueError(f"item {item.id!r} ({item.task}): gold {key!r} must be one of {list(allowed)}, "
                         f"got {value!r}")
    return value


def task_attributes(item: QAItem) -> dict[str, Attribute]:
    """Attributes a TFA item asks about, in vocabulary order (one for ``TFA-<attr>``, several for combined)."""
    try:
        vocab = get_vocabulary(item.vocabulary)
    except ValueError as e:
        raise ValueError(f"item {item.id!r} ({item.task}): {e}") from None
    if item.task == "TFA-combined":
        levels = _gold(item, "levels")
        if not isinstance(levels, dict) or not levels:
            raise ValueError(f"item {item.id!r} (TFA-combined): gold 'levels' must be a non-empty dict")
        unknown = [a for a in levels if a not in vocab]
        if unknown:
            raise ValueError(f"item {item.id!r} (TFA-combined): gold 'levels' names attributes {unknown} not in "
                             f"vocabulary {item.vocabulary!r} ({', '.join(vocab)})")
        return {name: attr for name, attr in vocab.items() if name in levels}
    name = item.task.removeprefix("TFA-")
    gold_name = item.gold.get("attribute", name)
    if gold_name != name:
        raise ValueError(f"item {item.id!r} ({item.task}): gold 'attribute' is {gold_name!r}, task says {name!r}")
    if name not in vocab:
        raise ValueError(f"item {item.id!r} ({item.task}): attribute {name!r} is not in vocabulary "
                         f"{item.vocabulary!r} ({', '.join(vocab)})")
    return {name: vocab[name]}


def _result(parsed: Any, gold: Any, extra: dict | None = None) -> ItemScore:
    detail = {"gold": gold, **(extra or {})}
    if parsed is None:
        return ItemScore(False, None, True, {**detail, "reason": "unreadable answer"})
    return ItemScore(parsed == gold, parsed, False, detail)


def _score_tfa(item: QAItem, answer: str, lenient: bool) -> ItemScore:
    ((name, attr),) = task_attributes(item).items()
    gold = _gold(item, "level", (0, 1, 2))
    parsed = parse_level(answer, attr, lenient)
    return _result(parsed, gold, {"attribute": name,
                                  "parsed_phrase": None if parsed is None else attr.levels[parsed]})


def _score_combined(item: QAItem, answer: str, lenient: bool) -> ItemScore:
    attributes = task_attributes(item)
    gold = {name: item.gold["levels"][name] for name in attributes}
    bad = {k: v for k, v in gold.items() if v not in (0, 1, 2)}
    if bad:
        raise ValueError(f"item {item.id!r} (TFA-combined): gold levels must be 0, 1 or 2, got {bad}")
    parsed = parse_combined(answer, attributes, lenient)
    per_attribute = {name: parsed[name] == gold[name] for name in attributes}
    unread = [name for name, v in parsed.items() if v is None]
    detail: dict[str, Any] = {"gold": gold, "per_attribute": per_attribute}
    if unread:
        detail["unreadable_attributes"] = unread
    if len(unread) == len(parsed):
        return ItemScore(False, None, True, {**detail, "reason": "unreadable answer"})
    return ItemScore(all(per_attribute.values()), parsed, bool(unread), detail)


def _score_ordinal(item: QAItem, answer: str, lenient: bool) -> ItemScore:
    n = len(item.videos)
    gold = _gold(item, "index", range(n))
    asked = opposite = None
    attribute = get_vocabulary(item.vocabulary).get(str(item.gold.get("attribute"))) if lenient else None
    if attribute is not None and item.gold.get("direction") in ("more", "most", "less", "least"):
        asked, opposite = ((attribute.more, attribute.less) if item.gold["direction"] in ("more", "most")
                           else (attribute.less, attribute.more))
    parsed = parse_ordinal(answer, lenient, asked=asked, opposite=opposite, n_objects=n)
    extra = {"n_objects": n}
    if parsed is not None and parsed >= n:
        extra["invalid"] = f"names object {parsed + 1} of {n}"
    return _result(parsed, gold, extra)


def _score_sfd(item: QAItem, answer: str, lenient: bool) -> ItemScore:
    kind = _gold(item, "kind", ("which", "yesno"))
    if kind == "which":
        return _score_ordinal(item, answer, lenient)
    gold = _gold(item, "value", (True, False))
    return _result(parse_yes_no(answer, lenient), gold, {"kind": "yesno"})


def _score_pc(item: QAItem, answer: str, lenient: bool) -> ItemScore:
    gold = _gold(item, "relation", PC_RELATIONS)
    name = _gold(item, "attribute")
    vocab = get_vocabulary(item.vocabulary)
    if name not in vocab:
        raise ValueError(f"item {item.id!r} (PC): attribute {name!r} is not in vocabulary {item.vocabulary!r}")
    return _result(parse_relation(answer, vocab[name], lenient), gold, {"attribute": name})


def _score_osc(item: QAItem, answer: str, lenient: bool) -> ItemScore:
    gold = list(_gold(item, "assignment"))
    if len(gold) != 3 or any(k not in (0, 1, 2) for k in gold):
        raise ValueError(f"item {item.id!r} (OSC): gold 'assignment' must be three option indices 0–2, got {gold}")
    parsed = parse_assignment(answer, item.options, lenient)
    per_video = None if parsed is None else [p == g for p, g in zip(parsed, gold, strict=True)]
    return _result(parsed, gold, {"per_video": per_video})


def _score_tsa(item: QAItem, answer: str, lenient: bool) -> ItemScore:
    gold = _gold(item, "letter", tuple(TSA_LETTERS))
    return _result(parse_letter(answer, item.options, lenient), gold)


def _score_rfor(item: QAItem, answer: str, lenient: bool) -> ItemScore:
    gold = _gold(item, "real", (True, False))
    return _result(parse_real_fake(answer, lenient), gold)


def _score_ocse(item: QAItem, answer: str, lenient: bool) -> ItemScore:
    gold = _gold(item, "state", CONTACT_STATES)
    parsed = parse_contact_state(answer, lenient)
    extra = {}
    if parsed is not None and item.options and parsed not in item.options:
        extra["invalid"] = f"{parsed!r} is not among the options {item.options}"
    return _result(parsed, gold, extra)


_SCORERS: dict[str, Callable[[QAItem, str, bool], ItemScore]] = {
    "TFA-combined": _score_combined,
    "SFD": _score_sfd,
    "PC": _score_pc,
    "SOI": _score_ordinal,
    "OSC": _score_osc,
    "TSA": _score_tsa,
    "RFOR": _score_rfor,
    "OCSE": _score_ocse,
}


def _scorer(task: str) -> Callable[[QAItem, str, bool], ItemScore]:
    if task in _SCORERS:
        return _SCORERS[task]
    if task.startswith("TFA-"):
        return _score_tfa
    raise ValueError(f"no scorer for task {task!r}")


def score_item(item: QAItem, prediction: str, mode: Mode | str = "strict") -> ItemScore:
    """Score one model output (full text, tags included) against ``item``'s gold."""
    if mode not in MODES:
        raise ValueError(f"scoring mode must be one of {MODES}, got {mode!r}")
    answer = extract_answer(prediction, mode)
    if answer is None:
        return ItemScore(False, None, True, {"reason": f"no answer found ({mode} extraction)"})
    score = _scorer(item.task)(item, answer, mode == "lenient")
    return ItemScore(score.correct, score.parsed, score.parse_failed, {"extracted": answer, **score.detail})


def check_gold(item: QAItem) -> None:
    """Raise ValueError when the item's gold answer text does not strictly score as right.

    Builders write ``answer`` (text) and ``gold`` (values) separately; this catches the two drifting
    apart before a benchmark is scored against them.
    """
    score = score_item(item, f"<answer>{item.answer}</answer>", "strict")
    if not score.correct:
        raise ValueError(f"item {item.id!r} ({item.task}): gold answer text {item.answer!r} does not match "
                         f"gold {item.gold!r} under the strict scorer (read as {score.parsed!r})")


def score_predictions(items: Sequence[QAItem], predictions: Mapping[str, str],
                      mode: Mode | str = "strict") -> list[dict]:
    """Per-item score records, in item order.

    Each record has ``id``, ``task``, ``correct``, ``parse_failed``, ``parsed``, ``prediction``,
    ``missing`` and ``detail``. An item with no prediction is wrong and a parse failure, with
    ``missing: true`` and ``prediction: null``, so it shows up in the records rather than vanishing.
    """
    if mode not in MODES:
        raise ValueError(f"scoring mode must be one of {MODES}, got {mode!r}")
    seen: set[str] = set()
    records: list[dict] = []
    for item in items:
        if item.id in seen:
            raise ValueError(f"duplicate item id {item.id!r}")
        seen.add(item.id)
        prediction = predictions.get(item.id)
        if prediction is None:
            score = ItemScore(False, None, True, {"reason": "no prediction for this item"})
        else:
            score = score_item(item, prediction, mode)
        records.append({"id": item.id, "task": item.task, "correct": score.correct,
                        "parse_failed": score.parse_failed, "parsed": score.parsed, "prediction": prediction,
                        "missing": prediction is None, "mode": mode, "detail": score.detail})
    return records
