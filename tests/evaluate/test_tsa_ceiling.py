"""The TSA ceiling benchmark's text (benchmarks/tsa_ceiling.py): each video becomes the words the condition allows."""

from __future__ import annotations

from typing import Any

import pytest

from tacreasoner.tasks.schema import QAItem, VideoRef
from tests.evaluate.evalsetup import benchmark_module


@pytest.fixture(scope="module")
def tsa_ceiling() -> Any:
    return benchmark_module("tsa_ceiling")


def _item(question: str) -> QAItem:
    return QAItem(id="t-TSA-0", task="TSA", question=question, answer="B",
                  gold={"letter": "B", "scenario": "scrape_ice", "needs": {"hardness": "high"}},
                  videos=[VideoRef(f"mini/obj{k}_0") for k in range(2)], objects=[f"obj{k}" for k in range(2)],
                  vocabulary="vtv150k", options=["the first object", "the second object"], split="val",
                  meta={"ranks": [{"hardness": 0}, {"hardness": 2}]})


LABELS = {"mini/obj0_0": {"vtv150k": {"hardness": 0, "protrusion": 1, "elasticity": 2, "friction": 0}},
          "mini/obj1_0": {"vtv150k": {"hardness": 2, "protrusion": 0, "elasticity": 0, "friction": 2}}}


def test_each_condition_describes_each_video_in_order(tsa_ceiling: Any) -> None:
    item = _item("<tactile>\n<tactile>\nYou need an object for scraping ice. Which is better? (A) ... (B) ...")
    none = tsa_ceiling.textual_question(item, "none", LABELS)
    assert none.startswith("an object\nan object\nYou need")
    needed = tsa_ceiling.textual_question(item, "needed", LABELS)
    assert needed.startswith("an object (hardness: highly deformable)\nan object (hardness: extremely hard)\n")
    every = tsa_ceiling.textual_question(item, "all", LABELS)
    first, second = every.split("\n")[:2]
    assert first == ("an object (hardness: highly deformable; protrusion: moderate protrusion; elasticity: strong "
                     "elasticity; friction: slight friction)")
    assert "friction: strong friction" in second and "<tactile>" not in every
