"""VideoBank: worker processes give exactly the in-process arrays, write the disk cache, and name a bad file."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from tacreasoner.data.video import write_video
from tacreasoner.model.video_processing import VideoProcessingConfig
from tacreasoner.train.data import MIN_CLIPS_PER_POOL, VideoBank

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
