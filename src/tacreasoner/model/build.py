"""Assemble a TacReasoner model and its processor from parts, and save/load the pair as one directory."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from transformers import AutoTokenizer, PreTrainedModel, PreTrainedTokenizerBase

from tacreasoner.model.encoder_config import TactileEncoderConfig
from tacreasoner.model.modeling import TacReasonerForCausalLM
from tacreasoner.model.processing import PROCESSOR_CONFIG_NAME, TacReasonerProcessor
from tacreasoner.model.token_rows import save_token_rows
from tacreasoner.model.tokenizer import TACTILE_PAD, prepare_tokenizer

__all__ = ["appearance_video_settings", "build_model", "load_model", "save_model"]



def build_model(llm: str | os.PathLike[str] | PreTrainedModel, *, tokenizer: PreTrainedTokenizerBase | None = None,
                encoder: TactileEncoderConfig | dict[str, Any] | None = None,
                appearance: str | os.PathLike[str] | None = None, video: dict[str, Any] | None = None,
                system_prompt: str | None = None, **llm_kwargs: Any,
                ) -> tuple[TacReasonerForCausalLM, TacReasonerProcessor]:
    """Wrap a causal LM (a directory such as `llm get smollm2` writes, or a hub id such as a Qwen2.5).

    The tokenizer (``llm``'s own by default) gets the tactile token, reasoning tags and a chat
    template where missing; the rows of tokens it gains are recorded as ``new_token_ids`` so Stage I
    trains them. ``appearance``: a ``pretrain-encoder`` or ``encoder get`` output directory, or a Hugging Face VideoMAE
    one as ``save_pretrained`` wrote it; its shape wins, and its ``video_processing.json`` (a VideoMAE's image processor
    normalisation) sets how frames are prepared unless ``video`` is given.
    """
    if tokenizer is None:
        if isinstance(llm, PreTrainedModel):
            raise ValueError("build_model: give tokenizer= when passing a model object instead of a directory")
        tokenizer = AutoTokenizer.from_pretrained(llm)
    before = len(tokenizer)
    added = prepare_tokenizer(tokenizer)
    new_ids = list(range(before, before + added))
    model = TacReasonerForCausalLM.from_llm(
        llm, tactile_token_id=int(tokenizer.convert_tokens_to_ids(TACTILE_PAD)), vocab_size=len(tokenizer),
        new_token_ids=new_ids, encoder=encoder, appearance=appearance, **llm_kwargs)
    if video is None and appearance is not None:
        video = appearance_video_settings(appearance)
    processor = TacReasonerProcessor.for_encoder(tokenizer, model.encoder_config, video=video or {},
                                                 system_prompt=system_prompt)
    return model, processor


def appearance_video_settings(appearance: str | os.PathLike[str]) -> dict[str, Any]:
    """How the appearance directory's encoder wants its frames prepared (``video_processing.json``: sampling,
    background, normalisation), without the frame count and size, which the encoder config fixes. The model's
    processor uses them, so the frozen branch sees frames prepared as in its own pre-training.

    A Hugging Face VideoMAE directory without ``video_processing.json`` gets its image processor's normalisation
    (``preprocessor_config.json``'s ``image_mean``/``image_std``, ImageNet's when it has none) on the sensor image as
    it is: :func:`tacreasoner.model.videomae.videomae_video_settings`."""
    from tacreasoner.jsonl import read_json_object
    from tacreasoner.model.video_processing import VideoProcessingConfig
    from tacreasoner.model.videomae import is_videomae_dir, videomae_video_settings

    path = Path(appearance) / "video_processing.json"
    if path.is_file():
        data = VideoProcessingConfig.from_dict(read_json_object(path, "the video processing of an encoder")).to_dict()
    elif is_videomae_dir(appearance):
        data = VideoProcessingConfig(**videomae_video_settings(appearance)).to_dict()
    else:
        return {}
    return {k: v for k, v in data.items() if k not in ("num_frames", "image_size")}


def save_model(model: Any, processor: TacReasonerProcessor, directory: str | os.PathLike[str]) -> Path:
    """Model (config + safetensors, or a PEFT adapter with the new tokens' trained rows) and processor side by side
    in one directory."""
    directory = Path(directory)
    model.save_pretrained(directory)
    if hasattr(model, "get_base_model"):  # PEFT: its file holds LoRA + projector; the rows are ours (token_rows)
        save_token_rows(model.get_base_model().language_model, directory)
    processor.save_pretrained(directory)
    return directory


def load_model(directory: str | os.PathLike[str], **kwargs: Any) -> tuple[TacReasonerForCausalLM, TacReasonerProcessor]:
    """A directory written by :func:`save_model` (a merged model, not an adapter)."""
    directory = Path(directory)
    if not (directory / "config.json").is_file():
        raise FileNotFoundError(f"{directory}: no config.json — not a saved TacReasoner model directory")
    if not (directory / PROCESSOR_CONFIG_NAME).is_file():
        raise FileNotFoundError(f"{directory}: no {PROCESSOR_CONFIG_NAME} — save the processor next to the model")
    return TacReasonerForCausalLM.from_pretrained(directory, **kwargs), TacReasonerProcessor.from_pretrained(directory)
