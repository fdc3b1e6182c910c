"""Retrieval augmentation (Octopi-1.5, issue 28): a benchmark whose questions carry each video's nearest train clips.

A small synthetic PhysiCLeAR-shaped folder (train objects beside the val/test ones of ``test_physiclear_folder``) and an
untrained saved appearance encoder: the neighbours are whatever its features say, what is tested is what the
transform promises whatever they are (own objects never retrieved, k, placeholders, the label words, determinism,
paths that resolve, the commands and their errors).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch
from typer.testing import CliRunner

import tacreasoner.train.data as train_data
from tacreasoner.cli import app
from tacreasoner.evaluate.retrieval import PREFIX, ReferenceClip, ReferenceSet, neighbour_text, retrieval_bench
from tacreasoner.tasks.bench import build_bench, build_folder_bench, load_bench
from tacreasoner.tasks.schema import PLACEHOLDER
from tacreasoner.tasks.vocab import PHYSICLEAR
from tests.evaluate.evalsetup import ENCODER, save_untrained_model
from tests.evaluate.test_physiclear_folder import make_folder

TRAIN = {"aluminium_foil": (1, 0, 0), "avocado_unripe": (2, 0, 1), "basket": (1, 2, 2), "blanket": (0, 1, 0),
         "bread_knife_blade": (2, 0, 0), "bubble_wrap": (0, 1, 2)}
"""Train objects added to the folder (name → hardness, roughness, bumpiness ranks): 6, so a 3-object item keeps 3
others."""
runner = CliRunner()


@pytest.fixture(autouse=True)
def _in_process(monkeypatch: pytest.MonkeyPatch) -> None:
    """Decode the few clips here in-process: starting worker processes would cost more than the decoding."""
    monkeypatch.setattr(train_data, "MIN_CLIPS_PER_POOL", 10**9)


def _labels(folder: Path) -> dict:
    return json.loads((folder / "labels.json").read_text())["objects"]


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The test folder's objects (denim in val, the rest in test) plus TRAIN, two videos each."""
    root = make_folder(tmp_path_factory.mktemp("retrieval_copy") / "data",
                       extra={name: ("train", ranks) for name, ranks in TRAIN.items()})
    labels = json.loads((root / "labels.json").read_text())
    labels["objects"]["denim"]["split"] = "val"
    (root / "labels.json").write_text(json.dumps(labels))
    return root


@pytest.fixture(scope="module")
def encoder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from tacreasoner.model.appearance import AppearanceEncoder
    from tacreasoner.model.encoder_config import TactileEncoderConfig

    torch.manual_seed(0)
    return AppearanceEncoder(TactileEncoderConfig.from_dict(dict(ENCODER))).save_pretrained(
        tmp_path_factory.mktemp("retrieval_encoder") / "encoder")


@pytest.fixture(scope="module")
def bench(folder: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("retrieval_bench") / "plain"
    build_bench("physiclear", folder, out, per_task=4)
    return out


@pytest.fixture(scope="module")
def augmented(bench: Path, encoder: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    mp = pytest.MonkeyPatch()
    mp.setattr(train_data, "MIN_CLIPS_PER_POOL", 10**9)
    try:
        out = tmp_path_factory.mktemp("retrieval_out") / "k2"
        retrieval_bench(bench, encoder, out, k=2)
    finally:
        mp.undo()
    return out


def _splits(bench: Path) -> list[str]:
    return [s for s in ("train", "val", "test") if (bench / f"{s}.jsonl").is_file()]


def test_neighbours_are_k_other_objects_with_their_label_words(folder: Path, bench: Path, augmented: Path) -> None:
    shared = _labels(folder)
    words = {name: PHYSICLEAR["hardness"].phrase(o["hardness"]) + "; " + PHYSICLEAR["roughness"].phrase(
        o["roughness"]) + "; " + PHYSICLEAR["bumpiness"].phrase(o["bumpiness"]) for name, o in shared.items()
        if "hardness" in o}
    seen = 0
    for split in _splits(bench):
        _, plain = load_bench(bench, split)
        _, items = load_bench(augmented, split)
        assert [i.id for i in items] == [i.id for i in plain] and len(items) > 0
        for old, new in zip(plain, items, strict=True):
            assert new.question.startswith(PREFIX) and new.question.endswith("\n" + old.question)
            assert new.question.count(PLACEHOLDER) == old.question.count(PLACEHOLDER) == len(new.videos)
            assert (new.answer, new.gold, new.videos) == (old.answer, old.gold, old.videos)
            found = new.meta["retrieval"]["videos"]
            assert len(found) == len(new.videos)
            prefix = new.question[:-len(old.question)]
            for hits in found:
                assert len(hits) == 2, "k neighbours per video"
                assert not {h["object"] for h in hits} & set(new.objects), "never the item's own objects"
                assert all(h["object"] in TRAIN for h in hits)
                sims = [h["similarity"] for h in hits]
                assert sims == sorted(sims, reverse=True)
                for h in hits:  # the words come from the raw labels.json, not from the code under test
                    assert f"{shared[h['object']]['name']} ({words[h['object']]})" in prefix
                seen += 1
            if len(new.videos) > 1:
                assert "For the second video:" in prefix
    assert seen > 50


def test_output_is_deterministic_and_its_videos_resolve_from_anywhere(bench: Path, encoder: Path, augmented: Path,
                                                                      tmp_path: Path,
                                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    from tacreasoner.train.data import bench_video_root

    again = tmp_path / "again"
    summary = retrieval_bench(bench, encoder, again, k=2)
    assert summary.reference_objects == len(TRAIN) and summary.reference_clips == 2 * len(TRAIN)
    for name in ("bench.json", *(f"{s}.jsonl" for s in _splits(bench))):
        assert (again / name).read_bytes() == (augmented / name).read_bytes(), name
    info = json.loads((augmented / "bench.json").read_text())
    assert info["retrieval"]["k"] == 2 and info["retrieval"]["reference_split"] == "train"
    assert info["retrieval"]["encoder"] == str(encoder.resolve())
    assert Path(info["video_root"]).is_absolute()
    monkeypatch.chdir(tmp_path)
    root = bench_video_root(augmented, info)
    assert all((root / v.path).is_file() for s in _splits(augmented) for i in load_bench(augmented, s)[1]
               for v in i.videos)


def test_neighbour_ranking_excludes_objects_breaks_ties_by_clip_id_and_may_give_fewer() -> None:
    def clip(name: str, obj: str) -> ReferenceClip:
        return ReferenceClip(name, obj, f"a {obj}", {"hardness": 0, "roughness": 1, "bumpiness": 2}, (name, None, None))

    clips = [clip("a_0", "a"), clip("b_0", "b"), clip("b_1", "b"), clip("c_0", "c")]
    feats = np.array([[1.0, 0.0], [0.6, 0.8], [0.6, 0.8], [0.0, 1.0]])
    ref = ReferenceSet(clips, feats, "physiclear")
    assert [i for i, _ in ref.neighbours(np.array([1.0, 0.0]), [], 3)] == [0, 1, 2]
    assert [i for i, _ in ref.neighbours(np.array([1.0, 0.0]), ["a"], 2)] == [1, 2]
    assert [i for i, _ in ref.neighbours(np.array([1.0, 0.0]), ["a", "b"], 3)] == [3]
    assert ref.neighbours(np.array([1.0, 0.0]), ["a", "b", "c"], 3) == []
    assert neighbour_text([[clips[0]]], "physiclear") == f"{PREFIX}: a a (soft; slightly rough; big bumps)."


def _invoke(*args: object):
    return runner.invoke(app, [str(a) for a in args])


def _one_line_error(result, *needles: str) -> None:
    assert result.exit_code == 2, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), result.output
    assert "Traceback" not in result.output
    for needle in needles:
        assert needle in lines[0], lines[0]


def test_retrieval_bench_command_and_its_one_line_errors(bench: Path, encoder: Path, augmented: Path,
                                                         folder: Path, tmp_path: Path) -> None:
    out = tmp_path / "k1"
    result = _invoke("retrieval-bench", "--bench", bench, "--encoder", encoder, "--out", out, "--k", 1)
    assert result.exit_code == 0, result.output
    _, items = load_bench(out, "val")
    assert items and all(len(h) == 1 for i in items for h in i.meta["retrieval"]["videos"])

    _one_line_error(_invoke("retrieval-bench", "--bench", tmp_path / "nowhere", "--encoder", encoder, "--out",
                            tmp_path / "x"), "bench.json")
    (tmp_path / "not_encoder").mkdir()
    _one_line_error(_invoke("retrieval-bench", "--bench", bench, "--encoder", tmp_path / "not_encoder", "--out",
                            tmp_path / "x"), "config.json")
    _one_line_error(_invoke("retrieval-bench", "--bench", bench, "--encoder", encoder, "--out", tmp_path / "x",
                            "--k", 0), "--k must be at least 1")
    test_only, _ = build_folder_bench(folder, tmp_path / "test_only")
    _one_line_error(_invoke("retrieval-bench", "--bench", test_only.out_dir, "--encoder", encoder, "--out",
                            tmp_path / "x"), "no train split")
    _one_line_error(_invoke("retrieval-bench", "--bench", augmented, "--encoder", encoder, "--out", tmp_path / "x"),
                    "already retrieval-augmented")
    _one_line_error(_invoke("retrieval-bench", "--bench", bench, "--encoder", encoder, "--out", bench),
                    "new folder")
    assert not (tmp_path / "x").exists()


def test_evaluate_physiclear_retrieval_asks_the_folder_like_the_training_bench(folder: Path, augmented: Path,
                                                                               tmp_path: Path) -> None:
    texts = [f"{i.question} {i.answer}" for s in _splits(augmented) for i in load_bench(augmented, s)[1]]
    model = save_untrained_model(texts, tmp_path / "model", vocab_size=400)
    out = tmp_path / "eval"
    args = ["evaluate-physiclear", "--model", model, "--data", folder, "--out", out, "--max-new-tokens", 2,
            "--per-task", 1]
    result = _invoke(*args, "--retrieval", augmented)  # encoder and k: as the training bench records them
    assert result.exit_code == 0, result.output
    info, items = load_bench(out / "bench", "val")  # the folder's val objects by default
    assert info["retrieval"]["k"] == 2 and info["retrieval"]["reference_bench"] == str(augmented.resolve())
    assert items and all(i.question.startswith(PREFIX) for i in items)
    assert all(len(h) == 2 and {x["object"] for x in h} <= set(TRAIN) for i in items
               for h in i.meta["retrieval"]["videos"])
    assert len((out / "model0" / "predictions" / "val.jsonl").read_text().splitlines()) == len(items)

    _one_line_error(_invoke(*args, "--encoder", augmented), "only go with --retrieval")
    test_only, _ = build_folder_bench(folder, tmp_path / "test_only")
    _one_line_error(_invoke(*args, "--retrieval", test_only.out_dir, "--encoder", model), "no train split")
    # answers resume by item id, and retrieval keeps the ids: an --out answered another way is refused, not mixed
    _one_line_error(_invoke(*args, "--retrieval", augmented, "--retrieval-k", 1), "retrieval_k changed")
    _one_line_error(_invoke(*args), "give a fresh --out")
