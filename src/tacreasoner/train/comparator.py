"""Fit the cross-video comparator (``encoder.cross_video``) when Stage II starts.

In Stage II the tactile encoder is frozen, so each training comparison's encoder output is fixed: the comparator
(which video the question picks) is fitted on those features alone, as benchmarks/comparator_probe.py does, and
so is the name matcher (which video is which listed option, OSC); both are then frozen, and Stage II's LoRA and
projector learn to read their verdicts from the tokens. Fitting is seeded and uses only the Stage I model and the
training data, so a resumed Stage II fits the same comparator again.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import torch

from tacreasoner.model.processing import OPTION_MASK_OFFSET
from tacreasoner.train.data import Tokenized, VideoBank, collate, comparison_targets


def comparisons(examples: Sequence[Tokenized]) -> list[Tokenized]:
    """The examples the comparator is fitted on: a gold pick among two or more videos."""
    return [e for e in examples if e.winner >= 0 and len(e.videos) >= 2]


def namings(examples: Sequence[Tokenized], max_videos: int) -> list[Tokenized]:
    """The examples the name matcher is fitted on: a gold assignment of as many listed options as videos."""
    return [e for e in examples if 2 <= len(e.videos) <= max_videos and len(e.assignment) == len(e.videos)
            and max(e.question_mask, default=0) - OPTION_MASK_OFFSET + 1 == len(e.videos)]


def fit_sets(model: Any, examples: Sequence[Tokenized]) -> tuple[list[Tokenized], list[Tokenized]]:
    """The comparisons and the namings (with ``encoder.cross_video_names``) ``model``'s cross-video layer is fitted
    on."""
    fusion = model.projector.cross_video
    if fusion is None:
        raise ValueError("the model has no cross-video comparator (encoder.cross_video is 0)")
    named = namings(examples, fusion.max_videos) if model.encoder_config.cross_video_names else []
    return comparisons(examples), named


def fit_comparator(model: Any, processor: Any, examples: Sequence[Tokenized], bank: VideoBank, seed: int,
                   progress: Callable[[int, int], None] | None = None, batch_size: int = 16) -> dict[str, Any]:
    """Fit ``model``'s comparator on the comparisons among ``examples`` (those with a gold pick and ≥ 2 videos)
    and, with ``encoder.cross_video_names``, its name matcher on those assigning listed options to videos (OSC);
    freeze both. Returns what each was fitted on and its accuracy there (``{"comparisons": 0}`` /
    ``{"named": 0}`` when none)."""
    chosen, named = fit_sets(model, examples)
    fusion, config = model.projector.cross_video, model.encoder_config
    was_training = model.training
    model.eval()
    videos, questions, options = encoder_outputs(model, processor, [*chosen, *named], bank, batch_size, progress)
    model.train(was_training)
    out: dict[str, Any] = {"comparisons": 0}
    if chosen:
        targets = comparison_targets(chosen, config.cross_video_attributes)
        out = fusion.fit(videos[:len(chosen)], torch.cat(questions)[:len(chosen)], targets, seed=seed)
    out["named"] = 0
    if named:
        out.update(fusion.fit_names(videos[len(chosen):], options[len(chosen):],
                                    torch.tensor([e.assignment for e in named]), seed=seed))
        model.projector.loud_option_marks(model.get_input_embeddings().weight, seed + 2)
    for p in fusion.comparator_parameters:
        p.requires_grad_(False)
    return out


def encoder_outputs(model: Any, processor: Any, examples: Sequence[Tokenized], bank: VideoBank, batch_size: int = 16,
                    progress: Callable[[int, int], None] | None = None,
                    ) -> tuple[list[torch.Tensor], list[torch.Tensor], list[torch.Tensor]]:
    """Per example the frozen encoder's output for its videos (k×N×H), and with a cross-video layer per batch its
    question vectors and per example its options' name vectors (what the fits read)."""
    videos: list[torch.Tensor] = []
    questions: list[torch.Tensor] = []
    options: list[torch.Tensor] = []
    with torch.no_grad():
        for start in range(0, len(examples), batch_size):
            chunk = examples[start:start + batch_size]
            batch = collate(processor, chunk, bank)
            _, features, per_sample, question, listed = model.tactile_features(
                batch["input_ids"], batch["pixel_values"], batch["attention_mask"], batch["question_mask"],
                batch["sensor_ids"], batch.get("appearance_tokens"))
            videos.extend(features.float().split(per_sample.tolist()))
            if question is not None:
                questions.append(question.float())
            if listed is not None:
                options.extend(vectors[:count].float() for vectors, count in zip(*listed, strict=True))
            if progress is not None:
                progress(min(start + batch_size, len(examples)), len(examples))
    return videos, questions, options
