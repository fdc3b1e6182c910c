"""Decode cache: hits, invalidation on edit, the byte bound, and the on-disk .npy store."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from tacreasoner.data import cache
from tacreasoner.data.cache import (
    cache_info,
    clear_cache,
    load_frames,
    reset_settings,
    set_disk_cache,
    set_memory_limit,
)
from tacreasoner.data.clip import TactileClip
from tacreasoner.video_io import write_video


@pytest.fixture(autouse=True)
def fresh_cache(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """Each test starts with an empty cache, default limits and no disk store, whatever the environment."""
    monkeypatch.delenv(cache.MEMORY_ENV, raising=False)
    monkeypatch.delenv(cache.DISK_ENV, raising=False)
    reset_settings()
    clear_cache()
    yield
    monkeypatch.undo()
    reset_settings()
    clear_cache()


def video(path: Path, value: int = 0, t: int = 5) -> Path:
    frames = np.random.default_rng(value).integers(0, 255, (t, 32, 48, 3), dtype=np.uint8)
    return write_video(path, frames, fps=10)


def test_second_load_is_a_hit_with_identical_read_only_data(tmp_path: Path) -> None:
    path = video(tmp_path / "a.mp4")
    first = load_frames(path)
    second = load_frames(str(path))  # str or Path, same key
    assert second is first and first.shape == (5, 32, 48, 3)
    info = cache_info()
    assert (info.hits, info.misses, info.bytes, info.entries) == (1, 1, first.nbytes, 1)
    with pytest.raises(ValueError, match="read-only"):
        first[0, 0, 0, 0] = 1


def test_a_modified_file_is_decoded_again(tmp_path: Path) -> None:
    path = video(tmp_path / "a.mp4", value=1)
    old = load_frames(path)
    stat = path.stat()
    video(path, value=2)
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns + 1_000_000_000))  # a new mtime even on coarse clocks
    new = load_frames(path)
    assert cache_info().misses == 2
    assert not np.array_equal(old, new)


def test_byte_bound_evicts_least_recently_used(tmp_path: Path) -> None:
    paths = [video(tmp_path / f"v{i}.mp4", value=i) for i in range(3)]
    one = load_frames(paths[0]).nbytes
    set_memory_limit(2 * one)
    load_frames(paths[1])
    load_frames(paths[0])  # v0 is now the most recent
    load_frames(paths[2])  # evicts v1
    info = cache_info()
    assert info.entries == 2 and info.bytes == 2 * one <= info.max_bytes
    load_frames(paths[0])
    assert cache_info().hits == 2
    load_frames(paths[1])
    assert cache_info().misses == 4
    set_memory_limit(0)  # disables the memory cache
    assert cache_info().entries == 0
    load_frames(paths[0])
    load_frames(paths[0])
    assert cache_info().hits == 2


def test_memory_limit_from_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(cache.MEMORY_ENV, "1.5")
    set_memory_limit(None)
    assert cache_info().max_bytes == int(1.5 * 2**20)
    monkeypatch.setenv(cache.MEMORY_ENV, "lots")
    set_memory_limit(None)
    with pytest.raises(ValueError, match="TACREASONER_DECODE_CACHE_MB"):
        cache_info()


def test_disk_cache_survives_a_cleared_memory_cache(tmp_path: Path) -> None:
    store = tmp_path / "frames"
    set_disk_cache(store)
    path = video(tmp_path / "clip_0.mp4", value=3)
    decoded = load_frames(path)
    files = list(store.glob("*.npy"))
    assert len(files) == 1 and files[0].name.startswith("clip_0.")
    clear_cache()  # a new process, as far as memory goes
    loaded = load_frames(path)
    assert cache_info().disk_hits == 1 and cache_info().misses == 0
    assert isinstance(loaded, np.memmap) and not loaded.flags.writeable
    assert np.array_equal(loaded, decoded)
    # Editing the video replaces its cache file instead of serving stale frames.
    stat = path.stat()
    video(path, value=4)
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns + 1_000_000_000))
    clear_cache()
    fresh = load_frames(path)
    assert cache_info().misses == 1 and not np.array_equal(fresh, decoded)
    assert len(list(store.glob("*.npy"))) == 1


def test_damaged_disk_file_is_rebuilt(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    store = tmp_path / "frames"
    monkeypatch.setenv(cache.DISK_ENV, str(store))
    reset_settings()  # follow the environment, as a fresh process would
    path = video(tmp_path / "clip_0.mp4")
    expected = np.array(load_frames(path))
    (npy,) = store.glob("*.npy")
    npy.write_bytes(b"garbage")
    clear_cache()
    assert np.array_equal(load_frames(path), expected) and cache_info().misses == 1


def test_clip_frames_go_through_the_cache(tmp_path: Path) -> None:
    clip = TactileClip(clip_id="c", object_id="o", fps=10, path=video(tmp_path / "c_0.mp4"))
    assert clip.frames is clip.frames
    assert cache_info().hits == 1
    with pytest.raises(FileNotFoundError, match=r"gone\.mp4"):
        load_frames(tmp_path / "gone.mp4")
