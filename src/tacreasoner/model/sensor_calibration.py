"""A model folder for one's own sensor: the imprint brought to the strength the model trained on.

A model trained with the gel swap (``gel_swap: imprint``) reads another sensor's clips lit as its own, but the
change a press makes is that sensor's own size (a simulated DIGIT's 1.5–1.9× a GelSight Mini's). The training
clips' imprint strength is kept beside the model (``sensor_reference.json``, :func:`record_sensor_reference`), so a
user with unlabelled clips of their sensor, of any objects, sets the gain without the training data
(:func:`calibrate_sensor`, ``tacreasoner calibrate-sensor``). Measured on DynTAC-Sim's held-out DIGIT style:
experiments/2026-12-01_imprint_strength.
"""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from tacreasoner.jsonl import atomic_write_text
from tacreasoner.model.processing import PROCESSOR_CONFIG_NAME, saved_processor_config
from tacreasoner.model.video_processing import (
    VideoInput,
    VideoProcessingConfig,
    imprint_gain_from_reference,
    measure_imprint_reference,
    sensor_of,
)

__all__ = ["CALIBRATION_NAME", "SENSOR_REFERENCE_NAME", "Calibration", "calibrate_sensor", "imprint_swap_config",
           "read_sensor_reference", "record_sensor_reference"]

SENSOR_REFERENCE_NAME = "sensor_reference.json"
"""The training clips' imprint strength, beside the weights of a model trained with the gel swap."""
CALIBRATION_NAME = "sensor_calibration.json"
"""In a calibrated folder: the gain, how many clips of which sensor set it, and the model it came from."""


def imprint_swap_config(model_dir: str | os.PathLike[str]) -> VideoProcessingConfig:
    """The model's frame preparation answering with ``gel_swap: imprint``, or a one-line error where it was trained
    without the gel swap (no ``video.gel_image``: there is no training sensor's gel to add the imprint to)."""
    video = dict(saved_processor_config(model_dir).get("video") or {})
    if not (Path(model_dir) / PROCESSOR_CONFIG_NAME).is_file():
        raise FileNotFoundError(f"{model_dir}: no {PROCESSOR_CONFIG_NAME} (not a saved TacReasoner model folder)")
    if video.get("gel_image") is None or video.get("gel_swap_above") is not None:
        raise ValueError(f"{model_dir}: trained without the gel swap (no video.gel_image, or a gate); a sensor gain "
                         "needs a model trained with gel_swap 'imprint', as the quickstart's")
    video.pop("imprint_gain", None)
    return VideoProcessingConfig.from_dict({**video, "gel_swap": "imprint"})


def record_sensor_reference(model_dir: str | os.PathLike[str], training_videos: Sequence[VideoInput], *,
                            reference: Sequence[float] | None = None) -> dict[str, Any]:
    """Write ``sensor_reference.json`` into a model folder: the mean imprint strength of ``training_videos`` (clips
    of the sensor it trained on, train objects only) as the model read them. ``reference``: one already measured
    for these clips and this preparation (a run's seeds share it). Returns what was written."""
    config = imprint_swap_config(model_dir)
    strength = list(reference) if reference is not None else measure_imprint_reference(training_videos, config)
    record = {"imprint_strength": [round(float(v), 6) for v in strength], "clips": len(training_videos),
              "sensors": sorted({sensor_of(v) for v in training_videos}), "split": "train",
              "video": {k: v for k, v in config.to_dict().items() if k != "gel_image"}}
    atomic_write_text(Path(model_dir) / SENSOR_REFERENCE_NAME, json.dumps(record, indent=2) + "\n")
    return record


def read_sensor_reference(model_dir: str | os.PathLike[str]) -> list[float] | None:
    """The recorded training imprint strength (three numbers), or None where the folder records none; an error
    where it was measured for another frame preparation than the folder's."""
    path = Path(model_dir) / SENSOR_REFERENCE_NAME
    if not path.is_file():
        return None
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
        value, video = record["imprint_strength"], record["video"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"{path}: cannot read imprint_strength and video ({exc})") from None
    if not isinstance(value, list) or len(value) != 3:
        raise ValueError(f"{path}: imprint_strength must be three numbers (R, G, B), got {value!r}")
    now = {k: v for k, v in imprint_swap_config(model_dir).to_dict().items() if k != "gel_image"}
    if video != now:
        changed = sorted(k for k in set(video) | set(now) if video.get(k) != now.get(k))
        raise ValueError(f"{path}: measured for another frame preparation ({', '.join(changed)} differ from "
                         f"{PROCESSOR_CONFIG_NAME}'s); give --training-clips to measure it again")
    return [float(v) for v in value]


@dataclass(frozen=True)
class Calibration:
    out: Path
    gain: list[float]
    clips: int
    reference_from: str


def calibrate_sensor(model_dir: str | os.PathLike[str], sensor_videos: Sequence[VideoInput],
                     out: str | os.PathLike[str], *,
                     training_videos: Sequence[VideoInput] | None = None) -> Calibration:
    """A copy of ``model_dir`` at ``out`` that answers clips of the sensor ``sensor_videos`` came from with its
    imprint scaled to the training strength (``video.imprint_gain``). The reference is the folder's
    ``sensor_reference.json``, or measured on ``training_videos`` where given (a model that records none). Weights
    are hard-linked where the file system allows (else copied); the original folder is not changed."""
    model_dir, out = Path(model_dir), Path(out)
    config = imprint_swap_config(model_dir)
    if not sensor_videos:
        raise ValueError("calibrate-sensor: no clips of the sensor given")
    if out.resolve() == model_dir.resolve():
        raise ValueError(f"{out}: the calibrated model needs its own folder (the original keeps answering its own "
                         "sensor unscaled)")
    if out.exists() and any(out.iterdir()):
        raise FileExistsError(f"{out}: exists and is not empty; give a new --out")
    if training_videos:
        reference, source = measure_imprint_reference(training_videos, config), \
            f"{len(training_videos)} training clips given"
    else:
        reference = read_sensor_reference(model_dir)
        if reference is None:
            raise ValueError(f"{model_dir}: no {SENSOR_REFERENCE_NAME} (a model published before it was recorded); "
                             "give --training-clips: clips of the sensor it trained on, train objects only")
        source = f"{model_dir / SENSOR_REFERENCE_NAME}"
    gain = imprint_gain_from_reference(sensor_videos, reference, config)
    out.parent.mkdir(parents=True, exist_ok=True)
    shutil.copytree(model_dir, out, copy_function=_link_or_copy, dirs_exist_ok=True)
    data = json.loads((out / PROCESSOR_CONFIG_NAME).read_text(encoding="utf-8"))
    data["video"] = replace(config, imprint_gain=gain).to_dict()
    config_file = out / PROCESSOR_CONFIG_NAME
    config_file.unlink()  # a hard link would change the original's config too
    atomic_write_text(config_file, json.dumps(data, indent=2) + "\n")
    atomic_write_text(out / CALIBRATION_NAME, json.dumps(
        {"imprint_gain": gain, "clips": len(sensor_videos), "sensors": sorted({sensor_of(v) for v in sensor_videos}),
         "model": str(model_dir), "reference": [round(float(v), 6) for v in reference],
         "reference_from": source}, indent=2) + "\n")
    return Calibration(out=out, gain=gain, clips=len(sensor_videos), reference_from=source)


def _link_or_copy(src: str, dst: str) -> str:
    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)
    return dst
