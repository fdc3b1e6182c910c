"""The TacReasoner model: dynamic-aware tactile encoder, projector, LLM wrapper and processor.

Needs the ``train`` (or ``hf``) extra: torch + transformers. Importing this package (or any module in it)
registers the classes with ``AutoConfig``, ``AutoModelForCausalLM`` and ``AutoProcessor`` (``auto.py``),
which imports torch and transformers. Without them installed nothing is registered, so the torch-free
parts (``encoder_config``, ``video_processing``, ``tokenizer``) still import in a base install.
The names below are looked up on first use.
"""

from __future__ import annotations

import importlib
import importlib.util
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


if importlib.util.find_spec("torch") is not None and importlib.util.find_spec("transformers") is not None:
    # Last, so that the modules auto.py imports find this package fully initialised.
    from tacreasoner.model import auto as _auto  # noqa: F401
