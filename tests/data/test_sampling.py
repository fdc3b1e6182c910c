"""Frame sampling, background subtraction, aspect-preserving resize and the real-video phase detector."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tacreasoner.data.sampling import (
    SAMPLING_METHODS,
    background_frame,
    contact_level,
    detect_contact_phases,
    resize_keep_aspect,
    sample_indices,
    subtract_background,
)

PHYSICLEAR = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "physiclear"

PHASES = ["no_contact"] * 10 + ["press"] * 30 + ["hold"] * 4 + ["rotate"] * 60 + ["release"] * 2 + ["no_contact"] * 20


# ---------------------------------------------------------------------------------------------- uniform


def test_uniform_is_evenly_spaced_with_both_ends() -> None:
    idx = sample_indices(126, 16)
    assert idx.dtype == np.int64 and len(idx) == 16
    assert idx[0] == 0 and idx[-1] == 125
    assert np.all(np.diff(idx) >= 8) and np.all(np.diff(idx) <= 9)


def test_short_clips_repeat_frames_and_cover_all_of_them() -> None:
    for method, kw in (("uniform", {}), ("salient", {"frames": np.zeros((5, 4, 4, 3), np.uint8)}),
                       ("phase", {"phases": ["no_contact", "press", "hold", "slide", "release"]})):
        idx = sample_indices(5, 16, method, **kw)
        assert len(idx) == 16 and np.all(np.diff(idx) >= 0) and set(idx) == set(range(5))


def test_seeded_uniform_jitters_reproducibly() -> None:
    a, b, c = sample_indices(126, 16, seed=1), sample_indices(126, 16, seed=1), sample_indices(126, 16, seed=2)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert len(np.unique(a)) == 16 and np.all(np.diff(a) > 0)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"n_frames": 10, "k": 0}, "k must be"),
    ({"n_frames": 0, "k": 4}, "n_frames must be"),
    ({"n_frames": 10, "k": 2.5}, "k must be"),
    ({"n_frames": 10, "k": 4, "method": "random"}, "uniform, salient, phase"),
    ({"n_frames": 10, "k": 4, "method": "salient"}, "needs frames"),
    ({"n_frames": 10, "k": 4, "method": "phase"}, "needs phases"),
    ({"n_frames": 10, "k": 4, "method": "phase", "phases": ["press"] * 9}, "9 labels"),
])
def test_argument_validation(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        sample_indices(**kwargs)


# ---------------------------------------------------------------------------------------------- salient


def test_salient_picks_the_frames_with_motion_in_temporal_order() -> None:
    rng = np.random.default_rng(0)
    frames = np.repeat(rng.integers(0, 255, (1, 24, 32, 3), dtype=np.uint8), 40, axis=0)
    moving = [31, 7, 22, 15]
    for t in sorted(moving):
        frames[t:] = rng.integers(0, 255, (24, 32, 3), dtype=np.uint8)  # a change at t, then still
    idx = sample_indices(40, 4, "salient", frames=frames)
    assert list(idx) == sorted(moving)


# ---------------------------------------------------------------------------------------------- phase-aware


def test_phase_aware_covers_every_contact_phase_and_one_background_frame() -> None:
    idx = sample_indices(len(PHASES), 16, "phase", phases=PHASES)
    picked = [PHASES[i] for i in idx]
    assert len(idx) == 16 and np.all(np.diff(idx) > 0)
    assert set(picked) == {"no_contact", "press", "hold", "rotate", "release"}
    assert picked.count("no_contact") == 1 and idx[0] == 0  # the first no-contact frame: the background
    assert picked.count("rotate") > picked.count("press") > picked.count("hold") >= 1
    assert picked.count("release") >= 1  # 2 frames of 126, still sampled


def test_phase_aware_with_fewer_slots_than_phases_keeps_the_longest() -> None:
    picked = [PHASES[i] for i in sample_indices(len(PHASES), 2, "phase", phases=PHASES)]
    assert picked == ["press", "rotate"]


def test_phase_aware_without_contact_falls_back_to_uniform() -> None:
    assert np.array_equal(sample_indices(50, 8, "phase", phases=["no_contact"] * 50), sample_indices(50, 8))


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from(["no_contact", "press", "hold", "slide", "release"]), min_size=1, max_size=80),
       st.integers(1, 24), st.one_of(st.none(), st.integers(0, 100)))
def test_phase_aware_properties(phases: list[str], k: int, seed: int | None) -> None:
    n = len(phases)
    idx = sample_indices(n, k, "phase", phases=phases, seed=seed)
    assert len(idx) == k and np.all(np.diff(idx) >= 0) and idx.min() >= 0 and idx.max() < n
    if n >= k:
        assert len(np.unique(idx)) == k
        picked = [phases[i] for i in idx]
        contact = set(phases) - {"no_contact"}
        if k >= len(contact):
            assert contact <= set(picked)
        if contact and len([p for p in phases if p != "no_contact"]) >= k:
            assert picked.count("no_contact") <= 1


# ---------------------------------------------------------------------------------------------- background


def test_background_subtraction_values() -> None:
    bg = np.full((4, 5, 3), 100, np.uint8)
    frames = np.stack([bg, bg + 51, bg - 100])
    out = subtract_background(frames, bg)
    assert out.dtype == np.float32 and out.shape == frames.shape
    assert np.allclose(out[0], 0.5) and np.allclose(out[1], 0.7) and np.allclose(out[2], 0.5 - 100 / 255)
    assert np.allclose(subtract_background(frames[1], bg), 0.7)  # a single frame works too
    assert np.allclose(subtract_background(frames), out)  # default background: the first frame
    with pytest.raises(ValueError, match="does not match"):
        subtract_background(frames, bg[:2])


def test_background_frame_is_the_first_no_contact_frame() -> None:
    frames = np.arange(4)[:, None, None, None] * np.ones((4, 2, 2, 3), np.uint8)
    assert background_frame(frames, ["press", "hold", "no_contact", "no_contact"])[0, 0, 0] == 2
    assert background_frame(frames)[0, 0, 0] == 0
    assert background_frame(frames, ["press"] * 4)[0, 0, 0] == 0


# ---------------------------------------------------------------------------------------------- resize


@pytest.mark.parametrize("mode", ["fit", "crop"])
@pytest.mark.parametrize(("src", "dst"), [((240, 320), (224, 224)), ((320, 240), (224, 224)),
                                          ((240, 320), (120, 400)), ((240, 320), (400, 120)), ((7, 5), (9, 11))])
def test_resize_output_shape(mode: str, src: tuple[int, int], dst: tuple[int, int]) -> None:
    frames = np.random.default_rng(0).integers(0, 255, (3, *src, 3), dtype=np.uint8)
    out = resize_keep_aspect(frames, *dst, mode=mode)
    assert out.shape == (3, *dst, 3) and out.dtype == np.uint8
    assert resize_keep_aspect(frames[0], *dst, mode=mode).shape == (*dst, 3)


@pytest.mark.parametrize("interpolation", ["AREA", "BILINEAR"])
def test_resize_equals_ffmpegs_per_frame_resampling(interpolation: str) -> None:
    """The shared swscale context must resample each frame exactly as a fresh one does."""
    import av

    frames = np.random.default_rng(1).integers(0, 256, (4, 60, 80, 3), dtype=np.uint8)
    out = resize_keep_aspect(frames, 24, 32, interpolation=interpolation)
    reference = np.stack([av.VideoFrame.from_ndarray(f, format="rgb24")
                          .reformat(width=32, height=24, interpolation=interpolation).to_ndarray(format="rgb24")
                          for f in frames])
    assert np.array_equal(out, reference)


def test_fit_pads_with_the_background_colour_and_crop_keeps_the_centre() -> None:
    frame = np.zeros((240, 320, 3), np.uint8)
    frame[:] = (40, 90, 160)  # gel background
    frame[100:140, 140:180] = 255  # an imprint in the middle
    fit = resize_keep_aspect(frame, 224, 224, mode="fit")
    assert np.all(fit[0] == (40, 90, 160)) and np.all(fit[-1] == (40, 90, 160))  # padded rows: gel colour
    assert fit[112, 112].min() > 200  # imprint still centred
    crop = resize_keep_aspect(frame, 224, 224, mode="crop")
    assert crop[112, 112].min() > 200 and np.all(crop[:, 0] == (40, 90, 160))
    with pytest.raises(ValueError, match="fit, crop"):
        resize_keep_aspect(frame, 10, 10, mode="stretch")


# ---------------------------------------------------------------------------------------------- phases


def _press_rotate_clip(noise: float = 1.5) -> tuple[np.ndarray, list[str]]:
    """A disk imprint that grows, holds while turning, and lifts; codec-like noise on every frame."""
    rng = np.random.default_rng(0)
    radii = [0] * 10 + list(range(4, 44, 4)) + [40] * 20 + [30, 20, 10] + [0] * 8
    yy, xx = np.mgrid[0:96, 0:128]
    frames = np.full((len(radii), 96, 128, 3), 110.0)
    for t, r in enumerate(radii):
        frames[t][(xx - 64) ** 2 + (yy - 48) ** 2 < r * r] += 30
    frames += rng.normal(0, noise, frames.shape)
    truth = ["no_contact"] * 10 + ["press"] * 10 + ["steady"] * 20 + ["release"] * 3 + ["no_contact"] * 8
    return np.clip(frames, 0, 255).astype(np.uint8), truth


def test_detect_contact_phases_on_a_noisy_synthetic_clip() -> None:
    frames, truth = _press_rotate_clip()
    phases = detect_contact_phases(frames, action="rotate")
    order = [p for i, p in enumerate(phases) if i == 0 or p != phases[i - 1]]
    assert order == ["no_contact", "press", "hold", "rotate", "release", "no_contact"]
    contact = np.array([p != "no_contact" for p in phases])
    assert (contact == np.array([p != "no_contact" for p in truth])).mean() > 0.95
    assert contact_level(frames[:10]).max() == 0.0  # sensor noise alone is not contact


def test_detect_contact_phases_without_contact() -> None:
    frames = np.random.default_rng(1).normal(120, 2, (20, 48, 64, 3)).clip(0, 255).astype(np.uint8)
    assert set(detect_contact_phases(frames)) == {"no_contact"}


@pytest.mark.skipif(not (PHYSICLEAR / "videos" / "apple_1.mov").is_file(), reason="PhysiCLeAR not present")
def test_detect_contact_phases_on_a_real_physiclear_clip() -> None:
    from tacreasoner.video_io import read_video

    frames, _ = read_video(PHYSICLEAR / "videos" / "apple_1.mov")
    phases = list(detect_contact_phases(frames, action="rotate"))
    order = [p for i, p in enumerate(phases) if i == 0 or p != phases[i - 1]]
    assert order[:5] == ["no_contact", "press", "hold", "rotate", "release"]
    assert phases[:20] == ["no_contact"] * 20  # the plain mean |I − B| would call these contact (codec noise)
    for method in SAMPLING_METHODS:
        idx = sample_indices(len(frames), 16, method, frames=frames, phases=phases)
        assert len(idx) == 16
