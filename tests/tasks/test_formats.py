"""QA item files: JSONL round trip and validation, VTV-LLM-style JSON round trip and import, LLaVA export."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tacreasoner.tasks.builders import build_items
from tacreasoner.tasks.formats import (
    EXTRA_KEY,
    infer_tfa_gold,
    read_jsonl,
    read_llava,
    read_vtv_json,
    to_llava,
    to_vtv_json,
    write_jsonl,
    write_llava,
    write_vtv_json,
)
from tacreasoner.tasks.schema import QAItem
from tests.tasks.clipfactory import make_clips

TASKS = ["TFA-hardness", "TFA-protrusion", "TFA-elasticity", "TFA-friction", "TFA-combined", "SFD", "SOI", "OSC",
         "TSA", "RFOR", "OCSE"]


@pytest.fixture(scope="module")
def items() -> list[QAItem]:
    clips = make_clips(20, repeats=2, with_paths=True)
    return build_items(clips, tasks=TASKS, vocabulary="vtv150k", split="test", seed=0, per_task=12, source="sim")


def dicts(items: list[QAItem]) -> list[dict]:
    return [i.to_dict() for i in items]


# ------------------------------------------------------------------------------------------ JSONL


def test_jsonl_round_trip_is_exact(items: list[QAItem], tmp_path: Path) -> None:
    path = write_jsonl(items, tmp_path / "sub" / "test.jsonl")
    assert dicts(read_jsonl(path)) == dicts(items)
    write_jsonl(items[:3], path)  # overwrite in place, atomically: no temporary files left behind
    assert len(read_jsonl(path)) == 3
    assert [p.name for p in path.parent.iterdir()] == ["test.jsonl"]


def _lines_with(items: list[QAItem], bad: str) -> list[str]:
    return [items[0].to_json(), items[1].to_json(), bad, items[3].to_json()]


def _edit(item: QAItem, **changes: object) -> str:
    return json.dumps({**item.to_dict(), **changes})


@pytest.mark.parametrize(("make_bad", "needle"), [
    (lambda it: '{"id": "x", "task": ', "not valid JSON"),
    (lambda it: "[1, 2]", "expected a JSON object"),
    (lambda it: _edit(it, colour="red"), "unknown field(s) ['colour']"),
    (lambda it: json.dumps({k: v for k, v in it.to_dict().items() if k != "gold"}), "missing field(s) ['gold']"),
    (lambda it: _edit(it, question="no placeholder here"), "0 <tactile> placeholders but 1 videos"),
    (lambda it: _edit(it, task="TFA-colour"), "unknown task 'TFA-colour'"),
    (lambda it: _edit(it, answer="extremely soft"), "does not match its gold"),
    (lambda it: _edit(it, gold={"attribute": "hardness", "level": 7}), "invalid value 7"),
    (lambda it: _edit(it, videos=[{"clip_id": "c", "frames": 3}]), "videos[0]: unknown field(s) ['frames']"),
    (lambda it: _edit(it, videos="clip.mp4"), "field 'videos' must be list"),
    (lambda it: _edit(it, split="holdout"), "split must be one of"),
    (lambda it: _edit(it, vocabulary="octopi"), "unknown vocabulary"),
    (lambda it: _edit(it, id="sim-test-TFA-hardness-00000"), "duplicate item id"),
])
def test_malformed_line_names_path_and_line(items: list[QAItem], tmp_path: Path, make_bad, needle: str) -> None:
    tfa = [i for i in items if i.task == "TFA-hardness"]
    path = tmp_path / "bad.jsonl"
    path.write_text("\n".join(_lines_with(tfa, make_bad(tfa[2]))) + "\n")
    with pytest.raises(ValueError) as info:
        read_jsonl(path)
    message = str(info.value)
    assert message.startswith(f"{path}:3: "), message
    assert needle in message, message


def test_blank_lines_are_skipped(items: list[QAItem], tmp_path: Path) -> None:
    path = tmp_path / "blank.jsonl"
    path.write_text(items[0].to_json() + "\n\n" + items[1].to_json() + "\n")
    assert len(read_jsonl(path)) == 2


# ------------------------------------------------------------------------------------------ VTV JSON


def test_vtv_export_shape(items: list[QAItem]) -> None:
    records = to_vtv_json(items, video_root="/data/sim")
    assert len(records) == len(items)
    for item, rec in zip(items, records, strict=True):
        assert set(rec) == {"id", "video", "conversations", EXTRA_KEY}
        assert rec["video"] == [f"/data/sim/{v.path}" for v in item.videos]
        human, gpt = rec["conversations"]
        assert human["from"] == "human" and gpt == {"from": "gpt", "value": item.answer}
        assert human["value"].count("<video>") == len(item.videos) and "<tactile>" not in human["value"]
    assert to_vtv_json(items[:1])[0]["video"] == [items[0].videos[0].path]


def test_vtv_round_trip_is_lossless(items: list[QAItem], tmp_path: Path) -> None:
    path = write_vtv_json(items, tmp_path / "qa.json", video_root="/data/sim")
    back = read_vtv_json(path)
    assert dicts(back) == dicts(items)
    assert [(i.question, i.answer, i.videos, i.task, i.gold) for i in back] == \
           [(i.question, i.answer, i.videos, i.task, i.gold) for i in items]


def test_vtv_import_rejects_edited_records(items: list[QAItem], tmp_path: Path) -> None:
    records = to_vtv_json(items[:2])
    records[1]["conversations"][1]["value"] = "something else"
    path = tmp_path / "edited.json"
    path.write_text(json.dumps(records))
    with pytest.raises(ValueError, match=rf"record 1 \(id '{items[1].id}'\).*differs"):
        read_vtv_json(path)


def _foreign(answer: str, question: str = "<video>\nHow hard is this object?", video: object = "cup_3.mp4") -> dict:
    return {"id": "q7", "video": video, "conversations": [{"from": "human", "value": question},
                                                         {"from": "gpt", "value": answer}]}


def test_foreign_vtv_json_infers_tfa_tasks(tmp_path: Path) -> None:
    records = [
        _foreign("moderately deformable"),
        _foreign("The object feels extremely hard.", video=["/v/sponge_12.mp4"]),
        _foreign("hardness: highly deformable; protrusion: no protrusion; elasticity: strong elasticity; "
                 "friction: slight friction"),
    ]
    path = tmp_path / "vtv.json"
    path.write_text(json.dumps(records))
    a, b, c = read_vtv_json(path, video_root="/v")
    assert (a.task, a.gold) == ("TFA-hardness", {"attribute": "hardness", "level": 1})
    assert a.answer == "moderately deformable" and "raw_answer" not in a.meta
    assert a.question == "<tactile>\nHow hard is this object?" and a.objects == ["cup"]
    assert (b.task, b.answer) == ("TFA-hardness", "extremely hard")
    assert b.meta["raw_answer"] == "The object feels extremely hard."
    assert b.videos[0].path == "sponge_12.mp4" and b.videos[0].clip_id == "sponge_12"
    assert c.task == "TFA-combined" and c.gold["levels"] == {"hardness": 0, "protrusion": 0, "elasticity": 2,
                                                             "friction": 0}


@pytest.mark.parametrize(("record", "needle"), [
    (_foreign("the first object", question="<video>\n<video>\nWhich is harder?", video=["a_1.mp4", "b_1.mp4"]),
     "cannot infer the task"),
    (_foreign("extremely hard highly deformable"), "cannot infer the task"),
    (_foreign("moderately deformable", question="How hard?"), "0 <video> token(s) for 1 video(s)"),
    ({"id": "q7", "video": "x.mp4"}, "missing 'conversations'"),
])
def test_foreign_vtv_json_errors_name_the_record(tmp_path: Path, record: dict, needle: str) -> None:
    path = tmp_path / "vtv.json"
    path.write_text(json.dumps([_foreign("moderately deformable"), record]))
    with pytest.raises(ValueError) as info:
        read_vtv_json(path)
    assert f"{path}: record 1 (id 'q7')" in str(info.value) and needle in str(info.value)


def test_infer_tfa_gold_prefers_longest_phrase() -> None:
    assert infer_tfa_gold("moderately hard", "physiclear") == ("TFA-hardness", {"attribute": "hardness", "level": 1})
    assert infer_tfa_gold("It has big bumps.", "physiclear") == ("TFA-bumpiness", {"attribute": "bumpiness",
                                                                                  "level": 2})
    assert infer_tfa_gold("no idea") is None


# ------------------------------------------------------------------------------------------ LLaVA


def test_llava_export_shape_and_round_trip(items: list[QAItem], tmp_path: Path) -> None:
    records = to_llava(items)
    for item, rec in zip(items, records, strict=True):
        assert set(rec) == {"id", "videos", "conversations"}
        assert rec["videos"] == [v.path for v in item.videos]
        human, gpt = rec["conversations"]
        assert human["from"] == "human" and human["value"].count("<video>") == len(item.videos)
        assert gpt == {"from": "gpt", "value": f"<answer>{item.answer}</answer>"}
    path = write_llava(items, tmp_path / "llava.json", include_meta=True)
    assert dicts(read_llava(path)) == dicts(items)
    tfa = [i for i in items if i.task == "TFA-friction"]
    write_llava(tfa, path)
    back = read_llava(path)
    assert [(i.task, i.gold, i.answer, i.question) for i in back] == [(i.task, i.gold, i.answer, i.question)
                                                                      for i in tfa]
