"""Clip → encoder input, and the encoder config's checks."""

from __future__ import annotations

import numpy as np
import pytest

from tacreasoner.data.clip import TactileClip
from tacreasoner.model.encoder_config import TactileEncoderConfig
from tacreasoner.model.video_processing import (
    VideoProcessingConfig,
    imprint_strength,
    measure_gel_image,
    measure_gel_reference,
    measure_gel_swap_above,
    measure_imprint_gain,
    preprocess_video,
)


def _frames(n: int = 12, h: int = 24, w: int = 32, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 255, (n, h, w, 3), dtype=np.uint8)


def test_output_shape_dtype_and_background_is_zero() -> None:
    still = np.repeat(_frames(1), 10, axis=0)
    out = preprocess_video(still, VideoProcessingConfig(num_frames=4, image_size=(16, 16)))
    assert out.shape == (4, 3, 16, 16) and out.dtype == np.float32
    assert np.allclose(out, 0.0)


def test_background_is_the_first_no_contact_frame_of_a_clip() -> None:
    frames = _frames(6)
    frames[3] = 0  # phases say frame 3 is the gel at rest
    clip = TactileClip(clip_id="c", object_id="o", fps=25, frames_in_memory=frames,
                       phases=["press", "press", "hold", "no_contact", "release", "release"])
    config = VideoProcessingConfig(num_frames=6, image_size=(24, 32), std=1.0, mean=0.0)
    out = preprocess_video(clip, config)
    # (I − B)/255 + 0.5 with B = frame 3, which is all zeros
    assert np.allclose(out[0], frames[0].transpose(2, 0, 1) / 255.0 + 0.5, atol=1e-6)


def test_salient_and_phase_sampling_and_the_seeded_jitter() -> None:
    frames = _frames(40)
    base = VideoProcessingConfig(num_frames=4, image_size=(8, 8))
    assert not np.array_equal(preprocess_video(frames, base, seed=1), preprocess_video(frames, base, seed=2))
    assert np.array_equal(preprocess_video(frames, base), preprocess_video(frames, base))
    salient = VideoProcessingConfig(num_frames=4, image_size=(8, 8), sampling="salient")
    assert preprocess_video(frames, salient).shape == (4, 3, 8, 8)
    # phase sampling without a phase track falls back to uniform rather than failing a batch
    phase = VideoProcessingConfig(num_frames=4, image_size=(8, 8), sampling="phase")
    assert np.array_equal(preprocess_video(frames, phase), preprocess_video(frames, base))


def test_contact_sampling_takes_the_frames_of_strongest_contact() -> None:
    from tacreasoner.data.sampling import sample_indices

    frames = np.full((30, 32, 32, 3), 120, np.uint8)
    for t, size in ((5, 4), (12, 14), (13, 16), (14, 15), (20, 6)):  # an imprint, biggest at frames 12-14
        frames[t, 16 - size // 2:16 + size // 2, 16 - size // 2:16 + size // 2] = 200
    assert sample_indices(30, 3, "contact", frames=frames).tolist() == [12, 13, 14]
    with pytest.raises(ValueError, match="'contact' needs frames"):
        sample_indices(30, 3, "contact")
    config = VideoProcessingConfig(num_frames=3, image_size=(32, 32), sampling="contact", std=1.0, mean=0.0)
    assert np.allclose(preprocess_video(frames, config)[1], (frames[13] - 120.0).transpose(2, 0, 1) / 255 + 0.5)


def test_kept_background_and_per_channel_normalisation() -> None:
    frames = _frames(5)
    imagenet = VideoProcessingConfig(num_frames=5, image_size=(24, 32), background="keep",
                                     mean=[0.485, 0.456, 0.406], std=[0.229, 0.224, 0.225])
    out = preprocess_video(frames, imagenet)
    expected = (frames[2] / 255.0 - np.array([0.485, 0.456, 0.406])) / np.array([0.229, 0.224, 0.225])
    assert np.allclose(out[2], expected.transpose(2, 0, 1), atol=1e-5)
    again = VideoProcessingConfig.from_dict(imagenet.to_dict())
    assert again == imagenet and again.to_dict()["mean"] == [0.485, 0.456, 0.406]
    with pytest.raises(ValueError, match="background 'none' is not one of"):
        VideoProcessingConfig(background="none")
    with pytest.raises(ValueError, match="one number or three"):
        VideoProcessingConfig(mean=[0.5, 0.5])


def test_bad_inputs_and_settings_are_named() -> None:
    with pytest.raises(ValueError, match="expected uint8 frames"):
        preprocess_video(np.zeros((4, 8, 8, 3), dtype=np.float32))
    with pytest.raises(ValueError, match="sampling 'random' is not one of"):
        VideoProcessingConfig(sampling="random")
    with pytest.raises(ValueError, match=r"unknown keys \['fps'\]"):
        VideoProcessingConfig.from_dict({"fps": 25})
    # a cache the config computes for itself is not a setting: named as unknown, not a TypeError from __init__
    with pytest.raises(ValueError, match=r"unknown keys \['_gel_full'\]"):
        VideoProcessingConfig.from_dict({"_gel_full": None})


def test_encoder_config_checks_and_round_trip() -> None:
    config = TactileEncoderConfig()
    assert TactileEncoderConfig.from_dict(config.to_dict()) == config
    assert config.grid == (4, 8, 8) and config.num_patches == 256
    with pytest.raises(ValueError, match="multiple of tubelet_size"):
        TactileEncoderConfig(num_frames=7)
    with pytest.raises(ValueError, match="multiple of patch_size"):
        TactileEncoderConfig(image_size=(60, 64))
    with pytest.raises(ValueError, match="tokens_per_video 300 needs more patch tokens"):
        TactileEncoderConfig(tokens_per_video=300)
    with pytest.raises(ValueError, match="must be a positive number"):
        TactileEncoderConfig(temporal_tokens=0)
    assert config.sensor_index("digit@30") == 2 and config.sensor_index("mini+markers") == 1
    assert config.sensor_index("gelsight-r1.5") == 0


def test_sensor_index_maps_variants_to_their_base_style() -> None:
    from tacreasoner.model.video_processing import sensor_index

    types = ("unknown", "mini", "digit", "tac3d")
    assert [sensor_index(s, types) for s in ("mini", "digit@60", "Mini+markers", "tac3d", "gelsight", "")] == \
        [1, 2, 1, 3, 0, 0]


def test_a_portrait_frame_is_turned_to_the_models_landscape_size() -> None:
    """``orientation: match``: a DIGIT's 320×240 frames fill a 120×160 image instead of a strip of it; frames
    already in the model's orientation are left as they are."""
    portrait = np.full((4, 32, 24, 3), 100, np.uint8)
    portrait[:, :8] = 200  # the top band of the portrait frame → the left band once turned counter-clockwise
    as_is = VideoProcessingConfig(num_frames=4, image_size=(24, 32), background="keep", mean=0.0, std=1.0)
    match = VideoProcessingConfig(num_frames=4, image_size=(24, 32), background="keep", mean=0.0, std=1.0,
                                  orientation="match")
    turned = preprocess_video(portrait, match)[0, 0]
    assert np.allclose(turned[:, :8], 200 / 255) and np.allclose(turned[:, 8:], 100 / 255)
    kept = preprocess_video(portrait, as_is)[0, 0]
    assert not np.allclose(kept, turned)
    landscape = _frames(4)
    assert np.array_equal(preprocess_video(landscape, match), preprocess_video(landscape, as_is))
    with pytest.raises(ValueError, match="orientation 'rotate' is not one of"):
        VideoProcessingConfig(orientation="rotate")


def test_magnitude_colour_is_the_size_of_the_change_without_its_colour() -> None:
    """``colour: magnitude``: an imprint lit red and the same imprint lit blue give the same input."""
    rest = np.full((3, 16, 16, 3), 100, np.uint8)
    red, blue = rest.copy(), rest.copy()
    red[1:, 4:8, 4:8, 0] = 160
    blue[1:, 4:8, 4:8, 2] = 40
    config = VideoProcessingConfig(num_frames=2, image_size=(16, 16), colour="magnitude", mean=0.5, std=1.0,
                                   sampling="uniform")
    a, b = preprocess_video(red, config), preprocess_video(blue, config)
    assert np.allclose(a, b) and np.allclose(a[:, 0], a[:, 2])
    assert np.allclose(a[-1, 0, 4:8, 4:8], 60 / 255 / np.sqrt(3)) and np.allclose(a[-1, 0, :4], 0.0)
    rgb = VideoProcessingConfig(num_frames=2, image_size=(16, 16), mean=0.5, std=1.0, sampling="uniform")
    assert not np.allclose(preprocess_video(red, rgb), preprocess_video(blue, rgb))
    with pytest.raises(ValueError, match="colour 'magnitude' needs background 'subtract'"):
        VideoProcessingConfig(background="keep", colour="magnitude")
    assert VideoProcessingConfig.from_dict(config.to_dict()) == config


def _lit_gel(seed: int, gain: tuple[float, float, float], offset: tuple[float, float, float],
             strength: tuple[float, float, float] = (40.0, 40.0, 40.0)) -> np.ndarray:
    """Eight 24×32 frames: a shaded gel with a growing imprint (``strength`` per channel at its peak), seen through a
    per-channel gain and offset."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:24, 0:32]
    base = np.stack([60 + 2 * xx, 100 + 3 * yy, 120 + xx + yy], axis=-1).astype(np.float64)
    frames = []
    for t in range(8):
        imprint = t / 7 * np.exp(-((yy - 12) ** 2 + (xx - 16) ** 2) / 30.0)
        frames.append(base + imprint[..., None] * np.asarray(strength) + rng.normal(0, 1, base.shape))
    lit = np.asarray(frames) * np.asarray(gain) + np.asarray(offset)
    return np.clip(lit, 0, 255).astype(np.uint8)


def test_gel_reference_maps_another_sensors_tint_back_and_leaves_the_reference_sensor_alone() -> None:
    seen = _lit_gel(0, (1.0, 1.0, 1.0), (0, 0, 0))
    other = _lit_gel(0, (0.6, 1.3, 0.8), (50, -40, 20))  # the same touch through another sensor's colours
    reference = measure_gel_reference([seen])
    plain = VideoProcessingConfig(num_frames=8, image_size=(24, 32), background="keep", mean=0.0, std=1.0)
    mapped = VideoProcessingConfig(num_frames=8, image_size=(24, 32), background="keep", mean=0.0, std=1.0,
                                   gel_reference=reference)
    # the seen sensor's own clip is (nearly) unchanged
    assert np.abs(preprocess_video(seen, mapped) - preprocess_video(seen, plain)).max() < 1e-3
    # the other sensor's clip comes back close to the seen one's, where unmapped it is far
    before = np.abs(preprocess_video(other, plain) - preprocess_video(seen, plain)).mean()
    after = np.abs(preprocess_video(other, mapped) - preprocess_video(seen, plain)).mean()
    assert after < before / 10 and after < 0.01
    assert np.allclose(reference["mean"], seen[0].reshape(-1, 3).mean(0) / 255, atol=1e-4)


def test_gel_image_swaps_where_another_sensors_light_falls_for_the_training_sensors() -> None:
    seen = _lit_gel(0, (1.0, 1.0, 1.0), (0, 0, 0))
    other = seen.astype(np.float64)
    yy, xx = np.mgrid[0:24, 0:32]
    lighting = np.stack([60 + 2 * xx, 100 + 3 * yy, 120 + xx + yy], axis=-1)  # _lit_gel's, lit from the far side:
    other += lighting[::-1, ::-1] - lighting  # the same tint and contrast, the light falling elsewhere
    other = np.clip(other, 0, 255).astype(np.uint8)
    base = dict(num_frames=8, image_size=(24, 32), background="keep", mean=0.0, std=1.0,
                gel_reference=measure_gel_reference([seen]))
    mapped = VideoProcessingConfig(**base)
    swapped = VideoProcessingConfig(**base, gel_image=measure_gel_image([seen], mapped))
    assert np.asarray(swapped.gel_image).shape == (6, 8, 3)  # a quarter of the model's resolution
    target = preprocess_video(seen, mapped)
    # the seen sensor's clip stays close to itself; the other's lighting, which the colour map leaves, is swapped
    assert np.abs(preprocess_video(seen, swapped) - target).mean() < 0.01
    before = np.abs(preprocess_video(other, mapped) - target).mean()
    after = np.abs(preprocess_video(other, swapped) - target).mean()
    assert before > 0.05 and after < before / 4
    # the imprint is the clip's own change from its own rest
    touched = preprocess_video(other, swapped)
    assert np.corrcoef((touched[-1] - touched[0]).ravel(), (target[-1] - target[0]).ravel())[0, 1] > 0.95


def test_gel_swap_lighting_keeps_the_clips_own_fine_detail_and_swaps_its_lighting() -> None:
    rng = np.random.default_rng(3)
    texture = rng.normal(0, 6, (24, 32, 1))  # the gel's own fine pattern, in every frame of the clip
    seen = np.clip(_lit_gel(0, (1.0, 1.0, 1.0), (0, 0, 0)) + texture, 0, 255).astype(np.uint8)
    yy, xx = np.mgrid[0:24, 0:32]
    lighting = np.stack([60 + 2 * xx, 100 + 3 * yy, 120 + xx + yy], axis=-1)
    other = np.clip(seen + lighting[::-1, ::-1] - lighting, 0, 255).astype(np.uint8)
    base = dict(num_frames=8, image_size=(24, 32), background="keep", mean=0.0, std=1.0,
                gel_reference=measure_gel_reference([seen]))
    image = measure_gel_image([seen], VideoProcessingConfig(**base))
    whole = VideoProcessingConfig(**base, gel_image=image)
    light = VideoProcessingConfig(**base, gel_image=image, gel_swap="lighting")
    assert VideoProcessingConfig.from_dict(light.to_dict()) == light and "gel_swap" not in whole.to_dict()
    target = preprocess_video(seen, VideoProcessingConfig(**base))

    def detail(video: np.ndarray, config: VideoProcessingConfig) -> float:
        first = preprocess_video(video, config)[0].mean(axis=0)  # the first frame, channels averaged
        blocks = first.reshape(6, 4, 8, 4).mean(axis=(1, 3)).repeat(4, axis=0).repeat(4, axis=1)
        return float(np.corrcoef((first - blocks).ravel(), texture[..., 0].ravel())[0, 1])  # its fine part

    assert detail(seen, whole) < 0.3 < 0.8 < detail(seen, light)  # whole: the texture went with the rest frame
    assert np.abs(preprocess_video(seen, light) - target).mean() < np.abs(preprocess_video(seen, whole) - target).mean()
    assert np.abs(preprocess_video(other, light) - target).mean() < 0.3 * np.abs(
        preprocess_video(other, VideoProcessingConfig(**base)) - target).mean()
    with pytest.raises(ValueError, match="gel_swap 'part' is not one of whole, lighting, imprint"):
        VideoProcessingConfig(**base, gel_image=image, gel_swap="part")
    with pytest.raises(ValueError, match="gel_swap 'lighting' needs gel_image"):
        VideoProcessingConfig(**base, gel_swap="lighting")


def test_gel_swap_imprint_keeps_another_sensors_imprint_at_its_own_scale() -> None:
    seen = _lit_gel(0, (1.0, 1.0, 1.0), (0, 0, 0))
    yy, xx = np.mgrid[0:24, 0:32]
    lighting = np.stack([60 + 2 * xx, 100 + 3 * yy, 120 + xx + yy], axis=-1).astype(np.float64)
    flat = seen - 0.5 * (lighting - lighting.mean(axis=(0, 1)))  # a gel lit half as unevenly, the same presses
    flat = np.clip(flat, 0, 255).astype(np.uint8)
    base = dict(num_frames=8, image_size=(24, 32), background="keep", mean=0.0, std=1.0,
                gel_reference=measure_gel_reference([seen]))
    image = measure_gel_image([seen], VideoProcessingConfig(**base))
    whole = VideoProcessingConfig(**base, gel_image=image)
    imprint = VideoProcessingConfig(**base, gel_image=image, gel_swap="imprint")
    assert VideoProcessingConfig.from_dict(imprint.to_dict()) == imprint

    def change(video: np.ndarray, config: VideoProcessingConfig) -> float:
        frames = preprocess_video(video, config)
        return float(np.abs(frames[-1] - frames[0]).mean())

    own = change(seen, VideoProcessingConfig(**base))
    assert change(flat, whole) > 1.5 * own  # the map's gain for the flatter gel inflates its imprint
    assert abs(change(flat, imprint) - own) < 0.1 * own  # kept at its own scale
    assert np.abs(preprocess_video(seen, imprint) - preprocess_video(seen, whole)).mean() < 0.01  # gain ~1: as whole


def test_imprint_gain_brings_a_stronger_sensors_imprint_to_the_trained_strength() -> None:
    seen = [_lit_gel(k, (1.0, 1.0, 1.0), (0, 0, 0)) for k in range(3)]
    strong = [_lit_gel(10 + k, (1.0, 1.0, 1.0), (0, 0, 0), strength=(72.0, 60.0, 40.0)) for k in range(3)]
    base = dict(num_frames=8, image_size=(24, 32), background="keep", mean=0.0, std=1.0,
                gel_reference=measure_gel_reference(seen))
    image = measure_gel_image(seen, VideoProcessingConfig(**base))
    whole = VideoProcessingConfig(**base, gel_image=image)
    imprint = VideoProcessingConfig(**base, gel_image=image, gel_swap="imprint")
    gain = measure_imprint_gain(strong, seen, imprint)  # other objects' presses would do: no pairing is needed
    assert np.allclose(gain, [40 / 72, 40 / 60, 1.0], atol=0.06)
    assert np.allclose(measure_imprint_gain(seen, seen, imprint), 1.0, atol=0.02)  # its own sensor: unscaled
    scaled = VideoProcessingConfig(**base, gel_image=image, gel_swap="imprint", imprint_gain=gain)
    assert VideoProcessingConfig.from_dict(scaled.to_dict()) == scaled and "imprint_gain" not in imprint.to_dict()
    trained = imprint_strength(seen[0], whole)
    assert np.abs(imprint_strength(strong[0], imprint) / trained - [1.8, 1.5, 1.0]).max() < 0.15
    assert np.abs(imprint_strength(strong[0], scaled) / trained - 1.0).max() < 0.1
    with pytest.raises(ValueError, match="imprint_gain needs gel_swap 'imprint'"):
        VideoProcessingConfig(**base, gel_image=image, imprint_gain=gain)
    with pytest.raises(ValueError, match="imprint_gain must be three numbers > 0"):
        VideoProcessingConfig(**base, gel_image=image, gel_swap="imprint", imprint_gain=[1.0, 0.0, 1.0])
    with pytest.raises(ValueError, match="needs gel_swap 'imprint'"):
        measure_imprint_gain(strong, seen, whole)
    with pytest.raises(ValueError, match="give clips of both"):
        measure_imprint_gain([], seen, imprint)


def test_gel_swap_above_leaves_the_training_sensors_clips_and_swaps_anothers() -> None:
    yy, xx = np.mgrid[0:24, 0:32]
    lighting = np.stack([60 + 2 * xx, 100 + 3 * yy, 120 + xx + yy], axis=-1)
    seen = [_lit_gel(seed, (1.0, 1.0, 1.0), (0, 0, 0)) for seed in range(3)]  # the training sensor, three clips
    other = np.clip(seen[0] + lighting[::-1, ::-1] - lighting, 0, 255).astype(np.uint8)  # lit from the far side
    base = dict(num_frames=8, image_size=(24, 32), background="keep", mean=0.0, std=1.0,
                gel_reference=measure_gel_reference(seen))
    mapped = VideoProcessingConfig(**base)
    image = measure_gel_image(seen, mapped)
    for mode in ("whole", "lighting"):
        always = VideoProcessingConfig(**base, gel_image=image, gel_swap=mode)
        above = measure_gel_swap_above(seen, always)
        assert 0 < above < 0.05
        gated = VideoProcessingConfig(**base, gel_image=image, gel_swap=mode, gel_swap_above=above)
        assert VideoProcessingConfig.from_dict(gated.to_dict()) == gated and "gel_swap_above" not in always.to_dict()
        for clip in seen:  # within every training clip's distance: exactly what the colour map alone gives
            assert np.array_equal(preprocess_video(clip, gated), preprocess_video(clip, mapped))
            assert not np.array_equal(preprocess_video(clip, always), preprocess_video(clip, mapped))
        assert np.array_equal(preprocess_video(other, gated), preprocess_video(other, always))  # another sensor
    with pytest.raises(ValueError, match="gel_swap_above needs gel_image"):
        VideoProcessingConfig(**base, gel_swap_above=0.01)
    with pytest.raises(ValueError, match="gel_swap_above must be a number ≥ 0"):
        VideoProcessingConfig(**base, gel_image=image, gel_swap_above=-0.1)
    with pytest.raises(ValueError, match="no clips"):
        measure_gel_swap_above([], gated)
    with pytest.raises(ValueError, match="needs gel_image"):
        measure_gel_swap_above(seen, mapped)


def test_gel_reference_settings_are_checked_and_saved() -> None:
    ref = {"mean": [0.2, 0.4, 0.4], "std": [0.1, 0.06, 0.1]}
    config = VideoProcessingConfig(background="keep", gel_reference=ref)
    assert VideoProcessingConfig.from_dict(config.to_dict()) == config
    assert "gel_reference" not in VideoProcessingConfig(background="keep").to_dict()  # old configs keep their key
    with pytest.raises(ValueError, match="needs background 'keep'"):
        VideoProcessingConfig(background="subtract", gel_reference=ref)
    with pytest.raises(ValueError, match="gel_reference must be"):
        VideoProcessingConfig(background="keep", gel_reference={"mean": [0.2, 0.4]})
    with pytest.raises(ValueError, match="std must be > 0"):
        VideoProcessingConfig(background="keep", gel_reference={"mean": [0.2] * 3, "std": [0.1, 0.0, 0.1]})
    with pytest.raises(ValueError, match="no clips"):
        measure_gel_reference([])
    image = [[[0.2, 0.4, 0.4]] * 4] * 3
    swapped = VideoProcessingConfig(background="keep", gel_reference=ref, gel_image=image)
    assert VideoProcessingConfig.from_dict(swapped.to_dict()) == swapped
    assert "gel_image" not in config.to_dict()
    with pytest.raises(ValueError, match="gel_image needs gel_reference"):
        VideoProcessingConfig(background="keep", gel_image=image)
    with pytest.raises(ValueError, match=r"gel_image must be an h×w×3 image in \[0, 1\]"):
        VideoProcessingConfig(background="keep", gel_reference=ref, gel_image=[[[0.2, 0.4, 1.5]]])
