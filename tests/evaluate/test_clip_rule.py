"""The conclusion rule on a model's own single-clip answers: readings, ties sharing credit, unread clips."""

from __future__ import annotations

import pytest

from tacreasoner.evaluate.clip_rule import clip_readings, rule_on_readings, rule_on_stated
from tacreasoner.tasks.schema import QAItem, VideoRef


def _tfa(clip: str, attribute: str, level: int) -> QAItem:
    words = {"hardness": ("soft", "moderately hard", "hard"), "roughness": ("smooth", "slightly rough", "rough")}
    return QAItem(id=f"tfa-{attribute}-{clip}", task=f"TFA-{attribute}", question="<tactile>\nQ?",
                  answer=words[attribute][level], gold={"attribute": attribute, "level": level},
                  videos=[VideoRef(clip_id=clip)], objects=[clip], vocabulary="physiclear")


def _soi(clips: list[str], index: int, ranks: list[int]) -> QAItem:
    return QAItem(id=f"soi-{'-'.join(clips)}", task="SOI", question="<tactile>\n<tactile>\n<tactile>\nQ?",
                  answer=f"the {('first', 'second', 'third')[index]} object",
                  gold={"index": index, "attribute": "hardness", "direction": "most"},
                  videos=[VideoRef(clip_id=c) for c in clips], objects=clips, vocabulary="physiclear",
                  meta={"attribute": "hardness", "ranks": ranks})


def test_own_question_wins_over_the_combined_reading() -> None:
    items = [_tfa("a", "hardness", 2)]
    combined = QAItem(id="comb-a", task="TFA-combined", question="<tactile>\nQ?",
                      answer="hardness: hard; roughness: smooth; bumpiness: no bumps",
                      gold={"levels": {"hardness": 2, "roughness": 0, "bumpiness": 0}}, videos=[VideoRef(clip_id="a")],
                      objects=["a"], vocabulary="physiclear")
    records = [{"id": "tfa-hardness-a", "parsed": 1},
               {"id": "comb-a", "parsed": {"hardness": 0, "roughness": 2, "bumpiness": None}}]
    assert clip_readings([*items, combined], records) == {"a": {"hardness": 1, "roughness": 2}}


def test_the_rule_concludes_from_readings_and_ties_share_the_credit() -> None:
    soi = [_soi(["a", "b", "c"], 0, [2, 1, 0]), _soi(["b", "c", "d"], 2, [1, 0, 2])]
    readings = {"a": {"hardness": 2}, "b": {"hardness": 2}, "c": {"hardness": 0}}  # b misread as hard; d unread
    score = rule_on_readings(soi, readings)["SOI"]
    # first item: a and b tie for hardest -> half credit; second: d unread -> wrong
    assert score.n == 2 and score.covered == 1 and score.accuracy == pytest.approx(0.25)
    perfect = rule_on_readings(soi, {**readings, "b": {"hardness": 1}, "d": {"hardness": 2}})["SOI"]
    assert perfect.accuracy == 1.0 and perfect.covered == 2


def test_the_rule_on_stated_levels_replaces_a_conclusion_that_does_not_follow() -> None:
    item = _soi(["a", "b", "c"], 0, [2, 1, 0])  # gold: the first is the hardest
    said = "<think>Video 1: hard. Video 2: {b}. Video 3: soft. The hardest is Video 3.</think>" \
           "<answer>the third object</answer>"
    records = [{"id": item.id, "task": "SOI", "correct": False, "prediction": said.format(b="moderately hard")}]
    assert rule_on_stated([item], records)["SOI"].accuracy == 1.0  # its own levels say the first
    records[0]["prediction"] = said.format(b="hard")  # a tie between the first two: half credit
    assert rule_on_stated([item], records)["SOI"].accuracy == pytest.approx(0.5)
    plain = [{"id": item.id, "task": "SOI", "correct": True, "prediction": "<answer>the first object</answer>"}]
    score = rule_on_stated([item], plain)["SOI"]
    assert score.accuracy == 1.0 and score.covered == 0  # no levels stated: its own answer stands
