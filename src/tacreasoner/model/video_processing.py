"""Turn a tactile clip (or raw frames, or a video file) into the encoder's input, the same way everywhere.

Training, pre-training, evaluation and serving all call :func:`preprocess_video`, so a model never
sees frames prepared differently from the ones it was trained on. Pure numpy: no torch needed.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from tacreasoner.data.clip import TactileClip
from tacreasoner.data.sampling import (
    RESIZE_MODES,
    SAMPLING_METHODS,
    background_frame,
    resize_keep_aspect,
    sample_indices,
    subtract_background,
)
from tacreasoner.fields import reject_unknown_fields

__all__ = ["BACKGROUNDS", "VideoInput", "VideoProcessingConfig", "base_sensor", "gel_rest_distance",
           "imprint_gain_from_reference", "imprint_strength", "measure_gel_image", "measure_gel_reference",
           "measure_gel_swap_above", "measure_imprint_gain", "measure_imprint_reference", "preprocess_video",
           "sensor_index", "sensor_of"]

BACKGROUNDS = ("subtract", "keep")
COLOURS = ("rgb", "magnitude")
ORIENTATIONS = ("as_is", "match")
GEL_SWAPS = ("whole", "lighting", "imprint")

VideoInput = TactileClip | np.ndarray | str | os.PathLike
"""A clip, T×H×W×3 uint8 frames, or a path to a video file."""


@dataclass
class VideoProcessingConfig:
    """How frames are chosen and normalised; saved in ``processor_config.json`` next to the model."""

    num_frames: int = 8
    image_size: tuple[int, int] = (64, 64)
    sampling: str = "uniform"
    resize_mode: str = "fit"
    mean: float | tuple[float, float, float] = 0.5
    """Background-subtracted frames are 0.5 where nothing touches; this centres them on 0. One value or one per
    RGB channel (ImageNet's for a pretrained image backbone)."""
    std: float | tuple[float, float, float] = 0.1
    """Imprints change pixels by a few percent; dividing by a small std gives the ViT unit-scale input."""
    background: str = "subtract"
    """``subtract``: (frame − the gel at rest)/255 + 0.5, the imprint alone; ``keep``: frame/255, the sensor image
    as it is (what an ImageNet backbone was trained on: lit gel, shading and texture)."""
    colour: str = "rgb"
    """``rgb``: the frame's colours; ``magnitude`` (with ``subtract``): how much each pixel changed, |I − B| over
    the three channels, the same on each: the imprint without the sensor's light colours, which differ between
    sensors (a GelSight Mini and a DIGIT light the gel with differently placed and coloured LEDs)."""
    orientation: str = "as_is"
    """``match``: a portrait frame (a DIGIT's 320×240) is turned a quarter to the model's landscape ``image_size``
    (and the other way round) before resizing, so it fills the image instead of a strip of it."""
    gel_reference: dict[str, tuple[float, float, float]] | None = None
    """With ``keep``: the training sensor's gel at rest, per-channel ``mean`` and ``std`` of its frame in [0, 1]
    (:func:`measure_gel_reference` over training clips). Each clip's colours are then mapped, channel by channel, so
    that its own gel at rest has those statistics: another sensor's tint and gain become the training sensor's,
    and a clip of the training sensor is left nearly as it is. Per clip; nothing is fitted on evaluation clips."""
    gel_image: list | None = None
    """With ``gel_reference``: the training sensor's average gel at rest as prepared (turned, resized; h×w×3 in
    [0, 1], any size of the model's aspect: it is resized to ``image_size``), from :func:`measure_gel_image` over
    training clips. Each frame's mapped gel at rest is then replaced by it — frame → map(frame) − map(rest) +
    image — so the imprint is the clip's own change from its own rest, lit as the training sensor lights its gel
    (where the light falls differs between sensors; a per-channel map leaves it)."""
    gel_swap: str = "whole"
    """With ``gel_image``: ``whole`` swaps the clip's whole rest frame for it; ``lighting`` only the rest frame's
    smooth part (the rest brought down to ``gel_image``'s size and back), keeping the clip's own fine detail;
    ``imprint`` the whole rest frame, adding the clip's change from it unmapped (frame → image + frame − rest): the
    colour map's gain, 2–3× for a sensor whose gel at rest is flatter, would scale its imprint too."""
    gel_swap_above: float | None = None
    """With ``gel_image``: swap only a clip whose mapped gel at rest differs from ``gel_image`` by more than this
    (:func:`gel_rest_distance`, a mean absolute difference in [0, 1]); a clip within it is prepared as without the
    swap. Set to the largest distance over the training sensor's own clips (:func:`measure_gel_swap_above`), it
    leaves the training sensor's clips as they are and swaps another sensor's."""
    imprint_gain: tuple[float, float, float] | None = None
    """With ``gel_swap: imprint``: the clip's change from rest scaled per channel (R, G, B) before the training
    sensor's gel is added back. Another sensor's imprint can be stronger or weaker than the one the model trained on
    (a simulated DIGIT's about 1.5–1.9× the Mini's); :func:`measure_imprint_gain` sets it for one's own sensor from
    unlabelled clips of it (any objects) against the model's training clips. None: unscaled."""
    _gel_full: np.ndarray | None = field(default=None, init=False, repr=False, compare=False)
    """``gel_image`` at ``image_size`` (float32 in [0, 1]), made once here rather than for every clip."""

    def __post_init__(self) -> None:
        self.image_size = tuple(int(v) for v in self.image_size)  # type: ignore[assignment]
        for name in ("mean", "std"):
            value = getattr(self, name)
            if isinstance(value, list | tuple):
                if len(value) != 3:
                    raise ValueError(f"video processing: {name} must be one number or three (R, G, B), got {value!r}")
                setattr(self, name, tuple(float(v) for v in value))
        if self.background not in BACKGROUNDS:
            raise ValueError(f"video processing: background {self.background!r} is not one of "
                             f"{', '.join(BACKGROUNDS)}")
        if self.colour not in COLOURS:
            raise ValueError(f"video processing: colour {self.colour!r} is not one of {', '.join(COLOURS)}")
        if self.colour == "magnitude" and self.background != "subtract":
            raise ValueError("video processing: colour 'magnitude' needs background 'subtract' (it is the size of "
                             "the change from the gel at rest)")
        if self.gel_reference is not None:
            ref = dict(self.gel_reference)
            if set(ref) != {"mean", "std"} or any(len(ref[k]) != 3 for k in ref):
                raise ValueError("video processing: gel_reference must be {mean: [r, g, b], std: [r, g, b]}, got "
                                 f"{self.gel_reference!r}")
            if self.background != "keep":
                raise ValueError("video processing: gel_reference needs background 'keep' (a subtracted frame has "
                                 "no gel colours left to map)")
            if min(ref["std"]) <= 0:
                raise ValueError(f"video processing: gel_reference std must be > 0, got {ref['std']}")
            self.gel_reference = {k: tuple(float(v) for v in ref[k]) for k in ("mean", "std")}
        if self.gel_image is not None:
            image = np.asarray(self.gel_image, dtype=np.float64)
            if image.ndim != 3 or image.shape[-1] != 3 or min(image.shape[:2]) < 1 or not np.isfinite(image).all() \
                    or image.min() < 0 or image.max() > 1:
                raise ValueError(f"video processing: gel_image must be an h×w×3 image in [0, 1], got shape "
                                 f"{image.shape}")
            if self.gel_reference is None:
                raise ValueError("video processing: gel_image needs gel_reference (the frames are mapped to the "
                                 "training sensor's colours before its gel at rest is swapped in)")
            self.gel_image = image.round(4).tolist()
            full = np.asarray(self.gel_image, np.float32)
            self._gel_full = full if full.shape[:2] == self.image_size else \
                _unit_resized(full, *self.image_size, "BILINEAR")
        if self.gel_swap not in GEL_SWAPS:
            raise ValueError(f"video processing: gel_swap {self.gel_swap!r} is not one of {', '.join(GEL_SWAPS)}")
        if self.gel_swap != "whole" and self.gel_image is None:
            raise ValueError(f"video processing: gel_swap {self.gel_swap!r} needs gel_image (what to swap in)")
        if self.gel_swap_above is not None:
            if self.gel_image is None:
                raise ValueError("video processing: gel_swap_above needs gel_image (the distance is measured to it)")
            if not np.isfinite(self.gel_swap_above) or self.gel_swap_above < 0:
                raise ValueError(f"video processing: gel_swap_above must be a number ≥ 0, got {self.gel_swap_above!r}")
            self.gel_swap_above = float(self.gel_swap_above)
        if self.imprint_gain is not None:
            gain = np.asarray(self.imprint_gain, dtype=np.float64)
            if gain.shape != (3,) or not np.isfinite(gain).all() or gain.min() <= 0:
                raise ValueError(f"video processing: imprint_gain must be three numbers > 0 (R, G, B), got "
                                 f"{self.imprint_gain!r}")
            if self.gel_swap != "imprint":
                raise ValueError("video processing: imprint_gain needs gel_swap 'imprint' (it scales the change "
                                 "from rest that the imprint swap adds unmapped)")
            self.imprint_gain = tuple(round(float(v), 4) for v in gain)  # type: ignore[assignment]
        if self.orientation not in ORIENTATIONS:
            raise ValueError(f"video processing: orientation {self.orientation!r} is not one of "
                             f"{', '.join(ORIENTATIONS)}")
        if self.num_frames < 1:
            raise ValueError(f"video processing: num_frames must be ≥ 1, got {self.num_frames}")
        if len(self.image_size) != 2 or min(self.image_size) < 1:
            raise ValueError(f"video processing: image_size must be (height, width), got {self.image_size!r}")
        if self.sampling not in SAMPLING_METHODS:
            raise ValueError(f"video processing: sampling {self.sampling!r} is not one of "
                             f"{', '.join(SAMPLING_METHODS)}")
        if self.resize_mode not in RESIZE_MODES:
            raise ValueError(f"video processing: resize_mode {self.resize_mode!r} is not one of "
                             f"{', '.join(RESIZE_MODES)}")
        if min(np.atleast_1d(self.std)) <= 0:
            raise ValueError(f"video processing: std must be > 0, got {self.std}")

    def to_dict(self) -> dict[str, Any]:
        def plain(v: float | tuple[float, ...]) -> float | list[float]:
            return list(v) if isinstance(v, tuple) else v

        return {"num_frames": self.num_frames, "image_size": list(self.image_size), "sampling": self.sampling,
                "resize_mode": self.resize_mode, "mean": plain(self.mean), "std": plain(self.std),
                "background": self.background,
                # written only when set, so a config (and a cache key) from before these options stays the same
                **({"colour": self.colour} if self.colour != "rgb" else {}),
                **({"orientation": self.orientation} if self.orientation != "as_is" else {}),
                **({"gel_reference": {k: list(v) for k, v in self.gel_reference.items()}}
                   if self.gel_reference is not None else {}),
                **({"gel_image": self.gel_image} if self.gel_image is not None else {}),
                **({"gel_swap": self.gel_swap} if self.gel_swap != "whole" else {}),
                **({"gel_swap_above": self.gel_swap_above} if self.gel_swap_above is not None else {}),
                **({"imprint_gain": list(self.imprint_gain)} if self.imprint_gain is not None else {})}

    @classmethod
    def from_dict(cls, data: dict[str, Any] | None) -> VideoProcessingConfig:
        data = dict(data or {})
        reject_unknown_fields(cls, data, "video processing config: unknown keys", known="declared")
        return cls(**data)


def _gel_statistics(frame: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-channel mean and standard deviation of one uint8 H×W×3 frame, in [0, 1]."""
    pixels = frame.reshape(-1, 3).astype(np.float64) / 255.0
    return pixels.mean(axis=0), pixels.std(axis=0)


def _to_gel_reference(out: np.ndarray, background: np.ndarray, reference: dict[str, tuple[float, ...]]) -> np.ndarray:
    """``out`` (frames in [0, 1]) mapped per channel so that ``background`` would have ``reference``'s statistics."""
    mean, std = _gel_statistics(background)
    gain = np.asarray(reference["std"]) / np.maximum(std, 1e-3)
    shifted = (out - mean.astype(np.float32)) * gain.astype(np.float32) + np.asarray(reference["mean"], np.float32)
    return np.clip(shifted, 0.0, 1.0, out=shifted)


def _unit_resized(frame: np.ndarray, height: int, width: int, interpolation: str = "AREA") -> np.ndarray:
    """One H×W×3 frame in [0, 1] resized to height×width (through uint8, what ``resize_keep_aspect`` takes),
    float32 in [0, 1]."""
    as_bytes = np.clip(np.rint(frame * 255.0), 0, 255).astype(np.uint8)
    return resize_keep_aspect(as_bytes, height, width, mode="crop", interpolation=interpolation) \
        .astype(np.float32) / 255.0


def _gel_image(config: VideoProcessingConfig) -> np.ndarray:
    """``config.gel_image`` at ``config.image_size``, float32 in [0, 1]."""
    assert config._gel_full is not None, "gel_image is not set"
    return config._gel_full


def _smoothed(frame: np.ndarray, config: VideoProcessingConfig) -> np.ndarray:
    """One frame in [0, 1] brought down to ``config.gel_image``'s size and back: its smooth part (the lighting)."""
    small = _unit_resized(frame, len(config.gel_image), len(config.gel_image[0]))
    return _unit_resized(small, *config.image_size, "BILINEAR")


def gel_rest_distance(mapped_rest: np.ndarray, config: VideoProcessingConfig) -> float:
    """How far a clip's gel at rest (prepared and colour-mapped, H×W×3 in [0, 1]) is lit from ``config.gel_image``:
    the mean absolute difference of its smooth part from it — what ``gel_swap: lighting`` would add to each frame."""
    return float(np.abs(_smoothed(mapped_rest, config) - _gel_image(config)).mean())


def measure_gel_swap_above(videos: Sequence[VideoInput], config: VideoProcessingConfig) -> float:
    """The largest :func:`gel_rest_distance` over ``videos`` (the training sensor's clips), for
    :attr:`VideoProcessingConfig.gel_swap_above`: no clip of that sensor seen in training lay farther."""
    if not videos:
        raise ValueError("measure_gel_swap_above: no clips given")
    if config.gel_image is None or config.background != "keep":
        raise ValueError("measure_gel_swap_above: config needs gel_image (and gel_reference, background 'keep')")
    distances = []
    for video in videos:
        frames, phases, _ = _frames_and_phases(video)
        rest = background_frame(frames, phases)
        mapped = _prepared(rest[None], config, rest)[0]
        distances.append(gel_rest_distance(mapped, config))
    return float(np.ceil(max(distances) * 1e6) / 1e6)  # rounded up: the farthest clip itself stays within


def measure_gel_image(videos: Sequence[VideoInput], config: VideoProcessingConfig, scale: int = 4) -> list:
    """The average gel at rest of ``videos`` (training clips of one sensor), each clip's rest frame turned and
    resized as ``config`` prepares frames, at 1/``scale`` of ``config.image_size``: for
    :attr:`VideoProcessingConfig.gel_image`. The lighting is smooth, so a small image keeps the config small."""
    if not videos:
        raise ValueError("measure_gel_image: no clips given")
    height, width = config.image_size
    total = np.zeros((height, width, 3), np.float64)
    for video in videos:
        frames, phases, _ = _frames_and_phases(video)
        rest = background_frame(frames, phases)
        if config.orientation == "match" and (rest.shape[0] > rest.shape[1]) != (height > width):
            rest = np.rot90(rest)
        total += resize_keep_aspect(np.ascontiguousarray(rest), height, width, mode=config.resize_mode)
    mean = (total / len(videos)).astype(np.float32)
    small = resize_keep_aspect(np.clip(np.rint(mean), 0, 255).astype(np.uint8), max(1, height // scale),
                               max(1, width // scale), mode="crop")
    return (small.astype(np.float64) / 255.0).round(4).tolist()


def imprint_strength(video: VideoInput, config: VideoProcessingConfig) -> np.ndarray:
    """Per channel, the root mean square change from the swapped-in gel at rest over ``video``'s frames as ``config``
    prepares them (it must swap: ``gel_image``, no gate): how strong the imprint reaches the model. Squared, so a
    sensor's pixel noise (small changes everywhere) weighs little beside the imprint (large changes where pressed)."""
    if config.gel_image is None or config.gel_swap_above is not None:
        raise ValueError("imprint_strength: config needs gel_image and no gel_swap_above")
    out = preprocess_video(video, config).transpose(0, 2, 3, 1)
    out = out * np.asarray(config.std, np.float32) + np.asarray(config.mean, np.float32)
    return np.sqrt(np.square(out - _gel_image(config)).mean(axis=(0, 1, 2)))


def measure_imprint_gain(sensor_videos: Sequence[VideoInput], training_videos: Sequence[VideoInput],
                         config: VideoProcessingConfig) -> list[float]:
    """For :attr:`VideoProcessingConfig.imprint_gain`: per channel, how much stronger the training clips' imprint
    reached the model (prepared as trained: ``config`` with ``gel_swap: whole``) than ``sensor_videos``' does under
    ``config``'s ``gel_swap: imprint`` — the ratio of their mean :func:`imprint_strength`. ``sensor_videos``: one's own
    sensor's clips, unlabelled and of any objects (not those one evaluates on)."""
    if not sensor_videos or not training_videos:
        raise ValueError("measure_imprint_gain: give clips of both the new sensor and the training sensor")
    _check_imprint_swap(config, "measure_imprint_gain")
    return imprint_gain_from_reference(sensor_videos, measure_imprint_reference(training_videos, config), config)


def measure_imprint_reference(training_videos: Sequence[VideoInput], config: VideoProcessingConfig) -> list[float]:
    """Per channel, the mean :func:`imprint_strength` of the training clips prepared as trained (``config`` with
    ``gel_swap: whole``, no gain): what :func:`imprint_gain_from_reference` brings another sensor to. Kept with a model
    (``sensor_reference.json``) so its users can measure their sensor's gain without the training clips."""
    if not training_videos:
        raise ValueError("measure_imprint_reference: no training clips given")
    trained = _unscaled(config, "whole")
    return np.mean([imprint_strength(v, trained) for v in training_videos], axis=0, dtype=np.float64).tolist()


def imprint_gain_from_reference(sensor_videos: Sequence[VideoInput], reference: Sequence[float],
                                config: VideoProcessingConfig) -> list[float]:
    """:func:`measure_imprint_gain` against a recorded :func:`measure_imprint_reference` (three numbers > 0)."""
    if not sensor_videos:
        raise ValueError("imprint gain: no clips of the new sensor given")
    _check_imprint_swap(config, "imprint gain")
    target = np.asarray(reference, dtype=np.float64)
    if target.shape != (3,) or not np.isfinite(target).all() or target.min() <= 0:
        raise ValueError(f"imprint gain: the reference must be three numbers > 0 (R, G, B), got {list(reference)!r}")
    unscaled = _unscaled(config, "imprint")
    found = np.mean([imprint_strength(v, unscaled) for v in sensor_videos], axis=0, dtype=np.float64)
    return (target / np.maximum(found, 1e-6)).round(4).tolist()


def _unscaled(config: VideoProcessingConfig, gel_swap: str) -> VideoProcessingConfig:
    """``config`` with ``gel_swap`` and no imprint gain."""
    return replace(config, gel_swap=gel_swap, imprint_gain=None)


def _check_imprint_swap(config: VideoProcessingConfig, what: str) -> None:
    if config.gel_swap != "imprint":
        raise ValueError(f"{what}: config needs gel_swap 'imprint' (the answer-time swap it scales)")


def measure_gel_reference(videos: Sequence[VideoInput]) -> dict[str, list[float]]:
    """The gel at rest of ``videos`` (training clips of one sensor): the mean over clips of each clip's
    per-channel mean and standard deviation, for :attr:`VideoProcessingConfig.gel_reference`."""
    if not videos:
        raise ValueError("measure_gel_reference: no clips given")
    stats = []
    for video in videos:
        frames, phases, _ = _frames_and_phases(video)
        stats.append(_gel_statistics(background_frame(frames, phases)))
    return {"mean": np.mean([m for m, _ in stats], axis=0).round(5).tolist(),
            "std": np.mean([s for _, s in stats], axis=0).round(5).tolist()}


def sensor_of(video: VideoInput) -> str:
    """The sensor style of a clip ('unknown' for bare frames or files)."""
    return video.sensor if isinstance(video, TactileClip) else "unknown"


def base_sensor(sensor: str) -> str:
    """A sensor style without its variant ("mini+markers", "digit@60" → "mini", "digit"), lower-case."""
    return sensor.split("+")[0].split("@")[0].lower()


def sensor_index(sensor: str, sensor_types: Sequence[str]) -> int:
    """Position of a sensor style in ``sensor_types`` (by :func:`base_sensor`); 0 if unknown."""
    base = base_sensor(sensor)
    return list(sensor_types).index(base) if base in sensor_types else 0


def _frames_and_phases(video: VideoInput) -> tuple[np.ndarray, Sequence[str] | None, str]:
    if isinstance(video, TactileClip):
        return video.frames, video.phases, f"clip {video.clip_id!r}"
    if isinstance(video, str | os.PathLike):
        from tacreasoner.data.readers import read_video_clip

        clip = read_video_clip(Path(video))
        return clip.frames, None, f"video {os.fspath(video)!r}"
    frames = np.asarray(video)
    return frames, None, "frames"


def _turned_and_resized(frames: np.ndarray, config: VideoProcessingConfig) -> np.ndarray:
    """uint8 T×H×W×3 frames turned (``orientation: match``) and resized to ``config.image_size``."""
    if config.orientation == "match" and (frames.shape[1] > frames.shape[2]) != \
            (config.image_size[0] > config.image_size[1]):
        frames = np.rot90(frames, axes=(1, 2))
    return resize_keep_aspect(frames, *config.image_size, mode=config.resize_mode)


def _unit(frames: np.ndarray, config: VideoProcessingConfig) -> np.ndarray:
    """uint8 frames turned, resized, in [0, 1] float32: the frames before any colour map."""
    out = _turned_and_resized(frames, config).astype(np.float32)
    out /= 255.0
    return out


def _mapped(unit: np.ndarray, config: VideoProcessingConfig, background: np.ndarray | None) -> np.ndarray:
    """``unit`` frames colour-mapped by ``background`` (the clip's gel at rest, as recorded) when
    ``config.gel_reference`` is set (a new array: ``unit`` is left as it was), else ``unit`` itself."""
    if config.gel_reference is None:
        return unit
    return _to_gel_reference(unit, background, config.gel_reference)


def _prepared(frames: np.ndarray, config: VideoProcessingConfig, background: np.ndarray | None) -> np.ndarray:
    """The frames as ``background: keep`` prepares them: turned, resized, in [0, 1], colour-mapped."""
    return _mapped(_unit(frames, config), config, background)


def preprocess_video(video: VideoInput, config: VideoProcessingConfig | None = None, *,
                     seed: int | None = None, background: np.ndarray | None = None) -> np.ndarray:
    """num_frames×3×H×W float32: sampled, resized keeping aspect, background-subtracted (unless
    ``config.background`` is ``keep``), normalised.

    The background is the clip's first no-contact frame (first frame when phases are unknown).
    ``seed`` jitters which frame is taken inside each sampling segment (training augmentation).
    ``background``: the gel at rest, for a segment cut from a longer clip (its own first frame may be
    in contact already).
    """
    config = config or VideoProcessingConfig()
    frames, phases, what = _frames_and_phases(video)
    if frames.ndim != 4 or frames.shape[-1] != 3 or frames.dtype != np.uint8:
        raise ValueError(f"{what}: expected uint8 frames T×H×W×3, got {frames.dtype} {tuple(frames.shape)}")
    if len(frames) == 0:
        raise ValueError(f"{what}: has no frames")
    method = config.sampling
    if method == "phase" and phases is None:
        method = "uniform"  # real video without a phase track: fall back rather than fail mid-batch
    idx = sample_indices(len(frames), config.num_frames, method,
                         frames=frames if method in ("salient", "contact") else None,
                         phases=phases if method == "phase" else None, seed=seed)
    keep = config.background == "keep"
    if keep and config.gel_reference is not None and background is None:
        background = background_frame(frames, phases)
    swap = keep and config.gel_image is not None
    if keep and not swap:
        chosen = frames[idx]
    else:  # the gel at rest first, prepared with the frames
        if background is None:
            background = background_frame(frames, phases)
        chosen = np.concatenate([background[None], frames[idx]])
    if keep:
        unit = _unit(chosen, config)
        out = _mapped(unit, config, background)
        if swap:
            if config.gel_swap_above is not None and gel_rest_distance(out[0], config) <= config.gel_swap_above:
                out = out[1:]  # lit as the training sensor's own clips were: left as the colour map leaves it
            else:
                if config.gel_swap == "imprint":  # the change from rest at its own scale, not the map's
                    out = unit
                rest = _smoothed(out[0], config)[None] if config.gel_swap == "lighting" else out[:1]
                out = out[1:] - rest
                if config.imprint_gain is not None:
                    out *= np.asarray(config.imprint_gain, np.float32)
                out += _gel_image(config)
                np.clip(out, 0.0, 1.0, out=out)
    else:
        chosen = _turned_and_resized(chosen, config)
        out = subtract_background(chosen[1:], chosen[0])
        if config.colour == "magnitude":
            change = np.sqrt(np.square(out - 0.5).sum(axis=-1, keepdims=True) / 3.0)
            out = np.repeat(change + 0.5, 3, axis=-1)
    out -= np.asarray(config.mean, np.float32)
    out /= np.asarray(config.std, np.float32)
    return np.ascontiguousarray(out.transpose(0, 3, 1, 2))
