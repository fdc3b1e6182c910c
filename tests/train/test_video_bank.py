"""VideoBank: worker processes give exactly the in-process arrays, write the disk cache, and name a bad file."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from tacreasoner.model.video_processing import VideoProcessingConfig
from tacreasoner.train.data import MIN_CLIPS_PER_POOL, VideoBank
from tacreasoner.video_io import write_video

CONFIG = VideoProcessingConfig(num_frames=4, image_size=(16, 16))


def _clips(root: Path, n: int) -> list[Path]:
    rng = np.random.default_rng(0)
    paths = []
    for i in range(n):
        sensor = "digit" if i % 3 == 0 else "mini"
        frames = np.full((12, 32, 32, 3), 120, np.uint8)
        frames[4:9, 8:24, 8:24] += rng.integers(0, 60, (5, 16, 16, 3), dtype=np.uint8)  # a press
        path = root / "clips" / sensor / f"clip_{i}.mp4"
        path.parent.mkdir(parents=True, exist_ok=True)
        write_video(path, frames, 10.0)
        paths.append(path)
    return paths


def _keys(paths: list[Path]) -> list[tuple[str, int | None, int | None]]:
    keys = [(str(p), None, None) for p in paths]
    keys += [(str(paths[0]), 2, 10), (str(paths[0]), 0, 6), (str(paths[1]), 3, 12)]  # segments share a decode
    return keys + keys[:3]  # repeats count once


def _bank(keys, **kwargs) -> VideoBank:
    bank = VideoBank(CONFIG, ["mini", "digit"])
    bank.build(keys, **kwargs)
    return bank


def test_workers_give_the_in_process_arrays_and_fill_the_disk_cache(tmp_path: Path) -> None:
    keys = _keys(_clips(tmp_path, MIN_CLIPS_PER_POOL + 1))
    alone = _bank(keys, workers=1)
    seen: list[tuple[int, int]] = []
    pooled = _bank(keys, workers=2, cache_dir=tmp_path / "cache", progress=lambda d, t: seen.append((d, t)))
    assert pooled.index == alone.index and len(alone.index) == len(set(keys))
    assert torch.equal(pooled.pixels, alone.pixels)
    assert torch.equal(pooled.sensors, alone.sensors) and set(alone.sensors.tolist()) == {0, 1}
    assert seen[-1] == (len(set(keys)), len(set(keys)))
    assert len(list((tmp_path / "cache").glob("*.npy"))) == len(set(keys))
    again: list[tuple[int, int]] = []
    cached = _bank(keys, workers=2, cache_dir=tmp_path / "cache", progress=lambda d, t: again.append((d, t)))
    assert again == [(len(set(keys)), len(set(keys)))]  # all from the disk cache, nothing left to decode
    assert torch.equal(cached.pixels, alone.pixels)


@pytest.mark.parametrize("workers", [1, 2])
def test_an_undecodable_video_names_its_file(tmp_path: Path, workers: int) -> None:
    paths = _clips(tmp_path, MIN_CLIPS_PER_POOL)
    paths[5].write_bytes(b"not a video")
    with pytest.raises(ValueError, match=f"{paths[5].name}: cannot decode training video"):
        _bank([(str(p), None, None) for p in paths], workers=workers)


def test_appearance_tokens_are_kept_on_disk_per_encoder(tmp_path: Path) -> None:
    """The frozen branch's tokens of every video, computed once and read back by the next stage or seed; another
    encoder (other weights) never reads them, and standardisation is applied on top of the raw tokens kept."""
    from tacreasoner.model.encoder_config import TactileEncoderConfig
    from tacreasoner.model.tactile_encoder import DynamicTactileEncoder

    keys = _keys(_clips(tmp_path, 3))
    bank = _bank(keys)
    config = TactileEncoderConfig(num_frames=4, image_size=(16, 16), patch_size=8, hidden_size=16, num_layers=1,
                                  num_heads=2, fusion_heads=2, temporal_hidden_size=16, tokens_per_video=3)
    torch.manual_seed(0)
    encoder = DynamicTactileEncoder(config, question_dim=8).eval()
    raw = bank.cache_appearance(encoder, cache_dir=tmp_path / "cache")
    assert raw is not None and raw.shape == (len(bank.index), 3, 16)
    files = list((tmp_path / "cache" / "appearance").rglob("*.npy"))
    assert len(files) == len(bank.index)
    calls: list[int] = []
    original = encoder.appearance.forward
    encoder.appearance.forward = lambda *a, **k: calls.append(1) or original(*a, **k)
    assert torch.equal(bank.cache_appearance(encoder, cache_dir=tmp_path / "cache"), raw) and not calls
    other = DynamicTactileEncoder(config, question_dim=8).eval()  # new random weights: its own tokens
    assert not torch.equal(bank.cache_appearance(other, cache_dir=tmp_path / "cache"), raw)
    assert len(list((tmp_path / "cache" / "appearance").iterdir())) == 2
    standardized = config.replace(standardize_appearance=True)
    encoder.config = standardized
    encoder.set_appearance_statistics(raw)
    bank.cache_appearance(encoder, cache_dir=tmp_path / "cache")
    flat = bank.appearance.reshape(-1, 16).double()
    assert flat.mean(0).abs().max() < 1e-4 and (flat.std(0) - 1).abs().max() < 1e-3


def test_the_decoding_processes_follow_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    from tacreasoner.train.data import VIDEO_WORKERS_ENV, _video_workers

    monkeypatch.setenv(VIDEO_WORKERS_ENV, "12")
    assert _video_workers(None) == 12
    assert _video_workers(3) == 3  # an explicit argument wins
    monkeypatch.setenv(VIDEO_WORKERS_ENV, "many")
    with pytest.raises(ValueError, match=f"{VIDEO_WORKERS_ENV}='many'"):
        _video_workers(None)
    monkeypatch.delenv(VIDEO_WORKERS_ENV)
    assert 1 <= _video_workers(None) <= 2
