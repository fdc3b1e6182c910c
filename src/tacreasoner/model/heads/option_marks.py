"""Option marks: the name matcher's verdict written into the text, on the tokens of each listed option's name.

The matcher says which video is which listed option; a vector per video place, added to the embedding of the
option's name tokens, lets the LLM find "the option of video 2" by attending for its mark (it wrote one assignment
code poorly). Which tokens name an option is the processor's business (``encoder.option_marker``).
"""

from __future__ import annotations

import torch

from tacreasoner.model.fitting import as_loud_as_a_token

__all__ = ["loud_option_marks", "mark_options"]


def loud_option_marks(marks: torch.nn.Parameter, text_rows: torch.Tensor, seed: int) -> None:
    """Start the marks as loud as a text token (``text_rows``: the LLM's embedding rows), as the verdicts start as
    loud as a tactile one: from zero they stay unread."""
    generator = torch.Generator().manual_seed(seed)
    with torch.no_grad():
        marks.copy_(as_loud_as_a_token(text_rows.float(), marks.shape, generator).to(marks.dtype))


def mark_options(embeds: torch.Tensor, marks: torch.Tensor | None, option: torch.Tensor, places: torch.Tensor
                 ) -> torch.Tensor:
    """``embeds`` (B×L×D) with each matched option's name tokens (``option``: B×L, the option index of each token,
    −1 elsewhere) carrying the mark of the video place the matcher gives that option (``places``, B×M)."""
    if marks is None or places.shape[1] == 0 or not bool((places >= 0).any()):
        return embeds
    at = places.gather(1, option.clamp(0, places.shape[1] - 1))  # B×L: place of each token's option
    at = torch.where(option >= 0, at, -1)
    return embeds + marks.to(embeds.dtype)[at.clamp(min=0)] * (at >= 0).unsqueeze(-1).to(embeds.dtype)
