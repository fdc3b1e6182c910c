"""What the serving tests share: the two questions the test model was taught, their replies, synthetic clips."""

from __future__ import annotations

import socket

import numpy as np

TEXTS = ["<think>The imprint is deep and wide, so it is soft.</think><answer>soft</answer>",
         "Is <tactile> soft or hard? Which of <tactile> and <tactile> is rougher? (A) first (B) second",
         "<think>Video 1 shows fine texture; video 2 is smooth.</think><answer>A</answer>"] * 20
ONE = "Is <tactile> soft or hard?"
TWO = "Which of <tactile> and <tactile> is rougher? (A) first (B) second"
REPLIES = {ONE: "<think>The imprint is deep and wide, so it is soft.</think><answer>soft</answer>",
           TWO: "<think>Video 1 shows fine texture; video 2 is smooth.</think><answer>A</answer>"}


def press_clip(seed: int = 0, frames: int = 12, size: int = 48) -> np.ndarray:
    """A synthetic press: a blob that grows and fades on a flat gel, T×H×W×3 uint8."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:size, 0:size]
    out = np.full((frames, size, size, 3), 120, np.uint8)
    for t in range(frames):
        depth = np.sin(np.pi * t / (frames - 1))
        blob = np.exp(-((xx - size / 2) ** 2 + (yy - size / 2) ** 2) / (2 * (4 + 6 * depth) ** 2)) * 60 * depth
        out[t] = np.clip(120 + blob[..., None] * np.array([1.0, 0.6, 0.3]) + rng.normal(0, 1, (size, size, 3)),
                         0, 255).astype(np.uint8)
    return out


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]
