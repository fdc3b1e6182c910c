"""Pixel cues on synthetic clips whose answers are known by construction."""

from __future__ import annotations

import numpy as np
import pytest

from tacreasoner.data.cues import clip_cues, detect_phases, frame_signals


def _disk_clip(radii: list[float], shift: list[float] | None = None, depth: float = 40.0) -> np.ndarray:
    """A grey background with a bright disk of the given radius per frame (0 = no contact)."""
    h, w = 240, 320
    yy, xx = np.mgrid[0:h, 0:w]
    frames = np.full((len(radii), h, w, 3), 100, np.uint8)
    for t, r in enumerate(radii):
        if r > 0:
            cx = 160 + (shift[t] if shift else 0.0)
            inside = (xx - cx) ** 2 + (yy - 120) ** 2 < r * r
            frames[t][inside] = 100 + depth
    return frames


def test_area_and_intensity_follow_the_imprint() -> None:
    frames = _disk_clip([0, 0, 20, 40, 60, 60, 40, 0])
    s = frame_signals(frames)
    assert s.area[0] == 0 and s.area[1] == 0
    assert s.area[2] < s.area[3] < s.area[4]
    assert s.area[4] == pytest.approx(np.pi * 60**2 / (240 * 320), rel=0.2)  # smoothing dilates the edge a little
    assert np.argmax(s.intensity) in (4, 5)
    assert s.diff_energy[5] < 0.05 * s.diff_energy[4]


def test_centroid_tracks_a_moving_imprint() -> None:
    frames = _disk_clip([40] * 6, shift=[-40, -24, -8, 8, 24, 40])
    s = frame_signals(frames, background=np.full((240, 320, 3), 100, np.uint8))
    assert np.allclose(np.diff(s.centroid[:, 0]), 16.0, atol=1.5)
    assert np.allclose(s.centroid[:, 1], 120.0, atol=1.5)


def test_detect_phases_on_a_press_hold_release_curve() -> None:
    radii = [0] * 5 + [12, 24, 36, 48, 60] + [60] * 10 + [40, 20] + [0] * 5
    phases = detect_phases(frame_signals(_disk_clip(radii)), action="slide")
    assert list(phases[:5]) == ["no_contact"] * 5
    assert phases[6] == "press"
    assert "hold" in phases and "slide" in phases
    assert phases[-6] in ("release", "no_contact") and phases[-1] == "no_contact"
    order = [p for i, p in enumerate(phases) if i == 0 or p != phases[i - 1]]
    assert order == ["no_contact", "press", "hold", "slide", "release", "no_contact"]


def test_no_contact_clip_has_no_phases_and_zero_cues() -> None:
    frames = _disk_clip([0] * 10)
    s = frame_signals(frames)
    assert set(detect_phases(s)) == {"no_contact"}
    cues = clip_cues(s, detect_phases(s))
    assert cues["max_area"] == 0 and cues["creep"] == 0 and cues["residual"] == 0
    assert all(np.isfinite(v) for v in cues.values())


def test_creep_and_residual_cues() -> None:
    radii = [0, 0, 24, 48, 48, 52, 56, 60, 60, 36, 36, 36, 0]
    phases = np.asarray(["no_contact"] * 2 + ["press"] * 2 + ["hold"] * 4 + ["slide"] + ["release"] * 3
                        + ["no_contact"], dtype=object)
    cues = clip_cues(frame_signals(_disk_clip(radii)), phases)
    assert cues["creep"] > 0.2
    assert cues["residual"] == pytest.approx((36 / 60) ** 2, rel=0.15)


def test_bad_shape_is_a_clear_error() -> None:
    with pytest.raises(ValueError, match="T×H×W×3"):
        frame_signals(np.zeros((4, 10, 10), np.uint8))
    with pytest.raises(ValueError, match="no frames"):
        frame_signals(np.zeros((0, 10, 10, 3), np.uint8), np.zeros((10, 10, 3), np.uint8))


def test_chunked_signals_equal_one_whole_clip_chunk_bit_for_bit(monkeypatch: pytest.MonkeyPatch) -> None:
    """frame_signals measures a few frames at a time for speed; chunk borders must not show (frame differences)."""
    import tacreasoner.data.cues as cues

    rng = np.random.default_rng(1)
    frames = _disk_clip([0, 0, 10, 25, 40, 55, 60, 60, 58, 50, 40, 30, 20, 0, 0, 0, 0, 0, 0, 0],
                        shift=list(np.linspace(0, 30, 20)))
    frames = np.clip(frames + rng.integers(-3, 4, frames.shape), 0, 255).astype(np.uint8)  # sensor noise
    chunked = frame_signals(frames)
    monkeypatch.setattr(cues, "FRAME_CHUNK", len(frames))
    whole = frame_signals(frames)
    for field in ("intensity", "area", "gradient", "texture", "bumps", "tint", "diff_energy", "centroid"):
        a, b = getattr(chunked, field), getattr(whole, field)
        assert a.dtype == b.dtype and np.array_equal(a, b, equal_nan=True), field
    assert chunked.diff_energy[8] > 0 and chunked.diff_energy[16] == whole.diff_energy[16]  # across chunk borders


def test_channel_mean_is_numpys_mean_bit_for_bit() -> None:
    from tacreasoner.data.cues import _channel_mean

    x = np.random.default_rng(0).normal(0, 50, (7, 31, 17, 3)).astype(np.float32)
    assert np.array_equal(_channel_mean(x), x.mean(axis=-1))
    assert _channel_mean(x).dtype == np.float32
