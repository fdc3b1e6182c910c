"""``TactileClip``: one tactile video with what is known about it, frames loaded lazily."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


@dataclass
class TactileClip:
    """A tactile video plus labels. Frames are decoded on first access unless given in memory.

    ``labels`` follows the simulator's layout: ``{"vtv150k": {attribute: rank}, "physiclear":
    {attribute: rank}, "real": bool | None}``; a source fills the vocabularies it has.
    """

    clip_id: str
    object_id: str
    fps: float
    path: Path | None = None
    frames_in_memory: np.ndarray | None = None
    sensor: str = "unknown"
    object_name: str = ""
    category: str = ""
    material: str = ""
    labels: dict = field(default_factory=dict)
    phases: list[str] | None = None
    """Per-frame phase labels when known (simulator ground truth or a detector)."""
    action: str | None = None
    n_frames: int | None = None
    source: str = ""
    split: str = ""
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.path is None and self.frames_in_memory is None:
            raise ValueError(f"clip {self.clip_id!r}: needs a video path or frames")
        if self.frames_in_memory is not None:
            self.n_frames = len(self.frames_in_memory)

    @property
    def frames(self) -> np.ndarray:
        """T×H×W×3 uint8 frames (decoded through the shared decode cache)."""
        if self.frames_in_memory is not None:
            return self.frames_in_memory
        from tacreasoner.data.cache import load_frames

        return load_frames(self.path)

    @property
    def background(self) -> np.ndarray:
        """The first no-contact frame (the first frame when phases are unknown)."""
        frames = self.frames
        if self.phases:
            for i, p in enumerate(self.phases):
                if p == "no_contact":
                    return frames[i]
        return frames[0]

    def rank(self, vocabulary: str, attribute: str) -> int | None:
        return (self.labels.get(vocabulary) or {}).get(attribute)

    @property
    def is_real(self) -> bool | None:
        return self.labels.get("real")
