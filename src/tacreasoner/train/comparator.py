"""Fit the cross-video comparator (``encoder.cross_video``) when Stage II starts.

In Stage II the tactile encoder is frozen, so each training comparison's encoder output is fixed: the comparator
(which video the question picks) is fitted on those features alone, as benchmarks/comparator_probe.py does, and
then frozen; Stage II's LoRA and projector learn to read its verdict from the tokens. Fitting is seeded and uses
only the Stage I model and the training data, so a resumed Stage II fits the same comparator again.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import torch

from tacreasoner.train.data import Tokenized, VideoBank, collate, comparison_targets


def comparisons(examples: Sequence[Tokenized]) -> list[Tokenized]:
    """The examples the comparator is fitted on: a gold pick among two or more videos."""
    return [e for e in examples if e.winner >= 0 and len(e.videos) >= 2]


def fit_comparator(model: Any, processor: Any, examples: Sequence[Tokenized], bank: VideoBank, seed: int,
                   progress: Callable[[int, int], None] | None = None, batch_size: int = 16) -> dict[str, Any]:
    """Fit ``model``'s comparator on the comparisons among ``examples`` (those with a gold pick and ≥ 2 videos)
    and freeze it. Returns what it was fitted on and its accuracy there (``{"comparisons": 0}`` when none)."""
    fusion = model.projector.cross_video
    if fusion is None:
        raise ValueError("the model has no cross-video comparator (encoder.cross_video is 0)")
    attributes = model.encoder_config.cross_video_attributes
    chosen = comparisons(examples)
    if not chosen:
        for p in fusion.comparator_parameters:
            p.requires_grad_(False)
        return {"comparisons": 0}
    videos: list[torch.Tensor] = []
    questions: list[torch.Tensor] = []
    was_training = model.training
    model.eval()
    with torch.no_grad():
        for start in range(0, len(chosen), batch_size):
            chunk = chosen[start:start + batch_size]
            batch = collate(processor, chunk, bank)
            _, features, per_sample, question = model.tactile_features(
                batch["input_ids"], batch["pixel_values"], batch["attention_mask"], batch["question_mask"],
                batch["sensor_ids"], batch.get("appearance_tokens"))
            videos.extend(features.float().split(per_sample.tolist()))
            questions.append(question.float())
            if progress is not None:
                progress(min(start + batch_size, len(chosen)), len(chosen))
    model.train(was_training)
    targets = comparison_targets(chosen, attributes)
    return fusion.fit(videos, torch.cat(questions), targets, seed=seed)
