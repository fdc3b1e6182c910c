"""Dataset readers: image folders, VTV-150K layout, DynTAC-Sim, PhysiCLeAR, and bad files in batch mode."""

from __future__ import annotations

import json
import re
from pathlib import Path

import av
import numpy as np
import pytest

from tacreasoner.data.clip import TactileClip
from tacreasoner.data.readers import (
    ClipList,
    LoadReport,
    check_video,
    default_physiclear_dir,
    load_clips,
    read_image_folder,
    read_physiclear,
    read_sim_dataset,
    read_video_clip,
    read_vtv150k,
)
from tacreasoner.data.splits import check_no_leakage
from tacreasoner.video_io import VideoError, write_video

PHYSICLEAR = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "physiclear"


def tiny_frames(t: int = 6, h: int = 32, w: int = 48, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 255, (t, h, w, 3), dtype=np.uint8)


def tiny_video(path: Path, t: int = 6, seed: int = 0) -> Path:
    return write_video(path, tiny_frames(t, seed=seed), fps=10)


def write_image(path: Path, image: np.ndarray) -> Path:
    """PNG/JPEG/BMP through FFmpeg's image2 muxer (no imaging library needed)."""
    codec, pix_fmt = {".png": ("png", "rgb24"), ".jpg": ("mjpeg", "yuvj420p"), ".jpeg": ("mjpeg", "yuvj420p"),
                      ".bmp": ("bmp", "bgr24")}[path.suffix.lower()]
    with av.open(str(path), "w", format="image2") as container:
        stream = container.add_stream(codec, rate=1)
        stream.height, stream.width = image.shape[:2]
        stream.pix_fmt = pix_fmt
        container.mux(stream.encode(av.VideoFrame.from_ndarray(image, format="rgb24")))
        container.mux(stream.encode(None))
    return path


# ---------------------------------------------------------------------------------------------- bad files


def _faststart_copy(src: Path, dst: Path) -> Path:
    """Remux with the index (moov) first: then a truncated file still opens and only a scan sees the loss."""
    with av.open(str(src)) as inp, av.open(str(dst), "w", options={"movflags": "faststart"}) as out:
        stream = out.add_stream_from_template(inp.streams.video[0])
        for packet in inp.demux(inp.streams.video[0]):
            if packet.dts is not None:
                packet.stream = stream
                out.mux(packet)
    return dst


def make_bad(kind: str, folder: Path) -> Path:
    if kind == "random_bytes":
        path = folder / "random_bytes.mp4"
        path.write_bytes(np.random.default_rng(1).bytes(4000))
    elif kind == "empty":
        path = folder / "empty.mp4"
        path.write_bytes(b"")
    elif kind == "truncated":
        good = tiny_video(folder / "whole.mp4", t=20)
        path = folder / "truncated.mp4"
        path.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
        good.unlink()
    elif kind == "truncated_faststart":
        good = _faststart_copy(tiny_video(folder / "whole.mp4", t=20), folder / "whole_fs.mp4")
        path = folder / "truncated_faststart.mp4"
        path.write_bytes(good.read_bytes()[: good.stat().st_size * 2 // 3])
    elif kind == "zero_frames":
        path = folder / "zero_frames.avi"
        with av.open(str(path), "w") as container:
            stream = container.add_stream("libx264", rate=10)
            stream.width, stream.height, stream.pix_fmt = 32, 32, "yuv420p"
            container.start_encoding()
    elif kind == "image":
        path = write_image(folder / "still.png", tiny_frames(1)[0])
    elif kind == "text":
        path = folder / "notes.mp4"
        path.write_text("not a video\n" * 20)
    else:
        raise AssertionError(kind)
    return path


BAD_KINDS = ["random_bytes", "empty", "truncated", "truncated_faststart", "zero_frames", "image", "text"]


@pytest.mark.parametrize("kind", BAD_KINDS)
def test_bad_file_raises_video_error_naming_it(tmp_path: Path, kind: str) -> None:
    path = make_bad(kind, tmp_path)
    with pytest.raises(VideoError, match=re.escape(path.name)):
        read_video_clip(path)


def test_zero_frame_and_truncated_reasons_are_specific(tmp_path: Path) -> None:
    with pytest.raises(VideoError, match="0 frames"):
        check_video(make_bad("zero_frames", tmp_path))
    with pytest.raises(VideoError, match="truncated"):
        check_video(make_bad("truncated_faststart", tmp_path))


def test_batch_mode_skips_counts_and_reports_every_bad_file(tmp_path: Path) -> None:
    good = [tiny_video(tmp_path / f"good_{i}.mp4", seed=i) for i in range(2)]
    bad = [make_bad(kind, tmp_path) for kind in BAD_KINDS]
    missing = tmp_path / "missing_0.mp4"
    report = load_clips([good[0], *bad, missing, good[1]])
    assert isinstance(report, LoadReport)
    assert [c.path for c in report.clips] == good
    assert [p for p, _ in report.skipped] == [*bad, missing]
    for path, reason in report.skipped:
        assert path.name in reason
    assert report.n_scanned == len(good) + len(bad) + 1
    summary = report.summary(max_listed=100)
    assert f"skipped {len(bad) + 1}" in summary and all(p.name in summary for p in bad)


def test_batch_mode_raise_stops_at_first_bad_file(tmp_path: Path) -> None:
    good = tiny_video(tmp_path / "good_0.mp4")
    bad = make_bad("random_bytes", tmp_path)
    with pytest.raises(VideoError, match=bad.name):
        load_clips([good, bad], on_error="raise")
    with pytest.raises(ValueError, match="on_error"):
        load_clips([good], on_error="ignore")  # type: ignore[arg-type]


def test_min_frames_skips_short_clips_with_a_reason(tmp_path: Path) -> None:
    short, long = tiny_video(tmp_path / "short_0.mp4", t=3), tiny_video(tmp_path / "long_0.mp4", t=8)
    report = load_clips([short, long], min_frames=5)
    assert [c.clip_id for c in report.clips] == ["long_0"]
    assert "fewer than min_frames=5" in report.skipped[0][1]


# ---------------------------------------------------------------------------------------------- single video


def test_read_video_clip_probes_and_defaults_ids(tmp_path: Path) -> None:
    path = tiny_video(tmp_path / "red_rubber_ball_3.mp4", t=7)
    clip = read_video_clip(path, sensor="digit", split="train")
    assert (clip.clip_id, clip.object_id, clip.n_frames, clip.fps) == ("red_rubber_ball_3", "red_rubber_ball", 7, 10)
    assert clip.sensor == "digit" and clip.split == "train" and clip.frames_in_memory is None
    assert clip.meta["height"] == 32 and clip.meta["width"] == 48
    assert clip.frames.shape == (7, 32, 48, 3)
    assert read_video_clip(path, clip_id="x", object_id="y").object_id == "y"


def test_read_video_clip_rejects_unknown_or_owned_fields(tmp_path: Path) -> None:
    path = tiny_video(tmp_path / "a_0.mp4")
    with pytest.raises(TypeError, match="colour"):
        read_video_clip(path, colour="red")
    with pytest.raises(TypeError, match="fps"):
        read_video_clip(path, fps=30)
    with pytest.raises(FileNotFoundError, match=r"nothing_0\.mp4"):
        read_video_clip(tmp_path / "nothing_0.mp4")


# ---------------------------------------------------------------------------------------------- image folders


def test_image_folder_uses_natural_sort_order(tmp_path: Path) -> None:
    folder = tmp_path / "press_seq"
    folder.mkdir()
    for i in (1, 2, 10, 3, 21):
        image = np.full((16, 24, 3), 10 * i, np.uint8)
        write_image(folder / f"frame{i}.png", image)
    (folder / "notes.txt").write_text("ignored")
    clip = read_image_folder(folder, fps=30, sensor="mini")
    assert clip.meta["frame_files"] == ["frame1.png", "frame2.png", "frame3.png", "frame10.png", "frame21.png"]
    assert [int(f[0, 0, 0]) for f in clip.frames] == [10, 20, 30, 100, 210]
    assert clip.frames.shape == (5, 16, 24, 3) and clip.n_frames == 5 and clip.fps == 30
    assert (clip.clip_id, clip.object_id, clip.sensor) == ("press_seq", "press_seq", "mini")


def test_image_folder_mixes_formats(tmp_path: Path) -> None:
    image = np.full((16, 24, 3), 120, np.uint8)
    for name in ("f1.jpg", "f2.JPEG", "f3.bmp", "f4.png"):
        write_image(tmp_path / name, image)
    clip = read_image_folder(tmp_path, fps=10)
    assert clip.n_frames == 4
    assert np.abs(clip.frames.astype(int) - 120).max() <= 6  # JPEG is lossy (and limited-range YUV)


def test_image_folder_errors(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="no frames found"):
        read_image_folder(tmp_path, fps=10)
    write_image(tmp_path / "a1.png", np.zeros((16, 24, 3), np.uint8))
    write_image(tmp_path / "a2.png", np.zeros((18, 24, 3), np.uint8))
    with pytest.raises(ValueError, match=r"a2\.png.*a1\.png"):
        read_image_folder(tmp_path, fps=10)
    with pytest.raises(ValueError, match="fps"):
        read_image_folder(tmp_path, fps=0)
    with pytest.raises(FileNotFoundError):
        read_image_folder(tmp_path / "absent", fps=10)


# ---------------------------------------------------------------------------------------------- VTV-150K


RANKS = {
    "soft_red_ball": {"hardness": 0, "protrusion": 1, "elasticity": 2, "friction": 1},
    "wood_block": {"hardness": 2, "protrusion": 0, "elasticity": 0, "friction": 2},
}


@pytest.fixture
def vtv_root(tmp_path: Path) -> Path:
    root = tmp_path / "vtv"
    root.mkdir()
    for name in ("soft_red_ball_0.mp4", "soft_red_ball_1.mov", "wood_block_10.avi", "wood_block_2.mp4",
                 "mystery_thing_0.mp4"):
        tiny_video(root / name)
    tiny_video(root / "noindex.mp4")  # does not follow <object>_<k>
    (root / "README.txt").write_text("not a video")
    return root


def _write_csv(path: Path, rows: dict[str, dict[str, object]]) -> Path:
    lines = ["object,hardness,protrusion,elasticity,friction"]
    lines += [",".join([obj, *(str(r[a]) for a in ("hardness", "protrusion", "elasticity", "friction"))])
              for obj, r in rows.items()]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_vtv150k_layout_with_json_and_csv_ranks(tmp_path: Path, vtv_root: Path) -> None:
    json_ranks = tmp_path / "ranks.json"
    json_ranks.write_text(json.dumps(RANKS))
    csv_ranks = _write_csv(tmp_path / "ranks.csv", RANKS)
    from_json, from_csv = read_vtv150k(vtv_root, json_ranks), read_vtv150k(vtv_root, csv_ranks)
    assert isinstance(from_json, ClipList) and isinstance(from_json, list)
    assert [(c.clip_id, c.labels) for c in from_json] == [(c.clip_id, c.labels) for c in from_csv]
    by_id = {c.clip_id: c for c in from_json}
    # Natural order: wood_block_2 before wood_block_10; objects split at the last underscore.
    assert list(by_id) == ["mystery_thing_0", "soft_red_ball_0", "soft_red_ball_1", "wood_block_2", "wood_block_10"]
    assert by_id["soft_red_ball_1"].object_id == "soft_red_ball"
    assert by_id["soft_red_ball_1"].labels == {"vtv150k": RANKS["soft_red_ball"]}
    assert by_id["wood_block_10"].object_id == "wood_block" and by_id["wood_block_10"].source == "vtv150k"
    # Unranked object: kept, marked and counted, not dropped.
    assert by_id["mystery_thing_0"].labels == {} and by_id["mystery_thing_0"].split == "unlabelled"
    report = from_json.report
    assert report.unlabelled == 1 and report.unlabelled_objects == ["mystery_thing"]
    assert [(p.name, "<object>_<k>" in why) for p, why in report.skipped] == [("noindex.mp4", True)]


@pytest.mark.parametrize(("bad", "field"),
                         [(3, "friction"), ("high", "friction"), (1.5, "friction"), (None, "friction")])
def test_vtv150k_bad_rank_names_file_object_and_field(tmp_path: Path, vtv_root: Path, bad: object, field: str) -> None:
    ranks = json.loads(json.dumps(RANKS))
    ranks["wood_block"][field] = bad
    path = tmp_path / "ranks.json"
    path.write_text(json.dumps(ranks))
    with pytest.raises(ValueError, match=rf"ranks\.json.*'wood_block'.*'{field}'"):
        read_vtv150k(vtv_root, path)


def test_vtv150k_csv_problems(tmp_path: Path, vtv_root: Path) -> None:
    bad = _write_csv(tmp_path / "bad.csv", {"wood_block": {**RANKS["wood_block"], "hardness": "hard"}})
    with pytest.raises(ValueError, match=r"bad\.csv.*'wood_block'.*'hardness'"):
        read_vtv150k(vtv_root, bad)
    header = tmp_path / "header.csv"
    header.write_text("object,hardness,protrusion,elasticity\nwood_block,1,1,1\n")
    with pytest.raises(ValueError, match="friction"):
        read_vtv150k(vtv_root, header)
    with pytest.raises(ValueError, match=r"\.yaml"):
        (tmp_path / "ranks.yaml").write_text("x: 1")
        read_vtv150k(vtv_root, tmp_path / "ranks.yaml")


def test_vtv150k_bad_video_is_reported(tmp_path: Path, vtv_root: Path) -> None:
    (vtv_root / "wood_block_3.mp4").write_bytes(b"\x00" * 100)
    clips = read_vtv150k(vtv_root, RANKS)
    assert "wood_block_3.mp4" in [p.name for p, _ in clips.report.skipped]
    with pytest.raises(VideoError, match=r"noindex\.mp4"):  # strict mode: a stray name is an error too
        read_vtv150k(vtv_root, RANKS, on_error="raise")
    (vtv_root / "noindex.mp4").unlink()
    with pytest.raises(VideoError, match=r"wood_block_3\.mp4"):
        read_vtv150k(vtv_root, RANKS, on_error="raise")


# ---------------------------------------------------------------------------------------------- DynTAC-Sim


@pytest.fixture(scope="module")
def sim_root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from tacreasoner.sim.generate import generate_dataset

    root = tmp_path_factory.mktemp("sim")
    generate_dataset(root, n_objects=2, repeats=1, sensors=["mini"], workers=1)
    return root


def test_sim_dataset_carries_ground_truth(sim_root: Path) -> None:
    from tacreasoner.sim.generate import read_manifest

    records = read_manifest(sim_root)
    clips = read_sim_dataset(sim_root)
    assert len(clips) == len(records) == 2 and not clips.report.skipped
    for clip, rec in zip(clips, records, strict=True):
        assert clip.source == "sim" and clip.sensor == "mini" and clip.object_id == rec["object"]
        assert clip.labels == rec["labels"] and set(clip.labels) >= {"vtv150k", "physiclear"}
        assert clip.phases == rec["frames"]["phase"] and len(clip.phases) == clip.n_frames == rec["n_frames"]
        assert clip.action == rec["action"] and clip.object_name == rec["object_name"]
        assert clip.material == rec["material"]["material"] and clip.category == rec["category"]
        assert len(clip.meta["ground_truth"]["normal_force"]) == clip.n_frames
    assert clips[0].frames.shape[0] == clips[0].n_frames
    assert read_sim_dataset(sim_root / "manifest.jsonl")[0].clip_id == clips[0].clip_id


def test_sim_dataset_reports_missing_and_broken_videos(sim_root: Path, tmp_path: Path) -> None:
    import shutil

    copy = tmp_path / "sim"
    shutil.copytree(sim_root, copy)
    videos = sorted(copy.glob("clips/*/*.mp4"))
    videos[0].unlink()
    videos[1].write_bytes(b"junk")
    clips = read_sim_dataset(copy)
    assert len(clips) == 0 and sorted(p.name for p, _ in clips.report.skipped) == sorted(v.name for v in videos)
    with pytest.raises((FileNotFoundError, VideoError)):
        read_sim_dataset(copy, on_error="raise")


# ---------------------------------------------------------------------------------------------- PhysiCLeAR


def _fake_physiclear(root: Path) -> Path:
    (root / "videos").mkdir(parents=True)
    for name in ("sponge_0", "sponge_1", "spoon_0", "rock_0"):
        tiny_video(root / "videos" / f"{name}.mov")
    labels = {"objects": {
        "sponge": {"split": "train", "name": "a sponge", "hardness": 0, "roughness": 2, "bumpiness": 1,
                   "material": "foam", "videos": ["videos/sponge_0.mov", "videos/sponge_1.mov", "videos/sponge_2.mov"]},
        "spoon": {"split": "val", "name": "a spoon", "hardness": 2, "roughness": 0, "bumpiness": 0,
                  "videos": ["videos/spoon_0.mov"]},
        "rock": {"split": "unlabeled", "videos": ["videos/rock_0.mov"]},
    }}
    (root / "labels.json").write_text(json.dumps(labels))
    return root


def test_physiclear_layout_on_a_small_copy(tmp_path: Path) -> None:
    root = _fake_physiclear(tmp_path / "pc")
    clips = read_physiclear(root)
    by_id = {c.clip_id: c for c in clips}
    assert set(by_id) == {"sponge_0", "sponge_1", "spoon_0", "rock_0"}
    sponge = by_id["sponge_1"]
    assert sponge.labels == {"physiclear": {"hardness": 0, "roughness": 2, "bumpiness": 1}}
    assert (sponge.object_id, sponge.object_name, sponge.material, sponge.split) == ("sponge", "a sponge", "foam",
                                                                                     "train")
    assert (sponge.source, sponge.sensor) == ("physiclear", "mini")
    assert by_id["rock_0"].split == "unlabelled" and by_id["rock_0"].labels == {}
    report = clips.report
    assert report.unlabelled == 1 and report.unlabelled_objects == ["rock"]
    assert [p.name for p, _ in report.skipped] == ["sponge_2.mov"]  # listed but missing: counted, not a crash
    with pytest.raises(FileNotFoundError, match=r"sponge_2\.mov"):
        read_physiclear(root, on_error="raise")


def test_physiclear_bad_rank_names_object_and_field(tmp_path: Path) -> None:
    root = _fake_physiclear(tmp_path / "pc")
    labels = json.loads((root / "labels.json").read_text())
    labels["objects"]["spoon"]["roughness"] = 5
    (root / "labels.json").write_text(json.dumps(labels))
    with pytest.raises(ValueError, match=r"labels\.json.*'spoon'.*'roughness'"):
        read_physiclear(root)


def test_default_physiclear_dir_prefers_the_environment(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    root = _fake_physiclear(tmp_path / "pc")
    monkeypatch.setenv("TACREASONER_PHYSICLEAR", str(root))
    assert default_physiclear_dir() == root
    assert len(read_physiclear()) == 4
    monkeypatch.setenv("TACREASONER_PHYSICLEAR", str(tmp_path / "absent"))
    assert default_physiclear_dir() != tmp_path / "absent"


@pytest.mark.skipif(not (PHYSICLEAR / "labels.json").is_file(), reason="PhysiCLeAR not present next to the checkout")
def test_real_physiclear_loads_with_object_level_splits() -> None:
    labels = json.loads((PHYSICLEAR / "labels.json").read_text())["objects"]
    clips = read_physiclear(PHYSICLEAR)
    assert not clips.report.skipped
    assert len(clips) == sum(len(o["videos"]) for o in labels.values())
    assert {c.split for c in clips} == {"train", "val", "unlabelled"}
    check_no_leakage((c.split, c.object_id) for c in clips)
    labelled = {obj for obj, o in labels.items() if o["split"] in ("train", "val")}
    assert {c.object_id for c in clips if c.labels} == labelled
    for clip in clips:
        assert isinstance(clip, TactileClip) and clip.sensor == "mini" and clip.fps in (10.0, 25.0)
        if clip.split == "unlabelled":
            assert clip.labels == {}
        else:
            ranks = clip.labels["physiclear"]
            assert set(ranks) == {"hardness", "roughness", "bumpiness"} and set(ranks.values()) <= {0, 1, 2}
            assert clip.object_name == labels[clip.object_id]["name"]
    assert clips.report.unlabelled == sum(len(o["videos"]) for o in labels.values() if o["split"] == "unlabeled")
