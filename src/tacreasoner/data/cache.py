"""Decode cache for tactile videos, so training epochs decode each clip once, not once per epoch.

Two levels:

* **memory**: an in-process LRU bounded by bytes (default 2 GiB; ``TACREASONER_DECODE_CACHE_MB``,
  or :func:`set_memory_limit`). 0 disables it.
* **disk** (optional): decoded frames as ``.npy`` files in ``TACREASONER_FRAME_CACHE_DIR`` or the
  directory given to :func:`set_disk_cache`, loaded with ``mmap`` so a new process (or a DataLoader
  worker) skips decoding and pages in only what it touches.

Entries are keyed by (resolved path, mtime_ns, size): editing or replacing a video re-decodes it.
Returned arrays are read-only because they are shared between callers; copy before modifying.
"""

from __future__ import annotations

import hashlib
import os
import secrets
import threading
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tacreasoner.video_io import read_video

__all__ = [
    "CacheInfo",
    "cache_info",
    "clear_cache",
    "disk_cache_dir",
    "load_frames",
    "reset_settings",
    "set_disk_cache",
    "set_memory_limit",
]

DEFAULT_MEMORY_MB = 2048
MEMORY_ENV = "TACREASONER_DECODE_CACHE_MB"
DISK_ENV = "TACREASONER_FRAME_CACHE_DIR"

_Key = tuple[str, int, int]


@dataclass(frozen=True)
class CacheInfo:
    """Counters since the last :func:`clear_cache`; ``hits + disk_hits + misses`` = calls."""

    hits: int
    """Served from memory."""
    misses: int
    """Decoded from the video file."""
    bytes: int
    """Bytes of frames held in memory now."""
    disk_hits: int
    entries: int
    max_bytes: int
    disk_dir: Path | None


class _DecodeCache:
    """LRU of decoded clips plus the optional ``.npy`` store; thread-safe (decoding runs unlocked)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._entries: OrderedDict[_Key, np.ndarray] = OrderedDict()
        self._bytes = 0
        self._max_bytes: int | None = None  # None: read the environment on first use
        self._disk: Path | None = None
        self._disk_set = False  # set_disk_cache() called: ignore the environment
        self.hits = self.misses = self.disk_hits = 0

    # ------------------------------------------------------------------------------------ settings

    @property
    def max_bytes(self) -> int:
        if self._max_bytes is None:
            self._max_bytes = _env_megabytes()
        return self._max_bytes

    def set_limit(self, max_bytes: int | None) -> None:
        if max_bytes is not None and max_bytes < 0:
            raise ValueError(f"memory limit must be >= 0 bytes (0 disables the cache), got {max_bytes}")
        with self._lock:
            self._max_bytes = max_bytes
            self._evict()

    @property
    def disk(self) -> Path | None:
        if self._disk_set:
            return self._disk
        env = os.environ.get(DISK_ENV, "").strip()
        return Path(env).expanduser() if env else None

    def set_disk(self, directory: str | os.PathLike[str] | None) -> None:
        self._disk_set = True
        self._disk = Path(directory).expanduser() if directory is not None else None

    # ------------------------------------------------------------------------------------ lookups

    def load(self, path: str | os.PathLike[str]) -> np.ndarray:
        key = _key(path)
        with self._lock:
            frames = self._entries.get(key)
            if frames is not None:
                self._entries.move_to_end(key)
                self.hits += 1
                return frames
        disk = self.disk
        frames = _disk_load(disk, key) if disk is not None else None
        if frames is not None:
            counter = "disk_hits"
        else:
            counter = "misses"
            frames, _ = read_video(key[0])
            frames.flags.writeable = False
            if disk is not None:
                _disk_store(disk, key, frames)
        with self._lock:
            setattr(self, counter, getattr(self, counter) + 1)
            self._insert(key, frames)
        return frames

    def _insert(self, key: _Key, frames: np.ndarray) -> None:
        if frames.nbytes > self.max_bytes:
            return  # would evict everything else and still not fit
        old = self._entries.pop(key, None)
        if old is not None:
            self._bytes -= old.nbytes
        self._entries[key] = frames
        self._bytes += frames.nbytes
        self._evict()

    def _evict(self) -> None:
        while self._entries and self._bytes > self.max_bytes:
            _, frames = self._entries.popitem(last=False)
            self._bytes -= frames.nbytes

    def reset_settings(self) -> None:
        with self._lock:
            self._max_bytes = None
            self._disk, self._disk_set = None, False
            self._evict()

    def info(self) -> CacheInfo:
        with self._lock:
            return CacheInfo(self.hits, self.misses, self._bytes, self.disk_hits, len(self._entries),
                             self.max_bytes, self.disk)

    def clear(self) -> None:
        with self._lock:
            self._entries.clear()
            self._bytes = 0
            self.hits = self.misses = self.disk_hits = 0


def _env_megabytes() -> int:
    raw = os.environ.get(MEMORY_ENV, "").strip()
    if not raw:
        return DEFAULT_MEMORY_MB * 2**20
    try:
        mb = float(raw)
    except ValueError:
        raise ValueError(f"{MEMORY_ENV}={raw!r}: expected a number of megabytes (0 disables the cache)") from None
    if mb < 0 or not np.isfinite(mb):
        raise ValueError(f"{MEMORY_ENV}={raw!r}: expected a number of megabytes >= 0")
    return int(mb * 2**20)


def _key(path: str | os.PathLike[str]) -> _Key:
    resolved = Path(path).expanduser().resolve()
    try:
        st = resolved.stat()
    except FileNotFoundError:
        raise FileNotFoundError(f"{path}: no such video file") from None
    return (str(resolved), st.st_mtime_ns, st.st_size)


def _disk_names(key: _Key) -> tuple[str, str]:
    """``<stem>.<path hash>.`` prefix (same for every version of a file) and the full file name."""
    path_hash = hashlib.sha1(key[0].encode()).hexdigest()[:12]
    version = hashlib.sha1(f"{key[1]}:{key[2]}".encode()).hexdigest()[:8]
    prefix = f"{Path(key[0]).stem}.{path_hash}."
    return prefix, f"{prefix}{version}.npy"


def _disk_load(directory: Path, key: _Key) -> np.ndarray | None:
    file = directory / _disk_names(key)[1]
    if not file.exists():
        return None
    try:
        frames = np.load(file, mmap_mode="r", allow_pickle=False)
    except (OSError, ValueError):
        file.unlink(missing_ok=True)  # a damaged cache file: decode again and rewrite it
        return None
    if frames.ndim != 4 or frames.dtype != np.uint8 or frames.shape[-1] != 3:
        file.unlink(missing_ok=True)
        return None
    return frames


def _disk_store(directory: Path, key: _Key, frames: np.ndarray) -> None:
    """Write atomically (temp file + rename) and drop stale versions of the same video."""
    prefix, name = _disk_names(key)
    try:
        directory.mkdir(parents=True, exist_ok=True)
        tmp = directory / f".{name}.{secrets.token_hex(4)}.tmp"
        try:
            with tmp.open("wb") as fh:
                np.save(fh, frames, allow_pickle=False)
            os.replace(tmp, directory / name)
        finally:
            tmp.unlink(missing_ok=True)
        for old in directory.glob(f"{prefix}*.npy"):
            if old.name != name:
                old.unlink(missing_ok=True)
    except OSError as exc:
        raise OSError(f"frame cache directory {directory}: cannot write {name} ({exc.strerror or exc})") from exc


_CACHE = _DecodeCache()


def load_frames(path: str | os.PathLike[str]) -> np.ndarray:
    """T×H×W×3 uint8 frames of a video, decoded at most once per file version (read-only array)."""
    return _CACHE.load(path)


def cache_info() -> CacheInfo:
    return _CACHE.info()


def clear_cache() -> None:
    """Empty the memory cache and reset the counters (disk files stay: they are still valid)."""
    _CACHE.clear()


def set_memory_limit(max_bytes: int | None) -> None:
    """Bound the memory cache in bytes (0 disables it; None: back to the environment/default)."""
    _CACHE.set_limit(max_bytes)


def set_disk_cache(directory: str | os.PathLike[str] | None) -> None:
    """Use ``directory`` for the ``.npy`` frame cache, or None for no disk cache (overrides the environment)."""
    _CACHE.set_disk(directory)


def reset_settings() -> None:
    """Forget :func:`set_memory_limit` / :func:`set_disk_cache`: follow the environment again."""
    _CACHE.reset_settings()


def disk_cache_dir() -> Path | None:
    return _CACHE.disk
