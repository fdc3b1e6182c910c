"""Dataset generation: determinism, manifest content, resume."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from tacreasoner.sim.generate import generate_dataset, read_manifest
from tacreasoner.sim.protocol import PHASES
from tacreasoner.video_io import read_video


def _files(root: Path) -> dict[str, bytes]:
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def test_same_seed_gives_identical_bytes_regardless_of_workers(tmp_path: Path) -> None:
    generate_dataset(tmp_path / "a", n_objects=2, repeats=2, sensors=["mini"], seed=7, workers=1)
    generate_dataset(tmp_path / "b", n_objects=2, repeats=2, sensors=["mini"], seed=7, workers=2)
    a, b = _files(tmp_path / "a"), _files(tmp_path / "b")
    assert a.keys() == b.keys()
    assert any(k.endswith(".mp4") for k in a)
    assert all(a[k] == b[k] for k in a)


def test_different_seed_gives_different_clips(tmp_path: Path) -> None:
    generate_dataset(tmp_path / "a", n_objects=1, repeats=1, sensors=["mini"], seed=1, workers=1)
    generate_dataset(tmp_path / "b", n_objects=1, repeats=1, sensors=["mini"], seed=2, workers=1)
    mp4 = "clips/mini/apple_real_0.mp4"
    assert (tmp_path / "a" / mp4).read_bytes() != (tmp_path / "b" / mp4).read_bytes()


def test_manifest_holds_labels_parameters_and_per_frame_ground_truth(tmp_path: Path) -> None:
    generate_dataset(tmp_path, n_objects=2, repeats=2, sensors=["mini", "digit"], seed=0, workers=2)
    records = read_manifest(tmp_path)
    assert len(records) == 2 * 2 * 2
    assert {r["action"] for r in records} == {"slide", "rotate"}
    for rec in records:
        frames, fps = read_video(tmp_path / rec["video"])
        assert frames.shape == (rec["n_frames"], rec["height"], rec["width"], 3)
        assert fps == pytest.approx(rec["fps"])
        gt = rec["frames"]
        for key in ("phase", "normal_force", "shear_x", "shear_y", "torque", "indent_gel", "indent_object",
                    "contact_area", "slip"):
            assert len(gt[key]) == rec["n_frames"], key
        assert set(gt["phase"]) <= set(PHASES)
        assert gt["phase"][0] == "no_contact" and gt["phase"][-1] == "no_contact"
        assert set(rec["labels"]["vtv150k"]) == {"hardness", "protrusion", "elasticity", "friction"}
        assert set(rec["labels"]["physiclear"]) == {"hardness", "roughness", "bumpiness"}
        assert rec["material"]["e0_mpa"] > 0
        assert max(gt["normal_force"]) > 2.5
    digit = [r for r in records if r["sensor"] == "digit"]
    assert digit[0]["height"] == 320 and digit[0]["width"] == 240 and digit[0]["fps"] == 30


def test_interrupted_run_resumes_without_redoing_finished_clips(tmp_path: Path) -> None:
    generate_dataset(tmp_path, n_objects=2, repeats=1, sensors=["mini"], seed=0, workers=1)
    done = tmp_path / "clips/mini/apple_real_0.mp4"
    stamp = done.stat().st_mtime_ns
    # Simulate a crash: one clip's sidecar and video never got written, the manifest is missing.
    (tmp_path / "clips/mini/apple_fake_0.json").unlink()
    (tmp_path / "clips/mini/apple_fake_0.mp4").unlink()
    (tmp_path / "manifest.jsonl").unlink()
    calls: list[tuple[int, int]] = []
    generate_dataset(tmp_path, n_objects=2, repeats=1, sensors=["mini"], seed=0, workers=1,
                     progress=lambda d, t: calls.append((d, t)))
    assert calls[0] == (1, 2) and calls[-1] == (2, 2)
    assert done.stat().st_mtime_ns == stamp
    assert len(read_manifest(tmp_path)) == 2


def test_other_settings_in_same_directory_are_refused(tmp_path: Path) -> None:
    generate_dataset(tmp_path, n_objects=1, repeats=1, sensors=["mini"], seed=0, workers=1)
    with pytest.raises(ValueError, match="different settings"):
        generate_dataset(tmp_path, n_objects=1, repeats=1, sensors=["mini"], seed=1, workers=1)
    generate_dataset(tmp_path, n_objects=1, repeats=1, sensors=["mini"], seed=1, workers=1, overwrite=True)
    assert json.loads((tmp_path / "dataset.json").read_text())["settings"]["seed"] == 1


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"n_objects": -3}, "--objects"),
        ({"n_objects": 0}, "--objects"),
        ({"repeats": 0}, "--repeats"),
        ({"sensors": ["gelsight9000"]}, "unknown sensor"),
        ({"sensors": []}, "--sensors"),
        ({"sensors": ["mini", "mini"]}, "twice"),
    ],
)
def test_bad_arguments_raise_clear_errors(tmp_path: Path, kwargs: dict, message: str) -> None:
    args = {"n_objects": 1, "repeats": 1, "sensors": ["mini"], "seed": 0, "workers": 1} | kwargs
    with pytest.raises(ValueError, match=message):
        generate_dataset(tmp_path, **args)


def test_unwritable_output_directory(tmp_path: Path) -> None:
    blocker = tmp_path / "file.txt"
    blocker.write_text("not a directory")
    with pytest.raises(ValueError, match="cannot write"):
        generate_dataset(blocker / "sub", n_objects=1, repeats=1, sensors=["mini"], workers=1)


def test_video_first_frame_is_untouched_background(tmp_path: Path) -> None:
    generate_dataset(tmp_path, n_objects=1, repeats=1, sensors=["mini"], seed=0, workers=1)
    frames, _ = read_video(tmp_path / "clips/mini/apple_real_0.mp4")
    first, peak = frames[0].astype(np.float32), frames[len(frames) // 2].astype(np.float32)
    assert np.abs(frames[1].astype(np.float32) - first).mean() < 2.0
    assert np.abs(peak - first).mean() > 3.0
