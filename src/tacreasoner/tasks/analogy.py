"""Which property "Does it feel like A or B?" asks: the one the two things differ on most.

A person may ask about a property without naming it, by offering two things to compare the touch with ("does it feel
like a cobblestone street or a paved road?" asks about bumps; "like a brick or a sponge?" about hardness). The word
list (:func:`tacreasoner.tasks.conclude.asked_properties`) finds no property word there, and a sentence embedding
reads such a question as about "feel" in general (roughness, hardness and bumpiness within 0.02 of each other). What
the two things usually feel like is general knowledge the project already writes down (``everyday_objects.yaml``):
the property whose typical ranks differ most between them is the one the choice is about. Where several differ as
much, the sentence embedding chooses among them; a thing that list does not know leaves the question to the readers
after this one.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from functools import lru_cache

from tacreasoner.tasks.everyday_objects import EverydayObject, everyday_objects

__all__ = ["ALTERNATIVES", "analogy_properties", "known_thing"]

ALTERNATIVES = re.compile(
    r"\blike\s+(?P<a>[^,;:?.!\n]+?)\s+or\s+(?:more\s+|rather\s+|maybe\s+)?(?:like\s+)?(?P<b>[^,;:?.!\n]+?)"
    r"(?=\s+(?:when|if|as|while|after|under|once|to\s+the|in\s+your|in\s+my)\b|[,;:?.!\n]|$)", re.IGNORECASE)
"""Two things offered as what the touch is like: "like A or (like) B", up to a clause or the sentence's end."""
_GENERIC = frozenset({
    "a", "an", "the", "some", "any", "one", "my", "your", "our", "their", "its", "this", "that", "of", "piece",
    "sheet", "bit", "lump", "patch", "slice", "bar", "handful", "scoop", "kind", "sort", "type", "new", "old",
    "fresh", "freshly", "wet", "dry", "big", "small", "little", "large", "thing", "stuff", "something", "more"})
"""Words that name no particular thing: they never make a phrase match an entry."""
_WORD = re.compile(r"[a-z]+(?:-[a-z]+)*")


def _content_words(phrase: str) -> frozenset[str]:
    """Lower-case words of ``phrase`` that can name a thing, plurals folded ("stones" → "stone")."""
    words = (w[:-1] if len(w) > 3 and w.endswith("s") and not w.endswith("ss") else w
             for w in _WORD.findall(re.sub(r"['’]s\b", "", phrase.lower())))
    return frozenset(w for w in words if len(w) > 2 and w not in _GENERIC)


@lru_cache(maxsize=1)
def _entries() -> tuple[tuple[frozenset[str], EverydayObject], ...]:
    return tuple((_content_words(o.name), o) for o in everyday_objects())


def known_thing(phrase: str) -> EverydayObject | None:
    """The everyday object ``phrase`` names: the entry sharing the most naming words with it, when exactly one does
    ("a bit of sandpaper" → a sheet of sandpaper; "rubber", shared by several entries, → None)."""
    words = _content_words(phrase)
    scored = sorted(((len(words & names), o) for names, o in _entries() if words & names), key=lambda t: -t[0])
    if not scored or (len(scored) > 1 and scored[1][0] == scored[0][0]):
        return None
    return scored[0][1]


def _rank(thing: EverydayObject, attribute: str) -> int | None:
    if attribute == "bumpiness":  # as everyday_objects.py says: bumpiness is the protrusion rank
        attribute = "protrusion"
    return thing.ranks.get(attribute)


def analogy_properties(text: str, vocabulary: Mapping[str, object]) -> tuple[str, ...]:
    """The properties of ``vocabulary`` on which the two things a "like A or B" choice offers differ most, by their
    typical ranks (several when they tie: "sandpaper or silk" differ as much in hardness as in roughness by the list);
    empty when there is no such choice, either thing is unknown, or they do not differ."""
    for match in ALTERNATIVES.finditer(text):
        a, b = known_thing(match.group("a")), known_thing(match.group("b"))
        if a is None or b is None or a == b:
            continue
        gaps = {p: abs(ra - rb) for p in vocabulary
                if (ra := _rank(a, p)) is not None and (rb := _rank(b, p)) is not None}
        widest = max(gaps.values(), default=0)
        if widest >= 1:
            return tuple(p for p, g in gaps.items() if g == widest)
    return ()
