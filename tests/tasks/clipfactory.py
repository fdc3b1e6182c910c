"""Synthetic labelled clips for the QA builder and format tests: simulator labels, no video files."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tacreasoner.data.clip import TactileClip
from tacreasoner.sim.materials import build_object_set, derive_labels


def synthetic_phases(rng: np.random.Generator, action: str) -> list[str]:
    """Protocol-shaped phases with jittered run lengths (some contact runs shorter than 4 frames)."""
    runs = [("no_contact", 2, 4), ("press", 3, 8), ("hold", 2, 7), (action, 3, 9), ("release", 2, 6),
            ("no_contact", 1, 3)]
    return [name for name, lo, hi in runs for _ in range(int(rng.integers(lo, hi + 1)))]


def make_clips(n_objects: int = 40, repeats: int = 3, seed: int = 0, with_paths: bool = False) -> list[TactileClip]:
    rng = np.random.default_rng(seed)
    clips = []
    for m in build_object_set(n_objects, seed=seed):
        for k in range(repeats):
            action = "slide" if k % 2 == 0 else "rotate"
            phases = synthetic_phases(rng, action)
            clip_id = f"mini/{m.name}_{k}"
            clips.append(TactileClip(
                clip_id=clip_id, object_id=m.name, fps=25.0,
                path=Path(f"clips/{clip_id}.mp4") if with_paths else None,
                frames_in_memory=np.zeros((len(phases), 4, 4, 3), np.uint8), sensor="mini",
                object_name=m.display_name, category=m.category, material=m.material, labels=derive_labels(m),
                phases=phases, action=action, source="sim",
            ))
    return clips
