"""Every built item is answerable: its gold answer scores right, every other well-formed answer wrong."""

from __future__ import annotations

from pathlib import Path

import pytest

from tacreasoner.evaluate.baselines import answer_space
from tacreasoner.tasks.bench import build_bench, load_bench, tasks_for
from tacreasoner.tasks.builders import build_items
from tacreasoner.tasks.scoring import score_item
from tests.tasks.clipfactory import make_clips

PHYSICLEAR = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "physiclear"


def _wrap(answer: str) -> str:
    return f"<think>Reasoning about the contact.</think><answer>{answer}</answer>"


@pytest.mark.parametrize(("source", "vocabulary"), [("sim", "vtv150k"), ("sim", "physiclear"),
                                                    ("physiclear", "physiclear")])
def test_gold_accepted_and_perturbed_rejected_for_every_task(source: str, vocabulary: str) -> None:
    clips = make_clips(n_objects=40, repeats=3, seed=2)
    tasks = tasks_for(source, vocabulary, has_phases=True, has_fruit=vocabulary == "vtv150k")
    assert ("PC" in tasks) == (vocabulary == "physiclear")  # Octopi's PC: the PhysiCLeAR vocabulary only
    items = build_items(clips, tasks=tasks, vocabulary=vocabulary, split="test", seed=5, per_task=12)
    assert {i.task for i in items} == set(tasks)
    for item in items:
        for mode in ("strict", "lenient"):
            assert score_item(item, _wrap(item.answer), mode).correct, (item.id, mode)
        wrong = [a for a in answer_space(item) if a != item.answer]
        assert wrong
        for answer in wrong[:5]:
            result = score_item(item, _wrap(answer), "strict")
            assert not result.correct and not result.parse_failed, (item.id, answer)


@pytest.mark.parametrize("real", [False, pytest.param(True, marks=pytest.mark.skipif(
    not (PHYSICLEAR / "labels.json").exists(), reason="PhysiCLeAR not available beside the checkout; CI has it"))])
def test_physiclear_builds_all_its_tasks(real: bool, physiclear_folder: Path, tmp_path: Path) -> None:
    """On the shared dataset and on a synthetic folder in its layout (so a plain clone tests it too)."""
    summary = build_bench("physiclear", PHYSICLEAR if real else physiclear_folder, tmp_path, seed=0)
    expected = set(tasks_for("physiclear", "physiclear", has_phases=False, has_fruit=False))
    assert expected == {"TFA-hardness", "TFA-roughness", "TFA-bumpiness", "TFA-combined", "SFD", "PC", "SOI", "OSC",
                        "TSA"}
    assert set(summary.counts["train"]) == expected - {"TSA"}
    assert set(summary.counts["val"]) == expected
    info, val = load_bench(tmp_path, "val")
    assert info["vocabulary"] == "physiclear" and summary.objects["val"] == (7 if real else 4)
    assert all(score_item(i, _wrap(i.answer)).correct for i in val)
