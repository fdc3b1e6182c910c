"""Gold answer text from machine-readable gold, exactly as the table in ``schema.py`` states.

One function owns the mapping so the builders, the file readers (which check that a stored answer
matches its gold) and the VTV import all agree with the scorers. This is not a scorer: it only
renders the *gold* text.
"""

from __future__ import annotations

from collections.abc import Mapping

from tacreasoner.tasks.schema import CONTACT_STATES, ORDINALS, PC_RELATIONS, TASKS
from tacreasoner.tasks.vocab import get_vocabulary

LETTERS = "ABC"
OPTION_MARKER = r"\(([A-Z])\)"
"""How a question marks each option it lists ("(A) kitchen sponge (B) fake apple"): a regular expression whose
group is the option's letter. The model reads options only through this, handed in as ``encoder.option_marker``."""
COMBINED_SEP = "; "


def ordinal_answer(index: int) -> str:
    """``the first object`` / ``the second object`` / ``the third object``."""
    return f"the {ORDINALS[index]} object"


def combined_answer(levels: Mapping[str, int], vocabulary: str) -> str:
    """``hardness: …; protrusion: …; …`` in vocabulary order."""
    vocab = get_vocabulary(vocabulary)
    return COMBINED_SEP.join(f"{a}: {vocab[a].phrase(levels[a])}" for a in vocab)


def osc_answer(assignment: list[int]) -> str:
    """``1-B, 2-A, 3-C``: video number, then the option letter of its object."""
    return ", ".join(f"{v + 1}-{LETTERS[k]}" for v, k in enumerate(assignment))


def _need(gold: Mapping, key: str, allowed: tuple | type, task: str) -> object:
    if key not in gold:
        raise ValueError(f"{task}: gold is missing {key!r}")
    value = gold[key]
    # True == 1, so a bool must never pass as a rank or an index.
    is_choice = isinstance(allowed, tuple)
    ok = (not isinstance(value, bool) and value in allowed) if is_choice else isinstance(value, allowed)
    if not ok:
        raise ValueError(f"{task}: gold {key!r} has invalid value {value!r}")
    return value


def _tfa(task: str, gold: Mapping, vocabulary: str) -> str:
    vocab = get_vocabulary(vocabulary)
    if task == "TFA-combined":
        levels = gold.get("levels")
        if not isinstance(levels, dict) or list(levels) != list(vocab):
            raise ValueError(f"{task}: gold 'levels' must map {list(vocab)} (in that order) to ranks, got {levels!r}")
        for a in levels:
            _need(levels, a, (0, 1, 2), task)
        return combined_answer(levels, vocabulary)
    attribute = task.removeprefix("TFA-")
    if attribute not in vocab:
        raise ValueError(f"{task}: attribute {attribute!r} is not in the {vocabulary} vocabulary")
    if gold.get("attribute") != attribute:
        raise ValueError(f"{task}: gold 'attribute' must be {attribute!r}, got {gold.get('attribute')!r}")
    return vocab[attribute].phrase(_need(gold, "level", (0, 1, 2), task))


def _comparison(task: str, gold: Mapping, vocabulary: str) -> str:
    attribute = _need(gold, "attribute", str, task)
    if attribute not in get_vocabulary(vocabulary):
        raise ValueError(f"{task}: attribute {attribute!r} is not in the {vocabulary} vocabulary")
    if task == "SOI":
        _need(gold, "direction", ("most", "least"), task)
        return ordinal_answer(_need(gold, "index", (0, 1, 2), task))
    _need(gold, "direction", ("more", "less"), task)
    kind = _need(gold, "kind", ("which", "yesno"), task)
    if kind == "which":
        return ordinal_answer(_need(gold, "index", (0, 1), task))
    return "yes" if _need(gold, "value", bool, task) else "no"


def _pc(task: str, gold: Mapping, vocabulary: str) -> str:
    attribute = _need(gold, "attribute", str, task)
    if attribute not in get_vocabulary(vocabulary):
        raise ValueError(f"{task}: attribute {attribute!r} is not in the {vocabulary} vocabulary")
    return str(_need(gold, "relation", PC_RELATIONS, task))


def _osc(task: str, gold: Mapping) -> str:
    assignment = gold.get("assignment")
    if not isinstance(assignment, list) or sorted(assignment) != [0, 1, 2]:
        raise ValueError(f"{task}: gold 'assignment' must be a permutation of [0, 1, 2], got {assignment!r}")
    return osc_answer(assignment)


def _tsa(task: str, gold: Mapping) -> str:
    _need(gold, "scenario", str, task)
    needs = _need(gold, "needs", dict, task)
    if not needs or any(v not in ("high", "low") for v in needs.values()):
        raise ValueError(f"{task}: gold 'needs' must map attributes to 'high'/'low', got {needs!r}")
    return _need(gold, "letter", ("A", "B"), task)


def render_answer(task: str, gold: Mapping, vocabulary: str = "vtv150k") -> str:
    """The gold answer text for ``gold``; ValueError when the gold breaks the schema's conventions."""
    if not isinstance(gold, Mapping):
        raise ValueError(f"{task}: gold must be a mapping, got {type(gold).__name__}")
    if task.startswith("TFA-"):
        return _tfa(task, gold, vocabulary)
    if task in ("SFD", "SOI"):
        return _comparison(task, gold, vocabulary)
    if task == "PC":
        return _pc(task, gold, vocabulary)
    if task == "OSC":
        return _osc(task, gold)
    if task == "TSA":
        return _tsa(task, gold)
    if task == "RFOR":
        _need(gold, "fruit", str, task)
        return "real" if _need(gold, "real", bool, task) else "fake"
    if task == "OCSE":
        return _need(gold, "state", CONTACT_STATES, task)
    raise ValueError(f"unknown task {task!r}; known: {', '.join(TASKS)}")
