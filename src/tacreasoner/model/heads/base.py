"""The one interface of the read-out heads: fitted on fixed encoder features, read as a verdict, written as vectors.

Every head (clip reader, comparator, name matcher; the option marks carry the matcher's verdict into the text) is
fitted in closed form (or nearly) on the frozen encoder's output for training prompts when Stage II starts, reads
one verdict per prompt, and writes that verdict into the tokens as trainable vectors. Fitting and reading go through
:class:`HeadRows`, so that one routine can fit any head out of fold (:mod:`tacreasoner.model.heads.crossfit`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import torch

__all__ = ["HeadRows", "ReadoutHead"]


@dataclass
class HeadRows:
    """Prompts as a head sees them: per prompt its videos' encoder output, plus what the head reads besides.

    ``videos``: per prompt k×N×H; ``questions``: S×Dq question vectors (the comparator reads which attribute and
    which way); ``options``: per prompt its listed options' name vectors (the name matcher); ``targets``: per prompt
    the head's gold (its own format: levels per video, a pick, an assignment), None where a prompt has none."""

    videos: list[torch.Tensor]
    questions: torch.Tensor | None = None
    options: list[torch.Tensor] | None = None
    targets: list[Any] | None = None

    def __len__(self) -> int:
        return len(self.videos)

    def subset(self, rows: Sequence[int]) -> HeadRows:
        index = list(rows)
        return HeadRows(videos=[self.videos[i] for i in index],
                        questions=None if self.questions is None else self.questions[index],
                        options=None if self.options is None else [self.options[i] for i in index],
                        targets=None if self.targets is None else [self.targets[i] for i in index])


@runtime_checkable
class ReadoutHead(Protocol):
    """A benchmark-specific read-out plugged into the projector. Optional: the paper's model has none."""

    name: str
    reading: str
    """The ``readings=`` key its verdicts travel under (:data:`READINGS`)."""

    def fit_rows(self, rows: HeadRows, seed: int = 0) -> dict[str, Any]:
        """Fit on the prompts of ``rows`` that have a target, freeze the fitted part; what it was fitted on and how
        well it reads those prompts back. A ValueError when no prompt has a target."""
        ...

    def read_rows(self, rows: HeadRows) -> list[torch.Tensor]:
        """Per prompt its verdict, in the form the projector writes (:data:`READINGS`)."""
        ...

    def silent(self, rows: HeadRows, i: int) -> torch.Tensor:
        """The verdict of prompt ``i`` that says nothing (its fold's copy had nothing to fit on)."""
        ...


READINGS = {
    "clip_reader": "levels: per video its level of each trait (V×traits, −1 none)",
    "comparator": "pick: per prompt a score per video (B×max videos; the verdict is their softmax)",
    "name_matcher": "places: per prompt the video place of each listed option (B×options, −1 not matched)",
}
"""What each head reads, and how a batch hands the model readings made elsewhere (``readings=`` of forward)."""
