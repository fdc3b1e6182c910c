"""Shared fixtures: one small simulated dataset per test run (rendering is the slow part), free ports.

The suite runs in parallel processes (pytest-xdist, the README's test command): :func:`tests.shared.built_once`
builds an expensive read-only input once for the whole run, shared by every worker, instead of once per worker."""

from __future__ import annotations

import os
import socket
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from tacreasoner.sim.generate import generate_dataset
from tests.shared import built_once


def pytest_configure(config: pytest.Config) -> None:
    """Under pytest-xdist the workers share the cores: each gets its share as its torch threads and, through
    OMP_NUM_THREADS (which ``train.threads.available_cores`` reads), decodes training videos in-process instead of
    starting decoding processes of its own. Tests of more processes ask for them explicitly."""
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    if os.environ.get("PYTEST_XDIST_WORKER") and workers > 1 and "OMP_NUM_THREADS" not in os.environ:
        threads = max(1, (os.cpu_count() or 1) // workers)
        os.environ["OMP_NUM_THREADS"] = str(threads)
        if "torch" in sys.modules:
            sys.modules["torch"].set_num_threads(threads)


@pytest.fixture(scope="session")
def small_sim_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """14 objects (10 fruit, so real and fake in every split) × 2 repeats × Mini and DIGIT."""
    return built_once(tmp_path_factory, "small_sim", lambda root: generate_dataset(
        root, n_objects=14, repeats=2, sensors=["mini", "digit"], seed=3, workers=2))


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def free_port() -> Callable[[], int]:
    """A TCP port nobody listens on now, per call: a rendezvous address for a launched process group."""
    return _free_port


def write_gel_clip(path: Path, ranks: tuple[int, int, int], rng: Any, frames: int = 12,
                   size: tuple[int, int] = (48, 64)) -> None:
    """One clip of a gel pressed by a blob whose size follows the hardness rank and whose texture the roughness
    rank: what a reader of PhysiCLeAR-shaped folders needs, without the shared videos."""
    import numpy as np

    from tacreasoner.video_io import write_video

    h, w = size
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    gel = np.full((frames, h, w, 3), 110.0, np.float32) + rng.normal(0, 2, (1, h, w, 3))
    cy, cx = rng.uniform(0.3 * h, 0.7 * h), rng.uniform(0.3 * w, 0.7 * w)
    for t in range(frames // 3, frames):
        r = (3 + 2 * ranks[0]) * min(1.0, (t - frames // 3 + 1) / 3)
        blob = np.exp(-((yy - cy) ** 2 + (xx - cx) ** 2) / (2 * r * r))
        texture = np.sin(xx * (0.5 + ranks[1])) * 6 * blob
        gel[t] += (blob * 40)[..., None] + texture[..., None]
    write_video(path, np.clip(gel, 0, 255).astype(np.uint8), fps=25)


def write_labelled_folder(root: Path, objects: dict[str, tuple[str, tuple[int, int, int] | None]],
                          clips_per_object: int = 2, ext: str = "mp4", seed: int = 0, **clip: Any) -> Path:
    """A folder in PhysiCLeAR's layout (labels.json + videos/) holding ``objects``: name → (split, its hardness,
    roughness and bumpiness ranks, or None for an unlabelled object); clips ``videos/<name>_<j>.<ext>``."""
    import json

    import numpy as np

    rng = np.random.default_rng(seed)
    (root / "videos").mkdir(parents=True, exist_ok=True)
    labels = {}
    for name, (split, ranks) in objects.items():
        videos = [f"videos/{name}_{j}.{ext}" for j in range(clips_per_object)]
        for rel in videos:
            write_gel_clip(root / rel, ranks or (1, 1, 1), rng, **clip)
        entry: dict[str, Any] = {"split": split, "videos": videos}
        if ranks is not None:
            entry.update(name=name.replace("_", " "), hardness=ranks[0], roughness=ranks[1], bumpiness=ranks[2])
        labels[name] = entry
    (root / "labels.json").write_text(json.dumps({"objects": labels}))
    return root


def write_physiclear_folder(root: Path, splits: dict[str, int], clips_per_object: int = 2, frames: int = 12,
                            size: tuple[int, int] = (48, 64), seed: int = 0) -> Path:
    """A synthetic folder in PhysiCLeAR's layout: ``splits`` maps a split name to its number of objects; each object
    gets hardness/roughness/bumpiness ranks cycling through 0–2 (so every task finds objects to compare). No shared
    data needed: features that read PhysiCLeAR are tested on a plain clone with it."""
    objects: dict[str, tuple[str, tuple[int, int, int] | None]] = {}
    k = 0
    for split, count in splits.items():
        for i in range(count):
            labelled = split not in ("unlabeled", "unlabelled")
            objects[f"{split}_object_{i}"] = (split, (k % 3, (k // 3) % 3, (k + 1) % 3) if labelled else None)
            k += 1
    return write_labelled_folder(root, objects, clips_per_object, seed=seed, frames=frames, size=size)


@pytest.fixture(scope="session")
def physiclear_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A small synthetic PhysiCLeAR-shaped folder: 9 train, 4 val, 3 test and 2 unlabelled objects."""
    return built_once(tmp_path_factory, "physiclear", lambda root: write_physiclear_folder(
        root, {"train": 9, "val": 4, "test": 3, "unlabeled": 2}))


@pytest.fixture
def make_physiclear_folder() -> Callable[..., Path]:
    """:func:`write_physiclear_folder`, for a test that needs its own layout."""
    return write_physiclear_folder
