"""Which parameters each training stage updates, in one place so the trainer and the tests agree.

    Stage I  (alignment): temporal branch, fusion, sensor embedding, projector, and the embedding rows of
                          tokens added to the LLM's vocabulary (as small row tables, merged back on save).
                          LLM and appearance ViT frozen.
    Stage II (SFT):       projector + LoRA on the LLM's attention projections (+ the rows of the added tokens,
                          as in Stage I; saved beside the adapter). Whole tactile encoder frozen.

The appearance branch is never trained here (it is pre-trained by ``pretrain-encoder``).
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from torch import nn

from tacreasoner.fields import reject_unknown_fields
from tacreasoner.model.modeling import TacReasonerForCausalLM
from tacreasoner.model.token_rows import TokenRows, load_token_rows, merge_token_rows, train_token_rows

__all__ = ["STAGES", "LoraSettings", "configure_stage", "load_adapter", "merge_adapter", "no_decay_parameter_names",
           "trainable_parameter_names"]

STAGES = (1, 2)
DEFAULT_LORA_TARGETS = ("q_proj", "k_proj", "v_proj", "o_proj")


@dataclass
class LoraSettings:
    """The paper's Stage II adapter: rank 128, alpha 256, dropout 0.05 on q/k/v/o."""

    r: int = 128
    alpha: int = 256
    dropout: float = 0.05
    target_modules: tuple[str, ...] = field(default=DEFAULT_LORA_TARGETS)

    def __post_init__(self) -> None:
        self.target_modules = tuple(self.target_modules)
        if self.r < 1 or self.alpha <= 0:
            raise ValueError(f"lora: r must be ≥ 1 and alpha > 0, got r={self.r}, alpha={self.alpha}")
        if not 0 <= self.dropout < 1:
            raise ValueError(f"lora: dropout must be in [0, 1), got {self.dropout}")
        if not self.target_modules or not all(isinstance(t, str) and t.isidentifier() for t in self.target_modules):
            raise ValueError(f"lora: target_modules must be module names like q_proj, got {self.target_modules!r}")

    @classmethod
    def from_dict(cls, data: dict[str, Any] | None) -> LoraSettings:
        data = dict(data or {})
        reject_unknown_fields(cls, data, "lora: unknown keys", known="declared")
        return cls(**data)

    def peft_config(self) -> Any:
        """LoRA on the LM's projections + the projector. The new tokens' rows are not PEFT's trainable tokens:
        those rebuild the whole 49k-row matrix (and its gradient) every step; :func:`configure_stage` gives them row
        tables instead (a quickstart Stage II step 9% faster: benchmarks/results/step_time_ab.md)."""
        from peft import LoraConfig

        names = "|".join(self.target_modules)
        # only the language model's projections: the tactile encoder has none of these names, but be explicit
        return LoraConfig(r=self.r, lora_alpha=self.alpha, lora_dropout=self.dropout,
                          target_modules=rf".*language_model\..*\.({names})", modules_to_save=["projector"])


def _freeze(module: nn.Module) -> None:
    for p in module.parameters():
        p.requires_grad_(False)


def _train(module: nn.Module | None) -> None:
    if module is not None:
        for p in module.parameters():
            p.requires_grad_(True)


def _train_new_rows(model: TacReasonerForCausalLM) -> None:
    """Let only the added tokens' rows of the (input and output) embeddings learn, as their own small parameters
    (:mod:`tacreasoner.model.token_rows`): the optimizer, gradients and all-reduce hold rows, not matrices.
    The trainer does not weight-decay them (:func:`no_decay_parameter_names`), as before with the whole matrix."""
    ids = list(model.config.new_token_ids or [])
    if ids:
        train_token_rows(model.language_model, ids)


def configure_stage(model: TacReasonerForCausalLM, stage: int, lora: LoraSettings | None = None) -> nn.Module:
    """Set ``requires_grad`` for ``stage`` and return the module to train (a PEFT model for Stage II)."""
    if stage not in STAGES:
        raise ValueError(f"stage must be one of {STAGES}, got {stage!r}")
    merge_token_rows(model.language_model)  # a model configured before (Stage I in memory) is plain again
    _freeze(model)
    encoder = model.tactile_encoder
    if stage == 1:
        for part in (encoder.temporal, encoder.fusion, encoder.sensor_embed, model.projector):
            _train(part)
        if model.projector.clip_reader is not None:  # unfitted until Stage II: its vectors get no gradient here
            _freeze(model.projector.clip_reader)
        _train_new_rows(model)
        return model
    from peft import get_peft_model

    from tacreasoner.model.dropout import use_cpu_dropout

    with _without_peft_deprecation_noise():
        peft_model = get_peft_model(model, (lora or LoraSettings()).peft_config())
    use_cpu_dropout(peft_model)  # the same dropout, half the cost on the CPU (model/dropout.py)
    _train_new_rows(model)  # after PEFT, which freezes everything but its adapter; saved by save_token_rows
    return peft_model


def no_decay_parameter_names(model: nn.Module) -> set[str]:
    """Trainable parameters that must not be weight-decayed: biases, norms, and the new token rows."""
    masked = {id(module.rows) for module in model.modules() if isinstance(module, TokenRows)}
    names = set()
    for name, p in model.named_parameters():
        if p.requires_grad and (p.ndim < 2 or id(p) in masked or "norm" in name.lower()):
            names.add(name)
    return names


def trainable_parameter_names(model: nn.Module) -> list[str]:
    return [name for name, p in model.named_parameters() if p.requires_grad]


def load_adapter(model: TacReasonerForCausalLM, adapter_dir: str | os.PathLike[str], *, trainable: bool = False) -> Any:
    """A saved Stage II adapter (LoRA + projector, and the new tokens' rows saved beside it) on top of ``model``."""
    from peft import PeftModel

    adapter_dir = Path(adapter_dir)
    if not (adapter_dir / "adapter_config.json").is_file():
        raise FileNotFoundError(f"{adapter_dir}: no adapter_config.json (save one with the Stage II model's "
                                f"save_pretrained)")
    load_token_rows(model.language_model, adapter_dir)  # adapters from before 2026-11-28 carry them in PEFT's file
    with _without_peft_deprecation_noise():
        return PeftModel.from_pretrained(model, adapter_dir, is_trainable=trainable)


@contextmanager
def _without_peft_deprecation_noise() -> Iterator[None]:
    """PEFT reads transformers' deprecated ``is_gradient_checkpointing``: a warning users can do nothing about."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="`is_gradient_checkpointing` is deprecated", category=FutureWarning)
        yield


def merge_adapter(model: TacReasonerForCausalLM, adapter_dir: str | os.PathLike[str]) -> TacReasonerForCausalLM:
    """Fold a Stage II adapter into the weights: one plain model, no PEFT needed to run it."""
    merged = load_adapter(model, adapter_dir).merge_and_unload()
    for _, p in merged.named_parameters():
        p.requires_grad_(False)
    return merged
