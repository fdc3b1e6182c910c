"""Where does the unseen sensor's gap arise? Answer with a trained model whose temporal branch sees no change
between frames (every frame replaced by the clip's first, so the frame differences are zero), on the seen style's
val and on the held-out style's val. An inference-time diagnostic on one model, not a recipe:

    TEMPORAL=zero python experiments/2026-11-29_sensor_temporal_diag/diagnose.py evaluate --model M --bench B ...

(the rest of the command line is `tacreasoner`'s). TEMPORAL=as_is leaves the model alone.
"""

from __future__ import annotations

import os

from tacreasoner.cli import main
from tacreasoner.model import temporal

MODE = os.environ.get("TEMPORAL", "as_is")
_forward = temporal.TemporalBranch.forward


def _still(self, pixel_values, question=None):
    """The temporal branch given a clip with no motion: its first frame repeated."""
    return _forward(self, pixel_values[:, :1].expand_as(pixel_values).contiguous(), question)


if MODE == "zero":
    temporal.TemporalBranch.forward = _still
elif MODE != "as_is":
    raise SystemExit(f"TEMPORAL={MODE!r}: expected zero or as_is")

if __name__ == "__main__":
    main()
