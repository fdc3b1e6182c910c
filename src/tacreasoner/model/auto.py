"""Registers TacReasoner with transformers' Auto classes (imported by ``tacreasoner.model``'s ``__init__``).

After ``import tacreasoner.model`` (or any ``tacreasoner.model.*``), ``AutoConfig``, ``AutoModelForCausalLM``
and ``AutoProcessor`` load a saved TacReasoner directory (``build.save_model``) like any other model.
Plain ``register`` calls on the real classes: no import hook, and nothing happens to a process that
never imports the model (``import tacreasoner`` or ``tacreasoner.sim`` stays free of torch and transformers).
"""

from __future__ import annotations

import transformers  # lazy: the Auto modules load when first used below

# The config first: it says which transformers is needed when this one is too old, before the model or the
# processor fail inside transformers on the same missing piece.
from tacreasoner.model.configuration import TacReasonerConfig
from tacreasoner.model.modeling import TacReasonerForCausalLM
from tacreasoner.model.processing import TacReasonerProcessor

__all__ = ["register"]


def register() -> None:
    """Map ``model_type`` ``tacreasoner`` to the config, and the config to the model and the processor.

    ``exist_ok``: a second call (a reloaded module, a test) re-registers the same classes instead of failing.
    The processor is found by ``processor_config.json``'s ``processor_class`` name among registered classes.
    """
    transformers.AutoConfig.register(TacReasonerConfig.model_type, TacReasonerConfig, exist_ok=True)
    transformers.AutoModelForCausalLM.register(TacReasonerConfig, TacReasonerForCausalLM, exist_ok=True)
    transformers.AutoProcessor.register(TacReasonerConfig, TacReasonerProcessor, exist_ok=True)


register()
