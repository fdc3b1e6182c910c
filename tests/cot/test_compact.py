"""The compact describe-then-conclude style: its format, its answers, and what it costs in tokens."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from tacreasoner.cot.compact import compact_reasoning, compact_target
from tacreasoner.tasks.bench import load_bench
from tacreasoner.tasks.builders import build_items
from tacreasoner.tasks.conclude import REASONED_TASKS, consistency
from tacreasoner.tasks.extract import split_reasoning
from tacreasoner.tasks.paraphrase import reword_items
from tacreasoner.tasks.schema import QAItem
from tacreasoner.tasks.scoring import score_item
from tests.tasks.clipfactory import make_clips

TASKS = {"vtv150k": ["TFA-hardness", "TFA-combined", "SFD", "SOI", "OSC", "RFOR"],
         "physiclear": ["TFA-bumpiness", "TFA-combined", "SFD", "PC", "SOI", "OSC"]}


@pytest.fixture(scope="module", params=sorted(TASKS))
def items(request: pytest.FixtureRequest) -> list[QAItem]:
    clips = make_clips(n_objects=30, repeats=2)
    built = build_items(clips, tasks=TASKS[request.param], vocabulary=request.param, split="train", seed=0)
    return built + reword_items(built, "train")


def test_reasoned_items_describe_each_video_then_conclude_in_the_asked_form(items: list[QAItem]) -> None:
    for item in items:
        target = compact_target(item)
        reasoning, answer = split_reasoning(target)
        assert answer == item.answer
        if item.task not in REASONED_TASKS:
            assert target == f"<answer>{item.answer}</answer>"
            continue
        assert target.startswith("<think>Video 1: ") and target.endswith(f"</think><answer>{item.answer}</answer>")
        for v in range(len(item.videos)):
            assert f"Video {v + 1}: " in reasoning
        assert consistency(item, target).consistent, target
        if item.meta.get("answer_form") != "letter":
            assert score_item(item, target).correct


def test_the_style_is_short(items: list[QAItem]) -> None:
    words = {t: max(len(compact_reasoning(i).split()) for i in items if i.task == t)
             for t in ("SFD", "SOI", "OSC")}
    assert words["SFD"] <= 20 and words["SOI"] <= 25  # SmolLM2: ~30 tokens
    assert words["OSC"] <= 75  # three videos and three named objects described: ~100 tokens


def test_an_answer_its_labels_do_not_imply_is_refused(items: list[QAItem]) -> None:
    soi = next(i for i in items if i.task == "SOI" and i.meta.get("answer_form") != "letter")
    wrong = (soi.gold["index"] + 1) % 3
    ordinal = ("first", "second", "third")[wrong]
    bad = dataclasses.replace(soi, gold={**soi.gold, "index": wrong}, answer=f"the {ordinal} object")
    with pytest.raises(ValueError, match="does not follow from its labels"):
        compact_target(bad)


def test_stage2_trains_on_the_compact_style_without_a_touchcot_file(physiclear_folder: Path, tmp_path: Path) -> None:
    from tacreasoner.tasks.bench import build_bench
    from tacreasoner.train.data import load_examples

    build_bench("physiclear", physiclear_folder, tmp_path / "bench")
    examples = load_examples(2, tmp_path / "bench", stage2_data="compact", paraphrases=True)
    plain = load_examples(2, tmp_path / "bench", stage2_data="plain", paraphrases=True)
    assert [e.key for e in examples] == [e.key for e in plain]  # the same items, other targets
    _, train = load_bench(tmp_path / "bench", "train")
    assert {e.task for e in examples if e.target.startswith("<think>")} == {i.task for i in train} & set(REASONED_TASKS)
    assert all(e.target == p.target for e, p in zip(examples, plain, strict=True) if e.task not in REASONED_TASKS)
