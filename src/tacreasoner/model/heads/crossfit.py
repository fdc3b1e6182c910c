"""Out-of-fold readings for training: a head's verdict on a training prompt comes from a copy not fitted on it.

A head fitted on the training prompts and then read on those same prompts gives near-gold verdicts (its ridge
fits read the train clips back at 90–100%), so Stage II would learn to trust a verdict that is far less reliable on
unseen objects. Cross-fitting (as in double machine learning) splits the training **objects** into folds; the
prompts of fold f (by the object of their first video) are read by a copy of the head fitted on the prompts that
touch no object of fold f. Stage II trains on those readings; the head kept for inference is fitted on everything.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import torch

from tacreasoner.model.heads.base import HeadRows, ReadoutHead

__all__ = ["CrossFit", "crossfit", "object_folds"]


@dataclass
class CrossFit:
    """Per prompt its out-of-fold reading (None where its fold's copy had nothing to fit on), and per fold what
    that copy was fitted on."""

    readings: list[torch.Tensor | None]
    folds: list[dict[str, Any]] = field(default_factory=list)


def object_folds(objects: Sequence[Sequence[str]], folds: int, seed: int) -> dict[str, int]:
    """Each object's fold: a seeded shuffle of the distinct objects, dealt round-robin."""
    if folds < 2:
        raise ValueError(f"cross-fitting needs at least 2 folds, got {folds}")
    distinct = sorted({o for row in objects for o in row})
    order = torch.randperm(len(distinct), generator=torch.Generator().manual_seed(seed)).tolist()
    return {distinct[i]: rank % folds for rank, i in enumerate(order)}


def crossfit(head: ReadoutHead, rows: HeadRows, objects: Sequence[Sequence[str]], folds: int = 5, seed: int = 0
             ) -> CrossFit:
    """Read every prompt of ``rows`` with a copy of ``head`` fitted out of its fold (``objects``: per prompt the
    object of each video, first first). ``head`` itself is left as it was: fit it on all rows afterwards for
    inference."""
    if len(objects) != len(rows):
        raise ValueError(f"got {len(rows)} prompts but objects for {len(objects)}")
    if any(len(o) == 0 for o in objects):
        raise ValueError("every prompt needs the object of at least its first video")
    fold_of = object_folds(objects, folds, seed)
    home = [fold_of[o[0]] for o in objects]
    out = CrossFit(readings=[None] * len(rows))
    for f in range(folds):
        held = [i for i, h in enumerate(home) if h == f]
        if not held:
            continue
        train = [i for i, o in enumerate(objects) if all(fold_of[x] != f for x in o)]
        fold: dict[str, Any] = {"fold": f, "held_out": len(held), "fitted_on": len(train)}
        copy_ = copy.deepcopy(head)
        try:
            fold["fit"] = copy_.fit_rows(rows.subset(train), seed=seed + f)
        except ValueError as exc:  # nothing of this head's kind outside the fold: no verdict for its prompts
            fold["fit"] = f"not fitted: {exc}"
            out.folds.append(fold)
            continue
        for i, reading in zip(held, copy_.read_rows(rows.subset(held)), strict=True):
            out.readings[i] = reading
        out.folds.append(fold)
    return out
