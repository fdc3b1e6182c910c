"""Other wordings of the benchmark's questions: more for training, held-out ones for a paraphrase evaluation.

A model trained only on the benchmark's templates knows those wordings, not questions in general (asked "Is this
object soft or hard?" in words it never saw, a PhysiCLeAR model answered "real"). ``paraphrases/train.yaml`` holds
wordings that training mixes in (``data.paraphrases``); ``paraphrases/heldout.yaml`` holds wordings that no training
ever sees, asked by ``tacreasoner paraphrase-bench`` / ``evaluate-physiclear --wording heldout`` to report accuracy
on unseen wordings beside the templates'. :func:`check_disjoint` (and a test) keeps the held-out wordings apart from
every benchmark template and training wording.

An item is re-worded by rendering another wording of its template's kind with the slots the builder stored
(``meta["slots"]``): the videos, gold and answer stay, except that a wording marked ``answer: letter`` lists the
options with letters and its answer becomes the letter ("the second object" → "B").
"""

from __future__ import annotations

import dataclasses
import hashlib
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from functools import cache, lru_cache
from pathlib import Path

from tacreasoner.tasks.schema import ORDINALS, QAItem
from tacreasoner.tasks.templating import KINDS, Template, TemplateError, _check_slots, load_templates
from tacreasoner.yamlfile import line_of, read_yaml

__all__ = ["HELDOUT_WORDINGS", "PARAPHRASE_DIR", "WORDINGS", "Paraphrase", "check_disjoint", "heldout_wording_of",
           "load_paraphrases", "normalise", "reword", "reword_items", "trained_wording_of"]

PARAPHRASE_DIR = Path(__file__).parent / "paraphrases"
WORDINGS = ("train", "heldout", "heldout2", "heldout3", "heldout4", "heldout5", "heldout6", "heldout7", "heldout8",
            "heldout9", "heldout10", "heldout11", "heldout12", "heldout13", "heldout14",
            "heldout15", "heldout16", "heldout17", "heldout18")
HELDOUT_WORDINGS = ("heldout", "heldout2", "heldout3", "heldout4", "heldout5", "heldout6", "heldout7", "heldout8",
                    "heldout9", "heldout10", "heldout11", "heldout12", "heldout13", "heldout14",
                    "heldout15", "heldout16", "heldout17", "heldout18")
"""Held-out sets: never trained on. ``heldout2`` (2026-11-29) was written after the stepwise modes' property lexicon
(``tasks.conclude.asked_properties``) and never run through it before it was measured; ``heldout3`` (later that day)
was written by someone who had not read the lexicon, and read only after its second version was committed: the
``auto`` answering mode is decided on it (experiments/2026-11-29_person_words). ``heldout4`` (the next day's session)
was written the same way and committed unread, before the re-asking of a person's question and the lexicon's third
version were; they are measured on it (experiments/2026-11-29_reask). ``heldout5`` (the same session, same way)
was committed unread after ``heldout4`` was read, before the wording re-asked in was chosen on val
(benchmarks/reask_wordings.py); the final figure is measured on it. ``heldout6`` (the next session, same way) was
committed unread before the lexicon's fourth version (two properties offered as alternatives) was written; that
version is measured on it (experiments/2026-11-29_lexicon_v4); ``heldout7`` (the same way, six wordings per
property) was committed unread after ``heldout6`` was read, before the lexicon's fifth version was measured on it;
``heldout8`` (the same way) after ``heldout7`` was read and the sixth version committed, to measure that version;
``heldout9`` (the next session, the same way) after ``heldout8`` was read, to measure the sixth version again before
any change (experiments/2026-11-29_lexicon_v6_again); ``heldout10`` (the same way, trade jargon and more regional
Englishes asked for) after ``heldout9`` was read and the seventh version committed, to measure that version;
``heldout11`` (the same session, ``heldout9``'s prompt word for word: the tenth's asked for trade jargon, which
invites the idiom the seventh version added) to measure the seventh version again, unchanged; ``heldout12`` (the
same prompt) after the eighth version was committed, to measure it; ``heldout13`` and ``heldout14`` (the next
session, the same prompt, both committed unread together) before the hybrid reader (the word list, then a sentence
embedding where it reads no property) was written: it is measured on the thirteenth, lexicon v10 with it on the
fourteenth; ``heldout15`` (the same prompt, after the fourteenth was read) measures the eleventh version, and
``heldout16`` (after the fifteenth was read) the twelfth (experiments/2026-11-29_hybrid_reader); ``heldout17`` (the
next session, the same prompt, after the sixteenth was read) the twelfth again, unchanged; ``heldout18``
(the session after, the same prompt, committed unread after the seventeenth was read, before the thirteenth version
(an analogy between things, "does it feel like a cobblestone lane or a paved road?", read by the embedding) was
written) to measure that version (experiments/2026-11-30_analogy_reader)."""
FIELDS = frozenset({"id", "text", "attribute", "answer"})
LETTER_TASKS = ("SFD", "SOI")
"""Tasks whose ``the first/second/third object`` answers a lettered wording turns into ``A``/``B``/``C``."""


@dataclass(frozen=True)
class Paraphrase:
    template: Template
    attribute: str | None = None
    """Only for items about this attribute (the text then needs no ``{attribute}`` slot)."""
    letter: bool = False
    """The options are listed with letters; the answer is the letter."""


def normalise(text: str) -> str:
    """A wording with its slots and placeholders blanked, lower case, single spaces: what "the same wording" means."""
    text = re.sub(r"\{[a-z_]+\}", "{}", text.lower()).replace("<tactile>", "<t>")
    return " ".join(re.sub(r"[^a-z0-9{}<>]+", " ", text).split())


def _parse(path: Path) -> dict[str, tuple[Paraphrase, ...]]:
    data, lines = read_yaml(path)
    if not isinstance(data, dict):
        raise TemplateError(f"{path}: top level must map template kinds to lists of wordings")
    out: dict[str, list[Paraphrase]] = {}
    for kind_name, entries in data.items():
        if kind_name not in KINDS:
            raise TemplateError(f"{path}:{line_of(lines, ())}: unknown template kind {kind_name!r}")
        if not isinstance(entries, list):
            raise TemplateError(f"{path}: {kind_name!r} must be a list of wordings")
        for i, entry in enumerate(entries):
            where = f"{path}:{line_of(lines, (kind_name, i))}"
            if not isinstance(entry, dict) or set(entry) - FIELDS or not {"id", "text"} <= set(entry):
                raise TemplateError(f"{where}: a wording is a mapping with id and text (optional: attribute, answer)")
            attribute = entry.get("attribute")
            letter = entry.get("answer") == "letter"
            if entry.get("answer") not in (None, "letter"):
                raise TemplateError(f"{where}: answer must be 'letter' when given, got {entry.get('answer')!r}")
            template = Template(str(entry["id"]), kind_name, str(entry["text"]).strip(), str(path),
                                line_of(lines, (kind_name, i)))
            kind = KINDS[kind_name]
            if attribute is not None:  # the wording names its property itself
                kind = dataclasses.replace(kind, required=kind.required - {"attribute"})
            _check_slots(template.text, kind, template.where)
            out.setdefault(kind_name, []).append(Paraphrase(template, attribute, letter))
    return {k: tuple(v) for k, v in out.items()}


@cache  # a few sets, each parsed once (8 was fewer than the sets)
def load_paraphrases(wording: str, directory: str | None = None) -> Mapping[str, tuple[Paraphrase, ...]]:
    """The ``train`` or a held-out set's wordings by template kind."""
    if wording not in WORDINGS:
        raise ValueError(f"unknown wording set {wording!r}; choose from {', '.join(WORDINGS)}")
    return _parse(Path(directory or PARAPHRASE_DIR) / f"{wording}.yaml")


def heldout_wording_of(question: str) -> str | None:
    """The id of the held-out wording (of any set) ``question`` is asked in (slots filled with anything), else
    None: how a test proves a training question never uses one."""
    return _wording_of(question, _heldout_patterns())


def trained_wording_of(question: str) -> str | None:
    """The id of the benchmark template or training wording ``question`` is asked in (slots filled with anything),
    else None: a question the model was trained to read in these words."""
    return _wording_of(question, _trained_patterns())


@lru_cache(maxsize=1)
def _heldout_patterns() -> tuple[tuple[str, re.Pattern[str]], ...]:
    """Every held-out set's wordings, compiled once per process: asked per question over ~1000 wordings, parsing
    and compiling them on each call cost 1.5 s a question (the check of every training question took 23 min)."""
    return _compiled(p.template for wording in HELDOUT_WORDINGS for kind in load_paraphrases(wording).values()
                     for p in kind)


@lru_cache(maxsize=1)
def _trained_patterns() -> tuple[tuple[str, re.Pattern[str]], ...]:
    return _compiled([t for kind in load_templates().values() for t in kind] +
                     [p.template for kind in load_paraphrases("train").values() for p in kind])


def _compiled(templates: Iterable[Template]) -> tuple[tuple[str, re.Pattern[str]], ...]:
    return tuple((t.id, _pattern(t.text)) for t in templates)


def _wording_of(question: str, patterns: Sequence[tuple[str, re.Pattern[str]]]) -> str | None:
    """The id of the first of ``patterns`` (template id, its text with slots as patterns) that is ``question``."""
    question = question.strip()
    return next((wording for wording, pattern in patterns if pattern.fullmatch(question)), None)


_WORDS = r"[a-z]+(?: [a-z]+)?"
_SLOT = {"attribute": r"[a-z]+", "comparative": _WORDS, "superlative": _WORDS, "fruit": r"[a-z ]+?",
         "attributes": r"[a-z, ]+?"}
"""What a slot is filled with (a property name, a word or two, a list of names); any other slot: text on one line.
A bare ``{attribute}?`` wording then matches a property name, not any question."""


@lru_cache(maxsize=256)
def _pattern(text: str) -> re.Pattern[str]:
    parts = re.split(r"(\{[a-z_]+\})", text)
    return re.compile("".join(_SLOT.get(part[1:-1], r"[^\n]+?") if re.fullmatch(r"\{[a-z_]+\}", part)
                              else re.escape(part) for part in parts), re.DOTALL)


def check_disjoint(directory: str | None = None) -> None:
    """Held-out wordings must differ from every benchmark template and training wording (and ids be unique)."""
    seen: dict[str, str] = {}
    for kind in load_templates().values():
        for t in kind:
            seen[normalise(t.text)] = t.where
    for p in (p for kind in load_paraphrases("train", directory).values() for p in kind):
        seen.setdefault(normalise(p.template.text), p.template.where)
    ids = {t.id for kind in load_templates().values() for t in kind} | \
          {p.template.id for kind in load_paraphrases("train", directory).values() for p in kind}
    for wording in HELDOUT_WORDINGS:  # each set apart from training, and the second apart from the first
        for p in (p for kind in load_paraphrases(wording, directory).values() for p in kind):
            if normalise(p.template.text) in seen:
                raise TemplateError(f"{p.template.where}: the held-out wording is also used for training or in "
                                    f"another held-out set ({seen[normalise(p.template.text)]})")
            if p.template.id in ids:
                raise TemplateError(f"{p.template.where}: id {p.template.id!r} is also another wording's")
        for p in (p for kind in load_paraphrases(wording, directory).values() for p in kind):
            seen[normalise(p.template.text)] = p.template.where
            ids.add(p.template.id)


@lru_cache(maxsize=1)
def _kind_of_template() -> dict[str, str]:
    return {t.id: kind for kind, ts in load_templates().items() for t in ts}


def _choices(item: QAItem, wording: str, letters: bool) -> tuple[Paraphrase, ...]:
    kind = _kind_of_template().get(str(item.meta.get("template", "")))
    if kind is None:
        return ()
    attribute = item.gold.get("attribute") if isinstance(item.gold, dict) else None
    options = load_paraphrases(wording).get(kind, ())
    return tuple(p for p in options if (p.attribute is None or p.attribute == attribute) and (letters or not p.letter))


def reword(item: QAItem, wording: str, salt: str = "", *, letters: bool = True) -> QAItem | None:
    """``item`` asked in one of the ``wording`` set's wordings for its kind (chosen by a hash of its id and
    ``salt``); None when the set has none for it. The item needs the slots its builder stored. ``letters=False``
    leaves out the wordings whose answer is a letter (for answers that cannot change, e.g. written reasoning)."""
    choices = _choices(item, wording, letters)
    if not choices:
        return None
    slots = item.meta.get("slots")
    if not isinstance(slots, dict):
        raise ValueError(f"item {item.id!r}: no stored slots (meta.slots): rebuild the benchmark with this version "
                         "to re-word its questions")
    digest = hashlib.sha256(f"{item.id}|{wording}|{salt}".encode()).digest()
    chosen = choices[int.from_bytes(digest[:8], "big") % len(choices)]
    answer = item.answer
    if chosen.letter:
        if item.task not in LETTER_TASKS or item.gold.get("kind", "which") != "which":
            return None
        answer = "ABC"[int(item.gold["index"])]
        if answer != "ABC"[ORDINALS.index(item.answer.split()[1])]:
            raise ValueError(f"item {item.id!r}: answer {item.answer!r} does not match its gold index")
    question = chosen.template.render(**{k: v for k, v in slots.items() if k in _slot_names(chosen)})
    return dataclasses.replace(item, question=question, answer=answer,
                               meta={**item.meta, "template": chosen.template.id, "wording": wording,
                                     "answer_form": "letter" if chosen.letter else "text"})


def _slot_names(p: Paraphrase) -> set[str]:
    from tacreasoner.tasks.templating import slot_names

    return slot_names(p.template.text)


def reword_items(items: Sequence[QAItem], wording: str, salt: str = "", *, letters: bool = True) -> list[QAItem]:
    """Every item the wording set can re-word, re-worded (ids get a ``-<wording>`` suffix); the others left out."""
    out = []
    for item in items:
        new = reword(item, wording, salt, letters=letters)
        if new is not None:
            out.append(dataclasses.replace(new, id=f"{item.id}-{wording}"))
    return out
