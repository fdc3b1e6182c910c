"""The one hook through which the core model meets the read-out heads.

The paper's model is encoder → projector → LLM. The heads (optional, benchmark-specific) act at two points only:
before the projector they write their verdicts into the encoder's output (:meth:`ReadoutHeads.write`), and after
the tactile tokens are placed the option marks go onto the listed options' name tokens (:meth:`ReadoutHeads.mark`).
A model without heads passes through both unchanged. The heads' trainable parts are built here from the encoder
config (:func:`build_heads`) and held by the projector, so saved models keep their parameter names
(``projector.cross_video.*``, ``projector.clip_reader.*``, ``projector.option_marks``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import torch
from torch import nn

from tacreasoner.model.heads.clip_reader import ClipReader
from tacreasoner.model.heads.cross_video import CrossVideoFusion
from tacreasoner.model.heads.option_marks import loud_option_marks, mark_options

if TYPE_CHECKING:
    from tacreasoner.model.encoder_config import TactileEncoderConfig

__all__ = ["HeadModules", "ReadoutHeads", "build_heads"]


@dataclass
class HeadModules:
    """The heads' trainable parts (None: that head is off)."""

    cross_video: CrossVideoFusion | None = None
    clip_reader: ClipReader | None = None
    option_marks: nn.Parameter | None = None
    """One vector per video place, added to a listed option's name tokens (the name matcher's verdict)."""


def build_heads(enc: TactileEncoderConfig, text_hidden: int) -> HeadModules:
    """The heads ``enc`` asks for, unfitted: the cross-video layer (comparator, name matcher) and its option marks
    with ``encoder.cross_video``, the clip reader with ``encoder.clip_reader`` and traits."""
    cross_video = CrossVideoFusion(enc.hidden_size, enc.fusion_heads, enc.mlp_ratio, enc.cross_video, text_hidden,
                                   enc.tokens_per_video, len(enc.cross_video_attributes)) if enc.cross_video else None
    traits = enc.clip_reader_traits if enc.clip_reader else ()
    clip_reader = ClipReader(enc.hidden_size, enc.tokens_per_video, traits, enc.clip_reader_levels) \
        if traits else None
    marks = nn.Parameter(torch.zeros(enc.cross_video, text_hidden)) if enc.cross_video else None
    return HeadModules(cross_video, clip_reader, marks)


class ReadoutHeads:
    """The heads of one projector, as the core model calls them (a view: it holds the projector's modules)."""

    def __init__(self, cross_video: CrossVideoFusion | None, clip_reader: ClipReader | None,
                 option_marks: nn.Parameter | None) -> None:
        self.cross_video = cross_video
        self.clip_reader = clip_reader
        self.option_marks = option_marks

    def write(self, features: torch.Tensor, per_sample: torch.Tensor | None = None,
              question: torch.Tensor | None = None, options: tuple[torch.Tensor, torch.Tensor] | None = None,
              winner: torch.Tensor | None = None, readings: dict[str, torch.Tensor] | None = None,
              ) -> tuple[torch.Tensor, torch.Tensor | None, torch.Tensor | None]:
        """The encoder's output (V×N×H) with every head's verdict written in, the comparator's loss against
        ``winner`` (None without one) and the name matcher's assignment (B×options, None without a matcher).

        ``per_sample``: videos per prompt (B; default one each); ``question``: the cross-video layer's question
        vectors (B×Dq); ``options``: the listed options' name vectors (``option_vectors``); ``readings``: verdicts
        made elsewhere (training's out-of-fold readings, keys in ``heads.base.READINGS``), written instead of the
        heads' own."""
        readings = readings or {}
        if per_sample is None:
            per_sample = torch.ones(len(features), dtype=torch.long, device=features.device)
        places = readings.get("places")
        if places is None and options is not None and self.cross_video is not None:
            places = self.cross_video.places(features, per_sample, options)
        loss, own = None, features
        if self.cross_video is not None:
            features, loss = self.cross_video(features, per_sample, question, winner, places, readings.get("pick"))
        if self.clip_reader is not None:  # reads a video's own encoder output, as it was fitted on, and speaks
            # only in one-video prompts: written into comparisons too it took SFD from 75% to 51% (docs/history.md)
            alone = (per_sample == 1).repeat_interleave(per_sample).to(features.dtype)
            vectors = self.clip_reader.vectors(own, readings.get("levels"))
            features = features + vectors.unsqueeze(1) * alone[:, None, None]
        return features, loss, places

    def mark(self, embeds: torch.Tensor, option: torch.Tensor, places: torch.Tensor | None) -> torch.Tensor:
        """``embeds`` (B×L×D) with each matched option's name tokens (``option``: B×L, each token's option index,
        −1 elsewhere) carrying the mark of the video place the matcher gave it; unchanged without a matcher."""
        if places is None:
            return embeds
        return mark_options(embeds, self.option_marks, option, places)

    def start_marks(self, text_rows: torch.Tensor, seed: int) -> None:
        """Start the option marks as loud as a text token (``text_rows``: the LLM's embedding rows)."""
        if self.option_marks is not None:
            loud_option_marks(self.option_marks, text_rows, seed)
