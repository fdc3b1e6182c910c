"""What the read-out heads need from the benchmark, which the model package does not know (light: no torch).

The model reads a clip reader's traits and a question's option markers only from its config
(``encoder.clip_reader_traits``, ``encoder.clip_reader_levels``, ``encoder.option_marker``); training fills them
from this benchmark's vocabulary and format when a config switches the heads on.
"""

from __future__ import annotations

from typing import Any

from tacreasoner.tasks.answers import OPTION_MARKER
from tacreasoner.tasks.schema import CONTACT_STATES

__all__ = ["MAX_LEVELS", "READER_TRAITS", "reader_vocabulary", "with_head_settings"]

READER_TRAITS = ("hardness", "protrusion", "elasticity", "friction", "roughness", "bumpiness", "real", "state")
"""What the reader reads of a clip: the TFA attributes (levels 0..2), real (1) or fake (0) fruit, and the contact
state of a segment (index in ``CONTACT_STATES``)."""
MAX_LEVELS = max(3, len(CONTACT_STATES))


def reader_vocabulary() -> tuple[tuple[str, ...], int]:
    """The traits and the most levels a clip reader fitted on this benchmark needs."""
    return READER_TRAITS, MAX_LEVELS


def with_head_settings(encoder: dict[str, Any]) -> dict[str, Any]:
    """The encoder settings with the clip reader's traits and levels (when ``clip_reader`` is on and names none)
    and the benchmark's option marker (when the name matcher is on and no marker is given)."""
    out = dict(encoder)
    if out.get("clip_reader") and not out.get("clip_reader_traits"):
        out["clip_reader_traits"], out["clip_reader_levels"] = reader_vocabulary()
    elif "clip_reader" in out and not out["clip_reader"]:
        out["clip_reader_traits"], out["clip_reader_levels"] = (), 0
    if out.get("cross_video") and out.get("cross_video_names", True) and "option_marker" not in out:
        out["option_marker"] = OPTION_MARKER
    return out
