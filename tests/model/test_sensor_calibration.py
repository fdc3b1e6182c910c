"""A model folder for one's own sensor: the recorded training strength, the gain from a new sensor's clips alone."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from tacreasoner.model.sensor_calibration import (
    CALIBRATION_NAME,
    SENSOR_REFERENCE_NAME,
    calibrate_sensor,
    read_sensor_reference,
    record_sensor_reference,
)
from tacreasoner.model.video_processing import (
    VideoProcessingConfig,
    measure_gel_image,
    measure_gel_reference,
    measure_imprint_gain,
)
from tests.model.test_video_processing import _lit_gel


def _swap_trained_model(folder: Path, seen: list[np.ndarray]) -> VideoProcessingConfig:
    """A model folder as the quickstart publishes it: imprint swap, the train clips' gel image; a stand-in weight."""
    base = dict(num_frames=8, image_size=(24, 32), background="keep", mean=0.0, std=1.0,
                gel_reference=measure_gel_reference(seen))
    image = measure_gel_image(seen, VideoProcessingConfig(**base))
    config = VideoProcessingConfig(**base, gel_image=image, gel_swap="imprint")
    folder.mkdir(parents=True)
    (folder / "processor_config.json").write_text(json.dumps({"video": config.to_dict(), "tokens_per_video": 5}))
    (folder / "model.safetensors").write_bytes(b"weights")
    return config


def test_a_calibrated_copy_answers_a_stronger_sensor_at_the_trained_strength_from_its_clips_alone(
        tmp_path: Path) -> None:
    seen = [_lit_gel(k, (1.0, 1.0, 1.0), (0, 0, 0)) for k in range(3)]
    strong = [_lit_gel(10 + k, (1.0, 1.0, 1.0), (0, 0, 0), strength=(72.0, 60.0, 40.0)) for k in range(3)]
    model = tmp_path / "model"
    config = _swap_trained_model(model, seen)
    with pytest.raises(ValueError, match=r"no sensor_reference\.json .* give --training-clips"):
        calibrate_sensor(model, strong, tmp_path / "early")
    record = record_sensor_reference(model, seen)
    assert record["clips"] == 3 and record["split"] == "train" and "gel_image" not in record["video"]
    before = (model / "processor_config.json").read_text()

    result = calibrate_sensor(model, strong, tmp_path / "digit")  # the training clips are not needed any more
    expected = measure_imprint_gain(strong, seen, config)
    assert np.allclose(result.gain, expected, atol=1e-4) and np.allclose(result.gain, [40 / 72, 40 / 60, 1], atol=0.06)
    video = json.loads((tmp_path / "digit" / "processor_config.json").read_text())["video"]
    assert video["imprint_gain"] == result.gain and video["gel_swap"] == "imprint"
    assert json.loads((tmp_path / "digit" / "processor_config.json").read_text())["tokens_per_video"] == 5
    assert (tmp_path / "digit" / "model.safetensors").read_bytes() == b"weights"
    assert (model / "processor_config.json").read_text() == before  # the original answers its own sensor unscaled
    saved = json.loads((tmp_path / "digit" / CALIBRATION_NAME).read_text())
    assert saved["clips"] == 3 and saved["imprint_gain"] == result.gain
    assert saved["reference_from"].endswith(SENSOR_REFERENCE_NAME)

    again = calibrate_sensor(tmp_path / "digit", strong, tmp_path / "twice")  # a calibrated folder's gain is replaced
    assert again.gain == result.gain
    given = calibrate_sensor(model, strong, tmp_path / "given", training_videos=seen)
    assert given.gain == result.gain and given.reference_from == "3 training clips given"


def test_calibration_refuses_what_it_cannot_do(tmp_path: Path) -> None:
    seen = [_lit_gel(k, (1.0, 1.0, 1.0), (0, 0, 0)) for k in range(2)]
    model = tmp_path / "model"
    _swap_trained_model(model, seen)
    record_sensor_reference(model, seen)
    with pytest.raises(ValueError, match="needs its own folder"):
        calibrate_sensor(model, seen, model)
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "x").write_text("x")
    with pytest.raises(FileExistsError, match="exists and is not empty"):
        calibrate_sensor(model, seen, tmp_path / "full")
    with pytest.raises(ValueError, match="no clips of the sensor"):
        calibrate_sensor(model, [], tmp_path / "none")
    plain = tmp_path / "plain"
    plain.mkdir()
    (plain / "processor_config.json").write_text(json.dumps({"video": {"background": "keep"}}))
    with pytest.raises(ValueError, match="trained without the gel swap"):
        calibrate_sensor(plain, seen, tmp_path / "out")
    with pytest.raises(FileNotFoundError, match="not a saved TacReasoner model folder"):
        calibrate_sensor(tmp_path / "nowhere", seen, tmp_path / "out")
    config = json.loads((model / "processor_config.json").read_text())
    config["video"]["num_frames"] = 4  # the preparation changed after the reference was measured
    (model / "processor_config.json").write_text(json.dumps(config))
    with pytest.raises(ValueError, match=r"measured for another frame preparation \(num_frames differ"):
        read_sensor_reference(model)
