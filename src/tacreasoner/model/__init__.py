"""The TacReasoner model: dynamic-aware tactile encoder, projector, LLM wrapper and processor.

Needs the ``train`` (or ``hf``) extra: torch + transformers. ``import tacreasoner`` already registers
these classes with ``AutoConfig``, ``AutoModelForCausalLM`` and ``AutoProcessor``. Names are imported
on first use, so torch-free parts (``encoder_config``, ``video_processing``) stay light.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "TacReasonerConfig": "configuration",
    "TacReasonerForCausalLM": "modeling",
    "TactileAnswer": "modeling",
    "TacReasonerProcessor": "processing",
    "TactileEncoderConfig": "encoder_config",
    "VideoProcessingConfig": "video_processing",
    "preprocess_video": "video_processing",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'tacreasoner.model' has no attribute {name!r}")
    return getattr(importlib.import_module(f"tacreasoner.model.{_EXPORTS[name]}"), name)
