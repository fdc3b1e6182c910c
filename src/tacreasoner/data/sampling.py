"""Frame sampling, background subtraction, resizing and phase detection for tactile clips.

Sampling methods (all return k sorted indices; repeats only when the clip has fewer than k frames):

* ``uniform``: evenly spaced over the clip, first and last frame included (VTV-LLM's 16 frames).
* ``salient``: the k frames that change most from the previous frame (Octopi), in temporal order.
* ``contact``: the k frames of strongest contact (most gel changed against the first, untouched frame), in
  temporal order: the frames where the imprint and its texture show best.
* ``phase``: k spread over the contact phases present (press, hold, slide/rotate, release, …) in
  proportion to their length with at least one each, plus at most one no-contact frame (the
  reference), so a short release or hold is never missed.
"""

from __future__ import annotations

from collections.abc import Sequence

import av
import numpy as np
from av.video.reformatter import VideoReformatter
from scipy import ndimage

from tacreasoner.data.cues import CONTACT_THRESHOLD, phases_from_level, smoothed_difference

__all__ = [
    "CONTACT_PHASES",
    "SAMPLING_METHODS",
    "background_frame",
    "contact_level",
    "detect_contact_phases",
    "frame_motion",
    "resize_keep_aspect",
    "sample_indices",
    "subtract_background",
]

SAMPLING_METHODS = ("uniform", "salient", "phase", "contact")
CONTACT_PHASES = ("press", "hold", "slide", "rotate", "dynamic", "release")
"""Known phase names in temporal order; any other label except ``no_contact`` also counts as contact."""
NO_CONTACT = "no_contact"
RESIZE_MODES = ("fit", "crop")


# ------------------------------------------------------------------------------------------- sampling


def sample_indices(n_frames: int, k: int, method: str = "uniform", *, frames: np.ndarray | None = None,
                   phases: Sequence[str] | np.ndarray | None = None, seed: int | None = None) -> np.ndarray:
    """k sorted frame indices (int64) chosen by ``method``; see the module docstring.

    ``frames`` is needed by ``salient`` and ``contact``, ``phases`` (one label per frame) by ``phase``. With
    ``seed`` set, ``uniform`` and ``phase`` draw one random frame per equal segment instead of the segment's
    fixed position (training-time augmentation); ``salient`` and ``contact`` are deterministic either way.
    """
    n_frames, k = _positive_int(n_frames, "n_frames"), _positive_int(k, "k")
    if method not in SAMPLING_METHODS:
        raise ValueError(f"unknown sampling method {method!r}; choose from {', '.join(SAMPLING_METHODS)}")
    if method in ("salient", "contact") and frames is None:
        raise ValueError(f"method {method!r} needs frames= (T×H×W×3) to measure {method}")
    if method == "phase" and phases is None:
        raise ValueError("method 'phase' needs phases= (one label per frame; see detect_contact_phases)")
    if frames is not None and len(frames) != n_frames:
        raise ValueError(f"frames has {len(frames)} frames but n_frames is {n_frames}")
    if phases is not None and len(phases) != n_frames:
        raise ValueError(f"phases has {len(phases)} labels but n_frames is {n_frames}")
    if n_frames <= k:
        # Every frame at least once (evenly repeated): nothing to choose between.
        return np.linspace(0, n_frames - 1, k).round().astype(np.int64)
    rng = np.random.default_rng(seed) if seed is not None else None
    if method == "uniform":
        if rng is None:
            return np.linspace(0, n_frames - 1, k, dtype=np.int64)
        return _spread(np.arange(n_frames), k, rng)
    if method == "salient":
        motion = frame_motion(np.asarray(frames))
        # Stable sort on −motion: ties go to the earlier frame, so the choice is reproducible.
        return np.sort(np.argsort(-motion, kind="stable")[:k]).astype(np.int64)
    if method == "contact":
        level = contact_level(np.asarray(frames))
        return np.sort(np.argsort(-level, kind="stable")[:k]).astype(np.int64)
    return _phase_indices(np.asarray(phases, dtype=object), k, rng)


def _positive_int(value: object, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
    return int(value)


def _spread(candidates: np.ndarray, k: int, rng: np.random.Generator | None) -> np.ndarray:
    """k distinct entries of a sorted array (len ≥ k): one per equal segment, its centre or a random one."""
    m = len(candidates)
    edges = (np.arange(k + 1) * m) // k
    if rng is None:
        picks = (edges[:-1] + edges[1:] - 1) // 2
    else:
        picks = edges[:-1] + (rng.random(k) * (edges[1:] - edges[:-1])).astype(np.int64)
    return candidates[picks].astype(np.int64)


def frame_motion(frames: np.ndarray, stride: int = 2) -> np.ndarray:
    """Mean |I_t − I_{t−1}| per frame (0 for the first), on a 1/stride grid: cheap and noise-robust."""
    if frames.ndim != 4:
        raise ValueError(f"frames must be T×H×W×C, got shape {frames.shape}")
    small = frames[:, ::stride, ::stride].astype(np.int16 if frames.dtype == np.uint8 else np.float32)
    motion = np.zeros(len(frames), np.float64)
    if len(frames) > 1:
        motion[1:] = np.abs(np.diff(small, axis=0)).mean(axis=(1, 2, 3))
    return motion


def _phase_indices(phases: np.ndarray, k: int, rng: np.random.Generator | None) -> np.ndarray:
    n = len(phases)
    labels = [p for p in dict.fromkeys(phases.tolist()) if p != NO_CONTACT]  # contact phases, first-seen order
    if not labels:
        return sample_indices(n, k, "uniform", seed=None if rng is None else int(rng.integers(2**31)))
    members = {p: np.flatnonzero(phases == p) for p in labels}
    if len(labels) > k:
        # Too few slots for one each: keep the k longest phases.
        labels = sorted(sorted(labels, key=lambda p: -len(members[p]))[:k], key=lambda p: members[p][0])
    no_contact = np.flatnonzero(phases == NO_CONTACT)
    slots = k
    extra: list[int] = []
    if no_contact.size and k > len(labels):
        extra.append(int(no_contact[0]))  # the background reference
        slots -= 1
    counts = _allocate([len(members[p]) for p in labels], slots)
    picks = [_spread(members[p], c, rng) for p, c in zip(labels, counts, strict=True)]
    out = np.sort(np.concatenate([np.asarray(extra, np.int64), *picks]))
    if len(out) < k:  # contact frames ran out (tiny clip with a long no-contact part): top up
        spare = np.setdiff1d(np.arange(n), out)
        out = np.sort(np.concatenate([out, _spread(spare, k - len(out), rng)]))
    return out


def _allocate(sizes: list[int], slots: int) -> list[int]:
    """One slot each, the rest proportional to size (largest remainder), never more than a phase holds."""
    counts = [1] * len(sizes)
    left = min(slots, sum(sizes)) - len(sizes)
    while left > 0:
        room = [s - c for s, c in zip(sizes, counts, strict=True)]
        open_ = [i for i, r in enumerate(room) if r > 0]
        total = sum(sizes[i] for i in open_)
        share = {i: left * sizes[i] / total for i in open_}
        given = 0
        for i in open_:
            add = min(int(share[i]), room[i])
            counts[i] += add
            given += add
        left -= given
        for i in sorted(open_, key=lambda i: share[i] - int(share[i]), reverse=True):
            if left == 0:
                break
            if counts[i] < sizes[i]:
                counts[i] += 1
                left -= 1
    return counts


# ------------------------------------------------------------------------------------------- background


def background_frame(frames: np.ndarray, phases: Sequence[str] | np.ndarray | None = None) -> np.ndarray:
    """The first no-contact frame (the gel at rest); the first frame when phases are unknown."""
    if len(frames) == 0:
        raise ValueError("no frames: cannot pick a background frame")
    if phases is not None:
        if len(phases) != len(frames):
            raise ValueError(f"phases has {len(phases)} labels but there are {len(frames)} frames")
        for i, phase in enumerate(phases):
            if phase == NO_CONTACT:
                return frames[i]
    return frames[0]


def subtract_background(frames: np.ndarray, background: np.ndarray | None = None) -> np.ndarray:
    """(I − B)/255 + 0.5 as float32: 0.5 where nothing touches, so the imprint stands out from the
    sensor's own colour pattern. B defaults to the first frame. Works on one frame or a clip."""
    frames = np.asarray(frames)
    if background is None:
        background = frames[0] if frames.ndim == 4 else frames
    background = np.asarray(background)
    if background.shape != frames.shape[-3:]:
        raise ValueError(f"background shape {background.shape} does not match frame shape {frames.shape[-3:]}")
    out = frames.astype(np.float32)
    out -= background.astype(np.float32)
    out /= 255.0
    out += 0.5
    return out


# ------------------------------------------------------------------------------------------- resizing


def resize_keep_aspect(frames: np.ndarray, height: int, width: int, mode: str = "fit",
                       interpolation: str = "AREA") -> np.ndarray:
    """Resize to exactly height×width without distorting the imprint's shape.

    ``fit`` scales the whole frame inside the target and pads the border by repeating the edge
    pixels (the gel's own background colour, not black bars a model could read as contact);
    ``crop`` scales to cover the target and cuts the centre. Input T×H×W×3 (or one H×W×3 frame)
    uint8; output has the same rank. Resampling is FFmpeg's (``interpolation``: AREA, BILINEAR, …).
    """
    height, width = _positive_int(height, "height"), _positive_int(width, "width")
    if mode not in RESIZE_MODES:
        raise ValueError(f"unknown resize mode {mode!r}; choose from {', '.join(RESIZE_MODES)}")
    frames = np.asarray(frames)
    single = frames.ndim == 3
    clip = frames[None] if single else frames
    if clip.ndim != 4 or clip.shape[-1] != 3 or clip.dtype != np.uint8:
        raise ValueError(f"frames must be uint8 T×H×W×3 or H×W×3, got {frames.dtype} {frames.shape}")
    h, w = clip.shape[1:3]
    scale = min(height / h, width / w) if mode == "fit" else max(height / h, width / w)
    new_h, new_w = max(1, round(h * scale)), max(1, round(w * scale))
    if mode == "fit":
        new_h, new_w = min(new_h, height), min(new_w, width)
    else:
        new_h, new_w = max(new_h, height), max(new_w, width)
    if (new_h, new_w) == (h, w):
        scaled = clip
    else:
        resizer = VideoReformatter()  # one swscale context for all frames (a new one per frame cost 7x)
        scaled = np.stack([
            resizer.reformat(av.VideoFrame.from_ndarray(np.ascontiguousarray(f), format="rgb24"),
                             width=new_w, height=new_h, interpolation=interpolation).to_ndarray()
            for f in clip
        ])
    if mode == "fit":
        top, left = (height - new_h) // 2, (width - new_w) // 2
        out = np.pad(scaled, ((0, 0), (top, height - new_h - top), (left, width - new_w - left), (0, 0)),
                     mode="edge")
    else:
        top, left = (new_h - height) // 2, (new_w - width) // 2
        out = np.ascontiguousarray(scaled[:, top:top + height, left:left + width])
    return out[0] if single else out


# ------------------------------------------------------------------------------------------- phases


def contact_level(frames: np.ndarray, background: np.ndarray | None = None, stride: int = 2) -> np.ndarray:
    """Per-frame contact strength: mean over the image of how far |I − B| rises above the contact
    threshold (grey levels × percent of the image).

    Real GelSight video has codec noise that keeps the plain mean |I − B| near 0.5–1 grey levels
    with nothing touching (it even steps at keyframes), swamping a light touch; only pixels that
    clearly changed count here, so no contact reads as 0.
    """
    _, diff = smoothed_difference(frames, background, stride)
    magnitude = ndimage.uniform_filter(np.abs(diff).mean(axis=-1), size=(1, 5, 5))
    return np.maximum(magnitude - CONTACT_THRESHOLD, 0.0).mean(axis=(1, 2)) * 100.0


def detect_contact_phases(frames: np.ndarray, action: str = "dynamic", *, background: np.ndarray | None = None,
                          release_level: float = 0.5) -> np.ndarray:
    """Per-frame phases of a real clip: no_contact, press, hold, <action>, release (object array).

    :func:`tacreasoner.data.cues.detect_phases` applied to :func:`contact_level`. Release starts
    where contact last falls below ``release_level`` of its peak (hand-held contacts fade while
    still moving). The background defaults to the first frame, so the clip must start untouched.
    Use ``action="rotate"`` for PhysiCLeAR (press, then rotate).
    """
    return phases_from_level(contact_level(frames, background), action, release_level=release_level)
