"""Out-of-fold readings for training: a head's verdict on a training prompt comes from a copy not fitted on it.

A head fitted on the training prompts and then read on those same prompts gives near-gold verdicts (its ridge
fits read the train clips back at 90–100%), so Stage II would learn to trust a verdict that is far less reliable on
unseen objects. Cross-fitting (as in double machine learning) splits the training **objects** into folds; a
prompt whose videos' objects lie in the folds S is read by a copy of the head fitted on the prompts that touch no
object of S (every video of the prompt counts, not only its first). Stage II trains on those readings; the head
kept for inference is fitted on everything.
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
    """Read every prompt of ``rows`` with a copy of ``head`` fitted on no object of that prompt (``objects``: per
    prompt the object of each video). ``head`` itself is left as it was: fit it on all rows afterwards for
    inference.

    A prompt's objects may fall in several folds (a comparison of two objects); its copy is then fitted on the
    prompts that touch none of those folds, so the verdict on a multi-video prompt never comes from a copy that saw
    any of its videos' objects. One copy is fitted per distinct set of folds."""
    if len(objects) != len(rows):
        raise ValueError(f"got {len(rows)} prompts but objects for {len(objects)}")
    if any(len(o) == 0 for o in objects):
        raise ValueError("every prompt needs the object of each of its videos")
    fold_of = object_folds(objects, folds, seed)
    touched = [frozenset(fold_of[x] for x in o) for o in objects]
    out = CrossFit(readings=[None] * len(rows))
    plans = []  # per copy: the prompts it reads, the copy, what it is fitted on, its seed, its record
    for held_folds in sorted(set(touched), key=lambda s: (len(s), sorted(s))):
        held = [i for i, s in enumerate(touched) if s == held_folds]
        train = [i for i, s in enumerate(touched) if not s & held_folds]
        fold: dict[str, Any] = {"folds": sorted(held_folds), "held_out": len(held), "fitted_on": len(train)}
        plans.append((held, copy.deepcopy(head), rows.subset(train), seed + min(held_folds), fold))
    for (held, copy_, _, _, fold), fit in zip(plans, _fit_copies(head, [p[1:4] for p in plans]), strict=True):
        if isinstance(fit, ValueError):  # nothing of this head's kind outside these folds: no verdict for its prompts
            fold["fit"] = f"not fitted: {fit}"
        else:
            fold["fit"] = fit
            for i, reading in zip(held, copy_.read_rows(rows.subset(held)), strict=True):
                out.readings[i] = reading
        out.folds.append(fold)
    return out


def _fit_copies(head: ReadoutHead, fits: list[tuple[Any, HeadRows, int]]) -> list[dict[str, Any] | ValueError]:
    """Each copy's ``fit_rows`` (copy, rows, seed); in one call where the head's kind fits copies together
    (``fit_rows_together``: the comparator's gradient fits), one by one otherwise."""
    together = getattr(type(head), "fit_rows_together", None)
    if together is not None:
        return together(fits)
    out: list[dict[str, Any] | ValueError] = []
    for copy_, train, seed in fits:
        try:
            out.append(copy_.fit_rows(train, seed=seed))
        except ValueError as exc:
            out.append(exc)
    return out
