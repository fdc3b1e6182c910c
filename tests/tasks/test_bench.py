"""Benchmark directories built from a simulated dataset and from a planted leak."""

from __future__ import annotations

import json
from collections import defaultdict
from pathlib import Path

import pytest

from tacreasoner.tasks.bench import BENCH_INFO, build_bench, load_bench
from tacreasoner.tasks.scoring import check_gold


@pytest.fixture(scope="module")
def bench(small_sim_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("bench")
    build_bench("sim", small_sim_dataset, out, seed=0, heldout_sensor="digit")
    return out


def _all_items(bench: Path) -> dict[str, list]:
    return {split: load_bench(bench, split)[1]
            for split in ("train", "val", "test", "val_heldout_sensor", "test_heldout_sensor")}


def test_objects_never_cross_splits_and_tsa_is_zero_shot(bench: Path) -> None:
    splits_of = defaultdict(set)
    for split, items in _all_items(bench).items():
        for item in items:
            for obj in item.objects:
                splits_of[obj].add(split.removesuffix("_heldout_sensor"))
    assert splits_of and all(len(s) == 1 for s in splits_of.values())
    train = load_bench(bench, "train")[1]
    assert train and not any(i.task == "TSA" for i in train)
    assert any(i.task == "TSA" for i in load_bench(bench, "test")[1])


@pytest.mark.parametrize("split", ["val", "test"])
def test_heldout_sensor_files_hold_only_that_sensor_on_their_split_objects(bench: Path, split: str) -> None:
    """val_heldout_sensor is where a recipe for unseen sensors is chosen; test_heldout_sensor is read once."""
    info, held = load_bench(bench, f"{split}_heldout_sensor")
    split_objects = {o for o, s in info["splits"].items() if s == split}
    assert held and info["counts"][f"{split}_heldout_sensor"]
    assert all(ref.clip_id.startswith("digit/") for i in held for ref in i.videos)
    assert all(set(i.objects) <= split_objects for i in held)
    assert all(i.split == split and i.id.endswith("-digit") for i in held)
    main = [ref for split in ("train", "val", "test") for i in load_bench(bench, split)[1] for ref in i.videos]
    assert all(ref.clip_id.startswith("mini/") for ref in main)


def test_items_are_answerable_and_videos_resolve(bench: Path) -> None:
    info = json.loads((bench / BENCH_INFO).read_text())
    root = Path(info["video_root"])
    for split, items in _all_items(bench).items():
        assert info["counts"][split] == {t: sum(i.task == t for i in items) for t in info["counts"][split]}
        for item in items:
            check_gold(item)
            for ref in item.videos:
                assert not Path(ref.path).is_absolute()
                assert (root / ref.path).exists()
    tasks = {i.task for items in _all_items(bench).values() for i in items}
    assert {"TFA-hardness", "TFA-combined", "SFD", "RFOR", "OCSE"} <= tasks


def test_same_seed_same_benchmark(small_sim_dataset: Path, bench: Path, tmp_path: Path) -> None:
    build_bench("sim", small_sim_dataset, tmp_path, seed=0, heldout_sensor="digit")
    for name in ("train.jsonl", "test.jsonl", "val_heldout_sensor.jsonl", "test_heldout_sensor.jsonl"):
        assert (tmp_path / name).read_text() == (bench / name).read_text()


def test_simulated_clips_in_physiclear_words(small_sim_dataset: Path, bench: Path, tmp_path: Path) -> None:
    """The same objects and splits, asked in PhysiCLeAR's vocabulary and task set (PC included), for training a
    real-data model beside simulated clips; the default benchmark is untouched by the option."""
    build_bench("sim", small_sim_dataset, tmp_path, seed=0, heldout_sensor="digit", vocabulary="physiclear")
    info = json.loads((tmp_path / BENCH_INFO).read_text())
    assert info["vocabulary"] == "physiclear" and "PC" in info["tasks"] and "TFA-roughness" in info["tasks"]
    assert info["splits"] == json.loads((bench / BENCH_INFO).read_text())["splits"]
    train = load_bench(tmp_path, "train")[1]
    assert {i.vocabulary for i in train} == {"physiclear"} and all(check_gold(i) is None for i in train)
    assert "PC" not in json.loads((bench / BENCH_INFO).read_text())["tasks"]
    with pytest.raises(ValueError, match="vocabulary 'vtv150k' is not available for source 'physiclear'"):
        build_bench("physiclear", small_sim_dataset, tmp_path / "x", vocabulary="vtv150k")
    with pytest.raises(ValueError, match="vocabulary 'octopi' is not available for source 'sim'"):
        build_bench("sim", small_sim_dataset, tmp_path / "y", vocabulary="octopi")


def test_bad_requests_are_clear_errors(small_sim_dataset: Path, tmp_path: Path, bench: Path) -> None:
    with pytest.raises(ValueError, match="unknown source"):
        build_bench("octopi", small_sim_dataset, tmp_path)
    with pytest.raises(ValueError, match="needs --ranks"):
        build_bench("vtv150k", small_sim_dataset, tmp_path)
    with pytest.raises(ValueError, match="not in the dataset"):
        build_bench("sim", small_sim_dataset, tmp_path, heldout_sensor="tac3d")
    with pytest.raises(FileNotFoundError, match="no such split"):
        load_bench(bench, "holdout")
    with pytest.raises(FileNotFoundError, match="not a benchmark directory"):
        load_bench(tmp_path / "nothing")


def test_planted_leak_is_refused(small_sim_dataset: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """If a split assignment ever put one object's clips in two splits, nothing may be written."""
    from tacreasoner.data import splits
    from tacreasoner.tasks import bench as bench_mod

    real_check = splits.check_no_leakage

    def leaky(pairs):
        pairs = list(pairs)
        split, obj = pairs[0]
        return real_check([*pairs, ("test" if split != "test" else "train", obj)])

    monkeypatch.setattr(splits, "check_no_leakage", leaky)
    with pytest.raises(splits.LeakageError):
        bench_mod.build_bench("sim", small_sim_dataset, tmp_path / "b", heldout_sensor="digit")
    assert not (tmp_path / "b" / BENCH_INFO).exists()


def test_vtv150k_layout_builds_a_benchmark(tmp_path: Path) -> None:
    """Flat ``<object>_<k>.mp4`` videos + a rank table → a benchmark; unranked objects are reported."""
    import numpy as np

    from tacreasoner.tasks.formats import read_vtv_json, write_vtv_json
    from tacreasoner.video_io import write_video

    videos = tmp_path / "videos"
    videos.mkdir()
    rng = np.random.default_rng(0)
    ranks = {}
    for i in range(12):
        obj = f"thing_{i}_x"  # underscores inside object names
        for k in range(2):
            write_video(videos / f"{obj}_{k}.mp4", rng.integers(0, 255, (6, 16, 16, 3), dtype=np.uint8), 25)
        if i < 11:
            ranks[obj] = {a: int(rng.integers(3)) for a in ("hardness", "protrusion", "elasticity", "friction")}
    table = tmp_path / "ranks.json"
    table.write_text(json.dumps(ranks))
    summary = build_bench("vtv150k", videos, tmp_path / "bench", ranks=table, seed=0)
    assert any("2 VTV-150K clips without ranks" in n for n in summary.notes)
    info, test = load_bench(tmp_path / "bench", "test")
    assert info["vocabulary"] == "vtv150k" and "thing_11_x" not in info["splits"]
    assert {"TFA-hardness", "TFA-friction", "TFA-combined"} <= {i.task for i in test}
    write_vtv_json(test, tmp_path / "vtv.json")
    back = read_vtv_json(tmp_path / "vtv.json")
    assert [(i.question, i.answer, i.task) for i in back] == [(i.question, i.answer, i.task) for i in test]


def test_relative_data_path_gives_paths_relative_to_video_root(
        small_sim_dataset: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import os

    monkeypatch.chdir(tmp_path)
    rel = Path(os.path.relpath(small_sim_dataset, tmp_path))
    build_bench("sim", rel, tmp_path / "b", heldout_sensor="digit")
    info, items = load_bench(tmp_path / "b", "train")
    root = Path(info["video_root"])
    assert all((root / ref.path).exists() for i in items for ref in i.videos)
