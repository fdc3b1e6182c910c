"""The text-rehearsal TSA benchmark's pieces (benchmarks/tsa_text_rehearsal.py): families, the swap, the letter."""

from __future__ import annotations

from collections import Counter
from typing import Any

import pytest
from evalsetup import benchmark_module

from tacreasoner.knowledge.corpus import build_corpus
from tacreasoner.tasks.schema import QAItem, VideoRef


@pytest.fixture(scope="module")
def rehearsal() -> Any:
    return benchmark_module("tsa_text_rehearsal")


def _item(letter: str = "B") -> QAItem:
    return QAItem(id="t-TSA-0", task="TSA", question="<tactile>\n<tactile>\nScraping ice? (A) the first object "
                  "(B) the second object", answer=letter,
                  gold={"letter": letter, "scenario": "scrape_ice", "needs": {"hardness": "high"}},
                  videos=[VideoRef(f"mini/obj{k}_0") for k in range(2)], objects=["obj0", "obj1"],
                  vocabulary="vtv150k", options=["the first object", "the second object"], split="val",
                  meta={"ranks": [{"hardness": 0}, {"hardness": 2}], "scores": [0, 2]})


def test_every_corpus_dialogue_has_a_family(rehearsal: Any) -> None:
    corpus = build_corpus(0, n_compare=200, n_scenario=200, n_fact=50)
    families = Counter(rehearsal.family(d) for d in corpus.dialogues)
    assert families["scenario"] == 200, families  # each scenario choice scores both objects
    assert families["need"] >= 10 and families["compare"] >= 250, families
    for d in corpus.dialogues:
        if rehearsal.family(d) == "scenario":
            assert " suits it " in d[-1]["content"] and "<answer>" in d[-1]["content"]


def test_swapping_the_videos_swaps_the_gold_and_what_describes_them(rehearsal: Any) -> None:
    item = _item("B")
    twin = rehearsal.swapped(item)
    assert twin.gold["letter"] == twin.answer == "A" and item.gold["letter"] == "B"
    assert [v.clip_id for v in twin.videos] == ["mini/obj1_0", "mini/obj0_0"]
    assert twin.meta["ranks"] == [{"hardness": 2}, {"hardness": 0}] and twin.meta["scores"] == [2, 0]


@pytest.mark.parametrize(("reply", "right", "letter"), [
    ("<answer>the second object</answer>", True, "B"),
    ("<answer>A</answer>", False, "A"),
    ("<answer>grippy and hard</answer>", False, None),  # the scenario's needs, not a choice: follows nothing
    ("no tags at all", False, None),
])
def test_the_letter_read_from_a_reply(rehearsal: Any, reply: str, right: bool, letter: str | None) -> None:
    assert rehearsal.lenient(_item("B"), reply) == (right, letter)
