"""A saved tiny model taught two replies (the serving path is what is tested) and synthetic clips on disk."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from tacreasoner.video_io import write_video
from tests.evaluate.evalsetup import save_untrained_model
from tests.serve.served import REPLIES, TEXTS, press_clip
from tests.shared import built_once


@pytest.fixture(scope="session")
def served_model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A tiny model taught two fixed replies (a few seconds of training), so that streams carry reasoning, an
    answer and an end of turn like a trained model's; other questions get its noise."""
    return built_once(tmp_path_factory, "served", _teach_two_replies) / "taught"


def _teach_two_replies(root: Path) -> None:
    import torch

    from tacreasoner.model.build import load_model, save_model

    model, processor = load_model(save_untrained_model(TEXTS, root, vocab_size=400))
    examples = [processor.example(q, a, [press_clip(k) for k in range(q.count("<tactile>"))])
                for q, a in REPLIES.items()]
    batch = processor.collate(examples)
    torch.manual_seed(0)
    optimizer = torch.optim.AdamW(model.parameters(), lr=3e-3)
    model.train()
    for _ in range(80):
        loss = model(**batch).loss
        loss.backward()
        optimizer.step()
        optimizer.zero_grad()
    save_model(model.eval(), processor, root / "taught")


@pytest.fixture(scope="session")
def clip_files(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    root = tmp_path_factory.mktemp("clips")
    return [write_video(root / f"press_{k}.mp4", press_clip(k), fps=10) for k in range(3)]


@pytest.fixture
def write_clip(tmp_path: Path) -> Callable[..., Path]:
    """``write_clip(name, frames, fps=10)``: frames as a video file in the test's folder (a one-frame clip, say)."""

    def write(name: str, frames: object, fps: float = 10) -> Path:
        return write_video(tmp_path / name, frames, fps=fps)  # type: ignore[arg-type]

    return write
