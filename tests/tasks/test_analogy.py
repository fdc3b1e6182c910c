"""Reading "does it feel like A or B?": the property the two things differ on most, by the everyday objects list."""

from __future__ import annotations

import pytest

from tacreasoner.tasks.analogy import analogy_properties, known_thing
from tacreasoner.tasks.conclude import asked_properties
from tacreasoner.tasks.vocab import get_vocabulary

PHYSICLEAR = get_vocabulary("physiclear")
VTV = get_vocabulary("vtv150k")


def test_a_phrase_names_the_entry_it_shares_most_words_with() -> None:
    assert known_thing("a freshly paved road").name == "a paved road"
    assert known_thing("a bit of sandpaper").name == "a sheet of sandpaper"
    assert known_thing("golf balls").name == "a golf ball"  # plural folded
    assert known_thing("rubber") is None  # shared by several entries alike: no one thing
    assert known_thing("a unicorn's mane") is None


@pytest.mark.parametrize(("text", "physiclear", "vtv"), [
    ("Does it feel like a cobblestone lane or a freshly paved road when you slide over it?",
     ("bumpiness",), ("protrusion",)),
    ("Is it like an ice rink or a rubber bath mat?", ("hardness", "bumpiness"), ("friction",)),
    ("Does it feel like a trampoline or like modelling clay?", (), ("elasticity",)),
    ("Is it more like sandpaper or silk?", ("hardness", "roughness"), ("hardness", "friction")),
])
def test_the_choice_asks_what_the_two_differ_on_most(text: str, physiclear: tuple, vtv: tuple) -> None:
    assert set(analogy_properties(text, PHYSICLEAR)) == set(physiclear)
    assert set(analogy_properties(text, VTV)) == set(vtv)


@pytest.mark.parametrize("text", ["What does it feel like?", "Does it feel like a tangerine?",
                                  "Is it like a unicorn or a dragon?", "Does it feel like this or like that?"])
def test_no_two_known_things_offered_reads_nothing(text: str) -> None:
    assert analogy_properties(text, PHYSICLEAR) == ()


def test_an_analogy_without_a_property_word_is_read_by_what_it_offers() -> None:
    q = "Does it feel like a cobblestone lane or a freshly paved road when you slide over it? <tactile>"
    assert asked_properties(q, "physiclear") == ["bumpiness"]  # was every property (read as "feel like" alone)
    assert asked_properties("What does it feel like? <tactile>", "physiclear") == list(PHYSICLEAR)


def test_a_tie_is_settled_by_the_fallback_only_among_the_tied_properties() -> None:
    q = "Does it feel like a tennis ball or a glass marble? <tactile>"  # hardness and roughness differ by 1 each
    assert asked_properties(q, "physiclear", lambda _q, _v: "roughness") == ["roughness"]
    # a fallback outside the tie leaves the question as before: "feel like" asks about the whole object
    assert asked_properties(q, "physiclear", lambda _q, _v: "bumpiness") == list(PHYSICLEAR)
    assert asked_properties(q, "physiclear") == list(PHYSICLEAR)


def test_a_named_property_still_wins_over_the_analogy() -> None:
    q = "Is it slippery like an ice rink or grippy like a rubber bath mat? <tactile>"
    assert asked_properties(q, "vtv150k") == ["friction"]
