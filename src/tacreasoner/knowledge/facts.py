"""The fact base of the commonsense corpus: objects with property levels, and the corpus wording.

Objects are the simulator's 15 catalogue objects (ranks from ``derive_labels`` of their *material
parameters*: what the object is typically like, never a clip's label) plus the everyday objects of
``tasks/everyday_objects.yaml`` (read by ``tasks.everyday_objects``, which the evaluation uses too). Every
object has a rank for each attribute of both vocabularies; a level is stated with the vocabulary's own
phrase (``tasks.vocab``), so the corpus speaks the benchmark's answer language.
"""

from __future__ import annotations

import re
import string
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from tacreasoner.tasks.everyday_objects import EVERYDAY_OBJECTS_FILE, everyday_objects
from tacreasoner.tasks.vocab import PHYSICLEAR, VTV150K
from tacreasoner.yamlfile import line_of, read_yaml

__all__ = ["ATTRIBUTES", "VOCABULARIES_OF", "KnowledgeObject", "Wording", "knowledge_objects", "level_phrase",
           "level_state", "load_wording"]

HERE = Path(__file__).resolve().parent
OBJECTS_FILE = EVERYDAY_OBJECTS_FILE
WORDING_FILE = HERE / "wording.yaml"

ATTRIBUTES = ("hardness", "protrusion", "elasticity", "friction", "roughness", "bumpiness")
VOCABULARIES_OF: dict[str, tuple[str, ...]] = {
    "hardness": ("vtv150k", "physiclear"), "protrusion": ("vtv150k",), "elasticity": ("vtv150k",),
    "friction": ("vtv150k",), "roughness": ("physiclear",), "bumpiness": ("physiclear",),
}
"""Which vocabularies phrase each attribute (hardness is in both, with different phrases)."""
_HAS_WORDS = ("no", "moderate", "strong", "slight", "small", "big")
_ARTICLE = re.compile(r"^(a|an|the)\s+", re.IGNORECASE)


def level_phrase(attribute: str, rank: int, vocabulary: str) -> str:
    """The vocabulary's answer phrase for a rank, e.g. ``("hardness", 2, "vtv150k")`` → ``extremely hard``."""
    vocab = {"vtv150k": VTV150K, "physiclear": PHYSICLEAR}[vocabulary]
    if attribute not in vocab:
        raise ValueError(f"attribute {attribute!r} is not in the {vocabulary} vocabulary")
    return vocab[attribute].phrase(rank)


def level_state(phrase: str) -> str:
    """A level phrase as a predicate: ``is extremely hard``, ``has no protrusion``."""
    return f"{'has' if phrase.split()[0] in _HAS_WORDS else 'is'} {phrase}"


def capital(text: str) -> str:
    return text[:1].upper() + text[1:]


@dataclass(frozen=True)
class KnowledgeObject:
    name: str
    """With its article, as it reads in a sentence: ``a real apple``."""
    material: str
    ranks: Mapping[str, int]
    """attribute → 0/1/2 for every attribute in ``ATTRIBUTES``."""
    source: str
    """``catalogue`` (a simulator object) or ``world`` (``tasks/everyday_objects.yaml``)."""
    sim_name: str | None = None

    @property
    def bare(self) -> str:
        """Without the article, as the benchmark's OSC options name objects: ``real apple``."""
        return _ARTICLE.sub("", self.name)

    @property
    def the(self) -> str:
        return f"the {self.bare}"

    def phrase(self, attribute: str, vocabulary: str) -> str:
        return level_phrase(attribute, self.ranks[attribute], vocabulary)


def _catalogue_objects() -> list[KnowledgeObject]:
    from tacreasoner.sim.materials import catalogue, derive_labels

    out = []
    for m in catalogue():
        labels = derive_labels(m)
        ranks = {**labels["vtv150k"], **labels["physiclear"]}
        out.append(KnowledgeObject(m.display_name, m.material, {a: int(ranks[a]) for a in ATTRIBUTES}, "catalogue",
                                   m.name))
    return out


def _world_objects(path: Path) -> list[KnowledgeObject]:
    return [KnowledgeObject(o.name, o.material, {**o.ranks, "bumpiness": o.ranks["protrusion"]}, "world")
            for o in everyday_objects(path)]


def knowledge_objects(path: str | Path | None = None) -> tuple[KnowledgeObject, ...]:
    """The catalogue objects, then the everyday ones (``tasks/everyday_objects.yaml`` or ``path``); names are
    checked unique."""
    objects = [*_catalogue_objects(), *_world_objects(OBJECTS_FILE if path is None else Path(path))]
    bares = [o.bare for o in objects]
    for i, a in enumerate(bares):
        for j, b in enumerate(bares):
            if i != j and re.search(rf"\b{re.escape(a)}\b", b):
                raise ValueError(f"object name {a!r} occurs inside {b!r}: names must not contain one another "
                                 f"(the corpus checks held-out pairs by name)")
    return tuple(objects)


# ------------------------------------------------------------------------------------------ wording

_OBJ1 = {"x", "X"}
_OBJ2 = _OBJ1 | {"y", "Y"}
_SCN = {"s", "S"}
# kind → (allowed slots, groups of which each needs at least one slot present)
_DOC_SLOTS: dict[str, tuple[set[str], list[set[str]]]] = {
    "fact": (_OBJ1 | {"state", "phrase", "attribute"}, [_OBJ1, {"state", "phrase"}]),
    "describe": (_OBJ1 | {"material", "states"}, [_OBJ1, {"states"}]),
    "scale": ({"attribute", "Attribute", "low", "mid", "high"}, [{"low"}, {"mid"}, {"high"}]),
    "same_level": ({"attribute", "a", "b"}, [{"a"}, {"b"}]),
    "comparative": (_OBJ2 | {"cmp"}, [_OBJ1, {"y", "Y"}, {"cmp"}]),
    "need": (_SCN | {"needs", "levels"}, [_SCN, {"needs", "levels"}]),
    "suits": (_SCN | _OBJ2, [_SCN, _OBJ1, {"y", "Y"}]),
}
_QUESTION_SLOTS: dict[str, tuple[set[str], list[set[str]]]] = {
    "fact": (_OBJ1 | {"attribute"}, [_OBJ1, {"attribute"}]),
    "describe": (_OBJ1, [_OBJ1]),
    "compare_yesno": (_OBJ2 | {"cmp"}, [_OBJ1, {"y", "Y"}, {"cmp"}]),
    "compare_which": (_OBJ2 | {"cmp"}, [_OBJ1, {"y", "Y"}, {"cmp"}]),
    "scenario": (_SCN | _OBJ2, [_SCN, _OBJ1, {"y", "Y"}]),
    "need": (_SCN, [_SCN]),
}
_NUMBERS = {"lx", "ly", "rel"}
_CONCLUDE = ({"Cmp", "cmp", "way", "the_x", "the_y"} | _NUMBERS, [{"the_x"}, {"the_y"}, {"cmp", "Cmp"}, {"way"}])
_REASONING_SLOTS: dict[str, tuple[set[str], list[set[str]]]] = {
    "fact": (_OBJ1 | {"state"}, [_OBJ1, {"state"}]),
    "need": (_SCN | {"needs", "levels"}, [_SCN, {"needs"}, {"levels"}]),
    "level_fact": (_OBJ1 | {"state", "level"}, [_OBJ1, {"state"}, {"level"}]),
    "compare_true": _CONCLUDE,
    "compare_false": _CONCLUDE,
    "score_state": ({"state", "level", "score", "need", "attribute"}, [{"state"}, {"score"}]),
    "score_fact": (_OBJ1 | {"states", "total"}, [_OBJ1, {"states"}, {"total"}]),
    "scenario_first": ({"the_x", "the_y"} | _NUMBERS, [{"the_x"}, {"the_y"}]),
    "scenario_second": ({"the_x", "the_y"} | _NUMBERS, [{"the_x"}, {"the_y"}]),
}
_ATTRIBUTE_WORDS = ("more", "less", "high", "low")


@dataclass(frozen=True)
class Wording:
    attributes: Mapping[str, Mapping[str, str]]
    """attribute → {more, less, high, low}."""
    reasoning: Mapping[str, str]
    documents: Mapping[str, tuple[str, ...]]
    questions: Mapping[str, tuple[str, ...]]


def _check_text(text: object, spec: tuple[set[str], list[set[str]]], where: str) -> str:
    if not isinstance(text, str) or not text.strip():
        raise ValueError(f"{where}: must be a non-empty string")
    try:
        names = {n for _, n, _, _ in string.Formatter().parse(text) if n is not None}
    except ValueError as e:
        raise ValueError(f"{where}: malformed braces ({e})") from None
    allowed, groups = spec
    if names - allowed:
        raise ValueError(f"{where}: unknown slot(s) {sorted(names - allowed)}; allowed: {sorted(allowed)}")
    for group in groups:
        if not names & group:
            raise ValueError(f"{where}: needs one of the slots {sorted(group)}")
    return text.strip()


def _section(data: dict, lines: dict, path: Path, key: str, specs: dict, many: bool) -> dict:
    section = data.get(key)
    where = f"{path}:{line_of(lines, (key,))}"
    if not isinstance(section, dict) or set(section) != set(specs):
        raise ValueError(f"{where}: {key!r} must map exactly these kinds: {', '.join(specs)}")
    out = {}
    for kind, spec in specs.items():
        value = section[kind]
        if not many:
            out[kind] = _check_text(value, spec, f"{path}:{line_of(lines, (key, kind))}: {key}.{kind}")
            continue
        if not isinstance(value, list) or not value:
            raise ValueError(f"{path}:{line_of(lines, (key, kind))}: {key}.{kind} must be a non-empty list")
        out[kind] = tuple(_check_text(t, spec, f"{path}:{line_of(lines, (key, kind, i))}: {key}.{kind}[{i}]")
                          for i, t in enumerate(value))
    return out


def load_wording(path: str | Path | None = None) -> Wording:
    """The corpus wording (default: the package's ``wording.yaml``), validated; errors name file:line."""
    return _default_wording() if path is None else _read_wording(Path(path))


@lru_cache(maxsize=1)
def _default_wording() -> Wording:
    return _read_wording(WORDING_FILE)


def _read_wording(path: Path) -> Wording:
    data, lines = read_yaml(path)
    expected = {"attributes", "reasoning", "documents", "questions"}
    if not isinstance(data, dict) or set(data) != expected:
        raise ValueError(f"{path}: top level must have exactly the keys {sorted(expected)}")
    attrs = data["attributes"]
    if not isinstance(attrs, dict) or set(attrs) != set(ATTRIBUTES):
        raise ValueError(f"{path}:{line_of(lines, ('attributes',))}: 'attributes' must map exactly "
                         f"{', '.join(ATTRIBUTES)}")
    for a, words in attrs.items():
        if not isinstance(words, dict) or set(words) != set(_ATTRIBUTE_WORDS) or \
                not all(isinstance(w, str) and w.strip() for w in words.values()):
            raise ValueError(f"{path}:{line_of(lines, ('attributes', a))}: attributes.{a} needs non-empty "
                             f"{', '.join(_ATTRIBUTE_WORDS)}")
    return Wording(
        attributes={a: {k: str(v).strip() for k, v in w.items()} for a, w in attrs.items()},
        reasoning=_section(data, lines, path, "reasoning", _REASONING_SLOTS, many=False),
        documents=_section(data, lines, path, "documents", _DOC_SLOTS, many=True),
        questions=_section(data, lines, path, "questions", _QUESTION_SLOTS, many=True),
    )
