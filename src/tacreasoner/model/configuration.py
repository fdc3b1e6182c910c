"""``TacReasonerConfig``: the wrapped LLM's config plus the tactile encoder's, saved as one ``config.json``."""

from __future__ import annotations

from typing import Any, ClassVar

import transformers
from transformers import AutoConfig, PreTrainedConfig

from tacreasoner.model.encoder_config import TactileEncoderConfig

MIN_TRANSFORMERS = "5.20"
"""The first transformers with ``SubConfigSpec`` (pyproject.toml's lower bound says the same)."""

try:
    from transformers.configuration_utils import SubConfigSpec
except ImportError as error:  # an older transformers: say what to install, not where deep inside it failed
    raise ImportError(f"tacreasoner needs transformers>={MIN_TRANSFORMERS} (SubConfigSpec); this environment has "
                      f"{transformers.__version__}: pip install 'transformers>={MIN_TRANSFORMERS}'") from error

__all__ = ["TacReasonerConfig"]


class TacReasonerConfig(PreTrainedConfig):
    """``text_config`` is any Hugging Face causal-LM config (Qwen2 by default); ``encoder`` holds
    :class:`TactileEncoderConfig` fields; ``tactile_token_id`` is the id each video's placeholder
    run is made of; ``new_token_ids`` are rows added to the LLM's vocabulary (trained in Stage I)."""

    model_type = "tacreasoner"
    sub_configs_defaults: ClassVar[dict] = {"text_config": SubConfigSpec(config_class=AutoConfig, model_type="qwen2")}

    text_config: dict | PreTrainedConfig | None = None
    encoder: dict | None = None
    tactile_token_id: int = -1
    new_token_ids: list | None = None
    projector_hidden_act: str = "gelu"
    tie_word_embeddings: bool = False

    def __post_init__(self, **kwargs: Any) -> None:
        super().__post_init__(**kwargs)
        self.encoder = TactileEncoderConfig.from_dict(self.encoder).to_dict()
        self.new_token_ids = [int(i) for i in (self.new_token_ids or [])]
        if self.text_config.tie_word_embeddings:
            self.tie_word_embeddings = True

    @property
    def encoder_config(self) -> TactileEncoderConfig:
        return TactileEncoderConfig.from_dict(self.encoder)

    @property
    def text_hidden_size(self) -> int:
        return int(self.text_config.hidden_size)
