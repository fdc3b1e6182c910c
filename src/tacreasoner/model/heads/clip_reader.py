"""A fitted read-out of one clip's traits (attribute levels, real or fake, contact state), written into its tokens.

The Stage I model, with the LLM frozen, reads single clips' hardness, elasticity, real-vs-fake and contact state
well above chance; Stage II's LoRA then trades those readings for the comparisons it is taught (docs/training.md,
the ablation table: w/o Stage II reads hardness 60%, RFOR 76%, the full model 31%, 50%). Yet a linear read-out of
the frozen encoder's output keeps them (benchmarks/results/tactile_readout.md). So, as the cross-video comparator
does for picks, the read-out is fitted on the frozen encoder's features when Stage II starts (a ridge classifier per
trait, closed form) and frozen, and the video of a one-video prompt carries in its tokens one loud vector per trait
for the level it reads (``TactileProjector.project``; in comparisons the levels blurred the comparator's pick): the
LLM learns to name a level from a vector that says it, not from a faint direction in the features.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import torch
from torch import nn

from tacreasoner.model.fitting import as_loud_as_a_token, ridge_solve
from tacreasoner.model.heads.base import HeadRows

__all__ = ["ClipReader"]


class ClipReader(nn.Module):
    """videos V×N×H → the same tokens plus, per trait the reader was fitted for, the vector of the level it reads.

    ``traits``: the names of what it reads (``encoder.clip_reader_traits``; which traits and what their levels mean
    is the training data's business, not the model's), ``levels``: the most levels of one trait. Until :meth:`fit`
    nothing is known and the tokens pass unchanged (Stage I). The read-out is a buffer, set in closed form and never
    trained; the level vectors start as loud as a token and train with the projector."""

    name = "clip_reader"
    reading = "levels"

    def __init__(self, hidden: int, tokens_per_video: int, traits: Sequence[str], levels: int) -> None:
        super().__init__()
        if not traits or levels < 2:
            raise ValueError(f"the clip reader needs at least one trait and two levels, got {list(traits)!r} and "
                             f"{levels}")
        self.traits = tuple(traits)
        width, slots = tokens_per_video * hidden, len(self.traits) * levels
        self.register_buffer("readout_weight", torch.zeros(slots, width))
        self.register_buffer("readout_bias", torch.zeros(slots))
        self.register_buffer("known", torch.zeros(len(self.traits), levels, dtype=torch.bool))
        self.readings = nn.Parameter(torch.zeros(len(self.traits), levels, hidden))

    @property
    def levels_per_trait(self) -> int:
        return self.known.shape[1]

    @property
    def fitted(self) -> bool:
        return bool(self.known.any())

    def levels(self, videos: torch.Tensor) -> torch.Tensor:
        """V×traits: the level read for each trait among the levels seen in fitting (−1 for a trait not fitted)."""
        flat = videos.flatten(1).to(self.readout_weight.dtype)
        scores = (flat @ self.readout_weight.T + self.readout_bias).view(len(videos), *self.known.shape)
        scores = scores.masked_fill(~self.known, float("-inf"))
        return torch.where(self.known.any(-1), scores.argmax(-1), -1)

    def forward(self, videos: torch.Tensor) -> torch.Tensor:
        return videos + self.vectors(videos).unsqueeze(1)

    def vectors(self, videos: torch.Tensor, levels: torch.Tensor | None = None) -> torch.Tensor:
        """V×H: the sum of the vectors of the levels read (zeros before :meth:`fit`). ``levels`` (V×traits, −1 =
        none): readings made elsewhere, written instead of this reader's own (training's out-of-fold readings,
        :func:`~tacreasoner.model.heads.crossfit.crossfit`)."""
        if levels is None:
            if not self.fitted:
                return videos.new_zeros(len(videos), videos.shape[-1])
            levels = self.levels(videos.detach())
        traits = torch.arange(len(self.traits), device=videos.device).expand_as(levels)
        vectors = self.readings[traits, levels.clamp(min=0)] * (levels >= 0).unsqueeze(-1).to(self.readings.dtype)
        return vectors.sum(1).to(videos.dtype)

    def fit(self, videos: torch.Tensor, labels: torch.Tensor, penalty: float = 100.0, seed: int = 0
            ) -> dict[str, dict[str, float]]:
        """Fit one ridge classifier per trait on the videos labelled for it, then freeze the read-out.

        ``videos``: V×N×H frozen encoder output; ``labels``: V×traits (order of ``traits``), the level of
        each trait or −1 where unknown. Returns per trait fitted the number of videos and the share read right."""
        levels = self.levels_per_trait
        if videos.ndim != 3 or labels.shape != (len(videos), len(self.traits)):
            raise ValueError(f"the clip reader needs V×N×H videos and V×{len(self.traits)} labels, got "
                             f"{tuple(videos.shape)} and {tuple(labels.shape)}")
        if bool((labels >= levels).any()):
            raise ValueError(f"a trait level is {int(labels.max())}, past the reader's {levels} levels")
        x = videos.flatten(1).float()
        weight = torch.zeros_like(self.readout_weight, dtype=torch.float64)
        bias = torch.zeros_like(self.readout_bias, dtype=torch.float64)
        known = torch.zeros_like(self.known)
        for t in range(len(self.traits)):
            rows = labels[:, t] >= 0
            seen = labels[rows, t].unique()
            if len(seen) < 2:  # nothing to tell apart
                continue
            onehot = torch.nn.functional.one_hot(labels[rows, t], levels).double()
            w, b = ridge_solve(x[rows], onehot, penalty)
            block = slice(t * levels, (t + 1) * levels)
            weight[block], bias[block] = w, b
            known[t, seen] = True
        if not bool(known.any()):
            raise ValueError("the clip reader needs, for at least one trait, videos labelled with two levels or more")
        with torch.no_grad():
            self.readout_weight.copy_(weight.to(self.readout_weight.dtype))
            self.readout_bias.copy_(bias.to(self.readout_bias.dtype))
            self.known.copy_(known)
            generator = torch.Generator().manual_seed(seed)
            self.readings.copy_(as_loud_as_a_token(x, self.readings.shape, generator).to(self.readings.dtype))
            read = self.levels(videos)
        out = {}
        for t, trait in enumerate(self.traits):
            rows = labels[:, t] >= 0
            if bool(known[t].any()):
                right = (read[rows, t] == labels[rows, t]).float().mean()
                out[trait] = {"videos": int(rows.sum()), "read": float(right)}
        return out

    # ---------------------------------------------------------------- the read-out head interface (heads.base)
    def fit_rows(self, rows: HeadRows, seed: int = 0) -> dict[str, Any]:
        """Fit on every video of ``rows`` with a label (``rows.targets``: per prompt k×traits levels, −1 unknown)."""
        videos, labels = _labelled_videos(rows)
        if not len(videos):
            raise ValueError("the clip reader has no labelled video to fit on")
        return {"videos": len(videos), **self.fit(videos, labels, seed=seed)}

    def read_rows(self, rows: HeadRows) -> list[torch.Tensor]:
        """Per prompt its videos' levels (k×traits, −1 where a trait was not fitted)."""
        with torch.no_grad():
            return [self.levels(v) for v in rows.videos]

    def silent(self, rows: HeadRows, i: int) -> torch.Tensor:
        return torch.full((len(rows.videos[i]), len(self.traits)), -1, dtype=torch.long)


def _labelled_videos(rows: HeadRows) -> tuple[torch.Tensor, torch.Tensor]:
    videos, labels = [], []
    for v, target in zip(rows.videos, rows.targets, strict=True):
        for video, label in zip(v, torch.as_tensor(target), strict=True):
            if bool((label >= 0).any()):
                videos.append(video)
                labels.append(label)
    if not videos:
        return torch.zeros(0), torch.zeros(0, dtype=torch.long)
    return torch.stack(videos), torch.stack(labels).long()
