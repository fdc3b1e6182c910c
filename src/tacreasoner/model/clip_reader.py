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

import torch
from torch import nn

from tacreasoner.model.fitting import as_loud_as_a_token, ridge_solve
from tacreasoner.tasks.schema import CONTACT_STATES

__all__ = ["READER_TRAITS", "ClipReader"]

READER_TRAITS = ("hardness", "protrusion", "elasticity", "friction", "roughness", "bumpiness", "real", "state")
"""What the reader reads of a clip: the TFA attributes (levels 0..2), real (1) or fake (0) fruit, and the contact
state of a segment (index in ``CONTACT_STATES``)."""
MAX_LEVELS = max(3, len(CONTACT_STATES))


class ClipReader(nn.Module):
    """videos V×N×H → the same tokens plus, per trait the reader was fitted for, the vector of the level it reads.

    Until :meth:`fit` nothing is known and the tokens pass unchanged (Stage I). The read-out is a buffer, set in
    closed form and never trained; the level vectors start as loud as a token and train with the projector."""

    def __init__(self, hidden: int, tokens_per_video: int) -> None:
        super().__init__()
        width, slots = tokens_per_video * hidden, len(READER_TRAITS) * MAX_LEVELS
        self.register_buffer("readout_weight", torch.zeros(slots, width))
        self.register_buffer("readout_bias", torch.zeros(slots))
        self.register_buffer("known", torch.zeros(len(READER_TRAITS), MAX_LEVELS, dtype=torch.bool))
        self.readings = nn.Parameter(torch.zeros(len(READER_TRAITS), MAX_LEVELS, hidden))

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

    def vectors(self, videos: torch.Tensor) -> torch.Tensor:
        """V×H: the sum of the vectors of the levels read (zeros before :meth:`fit`)."""
        if not self.fitted:
            return videos.new_zeros(len(videos), videos.shape[-1])
        levels = self.levels(videos.detach())
        traits = torch.arange(len(READER_TRAITS), device=videos.device).expand_as(levels)
        vectors = self.readings[traits, levels.clamp(min=0)] * (levels >= 0).unsqueeze(-1).to(self.readings.dtype)
        return vectors.sum(1).to(videos.dtype)

    def fit(self, videos: torch.Tensor, labels: torch.Tensor, penalty: float = 100.0, seed: int = 0
            ) -> dict[str, dict[str, float]]:
        """Fit one ridge classifier per trait on the videos labelled for it, then freeze the read-out.

        ``videos``: V×N×H frozen encoder output; ``labels``: V×traits (order of ``READER_TRAITS``), the level of
        each trait or −1 where unknown. Returns per trait fitted the number of videos and the share read right."""
        if videos.ndim != 3 or labels.shape != (len(videos), len(READER_TRAITS)):
            raise ValueError(f"the clip reader needs V×N×H videos and V×{len(READER_TRAITS)} labels, got "
                             f"{tuple(videos.shape)} and {tuple(labels.shape)}")
        if bool((labels >= MAX_LEVELS).any()):
            raise ValueError(f"a trait level is {int(labels.max())}, past the reader's {MAX_LEVELS} levels")
        x = videos.flatten(1).float()
        weight = torch.zeros_like(self.readout_weight, dtype=torch.float64)
        bias = torch.zeros_like(self.readout_bias, dtype=torch.float64)
        known = torch.zeros_like(self.known)
        for t in range(len(READER_TRAITS)):
            rows = labels[:, t] >= 0
            seen = labels[rows, t].unique()
            if len(seen) < 2:  # nothing to tell apart
                continue
            onehot = torch.nn.functional.one_hot(labels[rows, t], MAX_LEVELS).double()
            w, b = ridge_solve(x[rows], onehot, penalty)
            block = slice(t * MAX_LEVELS, (t + 1) * MAX_LEVELS)
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
        for t, trait in enumerate(READER_TRAITS):
            rows = labels[:, t] >= 0
            if bool(known[t].any()):
                right = (read[rows, t] == labels[rows, t]).float().mean()
                out[trait] = {"videos": int(rows.sum()), "read": float(right)}
        return out
