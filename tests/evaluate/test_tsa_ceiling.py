"""The TSA ceiling (tacreasoner.evaluate.tsa_ceiling): each video becomes the words the condition allows; its table."""

from __future__ import annotations

from pathlib import Path

import pytest

from tacreasoner.evaluate import tsa_ceiling
from tacreasoner.evaluate.tsa_ceiling import TsaCeiling
from tacreasoner.tasks.schema import QAItem, VideoRef


def _item(question: str) -> QAItem:
    return QAItem(id="t-TSA-0", task="TSA", question=question, answer="B",
                  gold={"letter": "B", "scenario": "scrape_ice", "needs": {"hardness": "high"}},
                  videos=[VideoRef(f"mini/obj{k}_0") for k in range(2)], objects=[f"obj{k}" for k in range(2)],
                  vocabulary="vtv150k", options=["the first object", "the second object"], split="val",
                  meta={"ranks": [{"hardness": 0}, {"hardness": 2}]})


LABELS = {"mini/obj0_0": {"vtv150k": {"hardness": 0, "protrusion": 1, "elasticity": 2, "friction": 0}},
          "mini/obj1_0": {"vtv150k": {"hardness": 2, "protrusion": 0, "elasticity": 0, "friction": 2}}}


def test_each_condition_describes_each_video_in_order() -> None:
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
    with pytest.raises(ValueError, match="condition must be one of none, needed, all"):
        tsa_ceiling.textual_question(item, "some", LABELS)


def test_the_table_marks_a_lower_bound_above_chance() -> None:
    def way(k: int, n: int, low: float, high: float) -> dict:
        return {"correct": k, "accuracy": k / n, "wilson": [low, high]}

    row = {"split": "val", "condition": "needed", "n": 50, "strict": way(0, 50, 0.0, 0.07),
           "lenient": way(20, 50, 0.28, 0.54), "logprob": way(40, 50, 0.67, 0.89), "ordinal": way(25, 50, 0.37, 0.63)}
    ceiling = TsaCeiling(llm=Path("llm"), bench=Path("bench"), threads=1, max_new_tokens=8, seconds=3.0,
                         results={"val/needed": row},
                         examples={"val/needed": [{"id": "x", "question": "q?", "reply": "A", "gold": "B"}]})
    md = ceiling.markdown()
    assert "| val | needed | 50 | 0.0 [0–7] | 40.0 [28–54] | 80.0 [67–89] ✓ | 50.0 [37–63] |" in md
    assert "- val/needed: `q?` → `A` (gold B)" in md
    assert ceiling.to_dict()["seconds"] == 3.0 and ceiling.to_dict()["llm"] == "llm"
