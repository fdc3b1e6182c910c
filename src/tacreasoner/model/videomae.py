"""Initialise the appearance branch from a Hugging Face VideoMAE checkpoint (or VTV-LLM's, which is one).

Reads ``config.json`` + safetensors of a ``VideoMAEModel`` / ``VideoMAEForPreTraining`` /
``VideoMAEForVideoClassification`` directory (keys optionally prefixed ``videomae.``), maps every key
onto :class:`~tacreasoner.model.appearance.AppearanceEncoder` and checks every shape. Both bias
spellings are read: ``attention.attention.q_bias``/``v_bias`` (checkpoints on the Hub, transformers
4.x) and ``query.bias``/``value.bias`` (transformers 5). Pickled weights are refused, never loaded.

    HF (after the ``videomae.`` prefix)                        AppearanceEncoder
    embeddings.patch_embeddings.projection.{weight,bias}       patch_embed.proj.{weight,bias}
    encoder.layer.i.layernorm_before.*                         blocks.i.norm1.*
    encoder.layer.i.attention.attention.{query,key,value}.weight
                                                               blocks.i.attn.{query,key,value}.weight
    encoder.layer.i.attention.attention.{q_bias|query.bias}    blocks.i.attn.q_bias
    encoder.layer.i.attention.attention.{v_bias|value.bias}    blocks.i.attn.v_bias
    encoder.layer.i.attention.output.dense.*                   blocks.i.attn.proj.*
    encoder.layer.i.layernorm_after.*                          blocks.i.norm2.*
    encoder.layer.i.intermediate.dense.*                       blocks.i.mlp.fc1.*
    encoder.layer.i.output.dense.*                             blocks.i.mlp.fc2.*
    layernorm.*   (absent with use_mean_pooling=True)          norm.*   (else kept fresh)
    —                                                          cls_token (always fresh)

Such a directory is also accepted as ``model.appearance`` as it is
(:func:`~tacreasoner.model.appearance.videomae_appearance`, which
:func:`~tacreasoner.model.appearance.load_appearance` calls when config.json says ``"model_type": "videomae"``),
and its image processor's normalisation becomes the model's frame preparation (:func:`videomae_video_settings`).
"""

from __future__ import annotations

import json
import math
import os
import re
from pathlib import Path
from typing import Any

import torch
from torch import nn

from tacreasoner.jsonl import read_json_object
from tacreasoner.model.appearance_io import load_safetensors_strict
from tacreasoner.model.encoder_config import TactileEncoderConfig

__all__ = ["IMAGENET_MEAN", "IMAGENET_STD", "PREPROCESSOR_NAMES", "encoder_config_from_videomae", "is_videomae_dir",
           "load_videomae", "map_videomae_key", "videomae_encoder_config",
           "videomae_video_settings"]

IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)
"""What VideoMAE was pre-trained with (IMAGENET_DEFAULT_MEAN/STD in its repository)."""
_HF_PROCESSOR_DEFAULT = (0.5, 0.5, 0.5)
"""transformers' ``VideoMAEImageProcessor`` class default (IMAGENET_STANDARD_*), for a key its file omits."""
PREPROCESSOR_NAMES = ("preprocessor_config.json", "video_preprocessor_config.json")
"""Where ``VideoMAEImageProcessor`` / ``VideoMAEVideoProcessor.save_pretrained`` write their settings."""
CLS_SEED = 0
"""VideoMAE has no CLS token: ours starts from this fixed seed, so every load of one directory gives the same
encoder (Stage II rebuilt from it, the appearance cache's key, retrieval's CLS features)."""

# Parts of the pre-training / classification wrappers that are not the encoder.
_IGNORED = re.compile(r"^(decoder\.|encoder_to_decoder\.|mask_token$|position_embeddings$|fc_norm\.|classifier\.|"
                      r"embeddings\.position_embeddings$)")
_LAYER = re.compile(r"^encoder\.layer\.(\d+)\.(.+)$")
_LAYER_PARTS = {
    "layernorm_before.weight": "norm1.weight",
    "layernorm_before.bias": "norm1.bias",
    "attention.attention.query.weight": "attn.query.weight",
    "attention.attention.key.weight": "attn.key.weight",
    "attention.attention.value.weight": "attn.value.weight",
    "attention.attention.q_bias": "attn.q_bias",
    "attention.attention.query.bias": "attn.q_bias",
    "attention.attention.v_bias": "attn.v_bias",
    "attention.attention.value.bias": "attn.v_bias",
    "attention.output.dense.weight": "attn.proj.weight",
    "attention.output.dense.bias": "attn.proj.bias",
    "layernorm_after.weight": "norm2.weight",
    "layernorm_after.bias": "norm2.bias",
    "intermediate.dense.weight": "mlp.fc1.weight",
    "intermediate.dense.bias": "mlp.fc1.bias",
    "output.dense.weight": "mlp.fc2.weight",
    "output.dense.bias": "mlp.fc2.bias",
}
_TOP = {
    "embeddings.patch_embeddings.projection.weight": "patch_embed.proj.weight",
    "embeddings.patch_embeddings.projection.bias": "patch_embed.proj.bias",
    "layernorm.weight": "norm.weight",
    "layernorm.bias": "norm.bias",
}
# Ours that a VideoMAE checkpoint may legitimately lack: they stay as initialised and are reported.
_MAY_BE_FRESH = ("cls_token", "norm.weight", "norm.bias")


def map_videomae_key(key: str) -> str | None:
    """Our parameter name for a VideoMAE key; None for keys outside the encoder (decoder, heads).

    Raises ValueError for an encoder key this mapping does not know (a different architecture).
    """
    key = key.removeprefix("videomae.")
    if _IGNORED.match(key):
        return None
    if key in _TOP:
        return _TOP[key]
    m = _LAYER.match(key)
    if m and m.group(2) in _LAYER_PARTS:
        return f"blocks.{m.group(1)}.{_LAYER_PARTS[m.group(2)]}"
    raise ValueError(f"VideoMAE key {key!r} has no counterpart in AppearanceEncoder (not a VideoMAE encoder?)")


def load_videomae(encoder: nn.Module, path: str | os.PathLike[str]) -> list[str]:
    """Copy a VideoMAE checkpoint's encoder weights into ``encoder`` (an
    :class:`~tacreasoner.model.appearance.AppearanceEncoder`); returns our keys left freshly initialised.

    Nothing is written unless every key maps and every shape matches (the error names the key and
    both shapes). The sinusoid position table is fixed, so ``num_frames``/``image_size`` may differ
    from the checkpoint's; tubelet, patch and width must not.
    """
    directory = Path(path)
    if not directory.is_dir():
        raise FileNotFoundError(f"{directory}: not a directory (expected a VideoMAE checkpoint: config.json + "
                                "model.safetensors)")
    hf_state = load_safetensors_strict(directory)
    ours = encoder.state_dict()
    mapped: dict[str, torch.Tensor] = {}
    sources: dict[str, str] = {}
    for key, tensor in sorted(hf_state.items()):
        target = map_videomae_key(key)
        if target is None:
            continue
        if target in mapped:
            raise ValueError(f"{directory}: {key} and {sources[target]} both map to {target}")
        if target not in ours:
            raise ValueError(f"{directory}: {key} maps to {target}, which this encoder does not have "
                             f"(checkpoint deeper than num_layers={encoder.config.num_layers}, or qkv_bias differs?)")
        if tuple(tensor.shape) != tuple(ours[target].shape):
            raise ValueError(f"{directory}: {key} has shape {tuple(tensor.shape)} but {target} needs "
                             f"{tuple(ours[target].shape)} (check hidden_size, patch_size, tubelet_size, mlp_ratio)")
        mapped[target], sources[target] = tensor, key
    missing = [k for k in ours if k not in mapped and k not in _MAY_BE_FRESH]
    if missing:
        raise ValueError(f"{directory}: checkpoint lacks weights for {', '.join(missing[:8])}"
                         f"{' …' if len(missing) > 8 else ''} ({len(missing)} in all; fewer layers than "
                         f"num_layers={encoder.config.num_layers}, or no q/v biases?)")
    with torch.no_grad():
        for key, tensor in mapped.items():
            ours[key].copy_(tensor.to(ours[key].dtype))
    return [k for k in ours if k not in mapped]


def _read_hf_config(path_or_hf_config: Any) -> tuple[dict[str, Any], str]:
    if isinstance(path_or_hf_config, dict):
        return dict(path_or_hf_config), "VideoMAE config"
    if hasattr(path_or_hf_config, "to_dict"):
        return path_or_hf_config.to_dict(), "VideoMAE config"
    path = Path(path_or_hf_config)
    path = path / "config.json" if path.is_dir() else path
    return read_json_object(path, "a VideoMAE config.json"), str(path)


def _pair(value: Any, name: str, where: str) -> tuple[int, int]:
    if isinstance(value, int):
        return value, value
    if isinstance(value, list | tuple) and len(value) == 2:
        return int(value[0]), int(value[1])
    raise ValueError(f"{where}: {name} must be an int or [height, width], got {value!r}")


def encoder_config_from_videomae(path_or_hf_config: Any) -> dict[str, Any]:
    """TactileEncoderConfig fields of a VideoMAE config (a directory, its config.json, a dict or a VideoMAEConfig).

    Merge the result into a :class:`TactileEncoderConfig` (``replace(**fields)``) before :func:`load_videomae`.
    """
    cfg, where = _read_hf_config(path_or_hf_config)
    model_type = cfg.get("model_type", "videomae")
    if model_type != "videomae":
        raise ValueError(f"{where}: model_type is {model_type!r}, not 'videomae'")
    if cfg.get("num_channels", 3) != 3:
        raise ValueError(f"{where}: num_channels is {cfg['num_channels']}; the tactile encoder takes RGB (3)")
    if cfg.get("hidden_act", "gelu") != "gelu":
        raise ValueError(f"{where}: hidden_act {cfg['hidden_act']!r} is not supported (the encoder uses exact GELU)")
    patch = _pair(cfg.get("patch_size", 16), "patch_size", where)
    if patch[0] != patch[1]:
        raise ValueError(f"{where}: patch_size {list(patch)} is not square")
    hidden = int(cfg.get("hidden_size", 768))
    intermediate = int(cfg.get("intermediate_size", 4 * hidden))
    qkv_bias = cfg.get("qv_bias", cfg.get("qkv_bias", True))
    return {
        "num_frames": int(cfg.get("num_frames", 16)),
        "image_size": _pair(cfg.get("image_size", 224), "image_size", where),
        "patch_size": patch[0],
        "tubelet_size": int(cfg.get("tubelet_size", 2)),
        "hidden_size": hidden,
        "num_layers": int(cfg.get("num_hidden_layers", 12)),
        "num_heads": int(cfg.get("num_attention_heads", 12)),
        "mlp_ratio": intermediate / hidden,
        "layer_norm_eps": float(cfg.get("layer_norm_eps", 1e-12)),
        "qkv_bias": bool(qkv_bias),
    }


def is_videomae_dir(directory: str | os.PathLike[str]) -> bool:
    """Whether ``directory``'s config.json is a Hugging Face VideoMAE one (``"model_type": "videomae"``).

    Unreadable JSON answers False: the loader then reports the file itself.
    """
    path = Path(directory) / "config.json"
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(data, dict) and data.get("model_type") == "videomae"


def videomae_encoder_config(directory: str | os.PathLike[str]) -> TactileEncoderConfig:
    """The appearance ViT's config for a VideoMAE directory (its shape; nothing is loaded)."""
    path = Path(directory) / "config.json"
    fields = encoder_config_from_videomae(path)
    # tokens_per_video/fusion_heads are no part of the ViT: set so only the checkpoint's own shape is checked here
    # (build_model takes the shape fields alone, onto the model's own encoder config).
    try:
        return TactileEncoderConfig(**{**fields, "tokens_per_video": 1, "fusion_heads": 1})
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def videomae_video_settings(directory: str | os.PathLike[str]) -> dict[str, Any]:
    """How a VideoMAE directory's frames are prepared, as :class:`VideoProcessingConfig` fields: the sensor image as it
    is (``background: keep``: VideoMAE saw whole RGB frames, never an imprint minus the gel at rest), normalised
    with its image processor's ``image_mean``/``image_std``.

    Read from ``preprocessor_config.json`` (or ``video_preprocessor_config.json``); keys the file omits take
    transformers' class defaults, ``do_normalize: false`` means mean 0 and std 1. The processor rescales by 1/255,
    which our frames in [0, 1] already are: any other ``rescale_factor``, or ``do_rescale: false``, is an error
    rather than a silently different input scale. Without either file: ImageNet's mean and std, which VideoMAE
    was pre-trained with. Resizing stays ours (the encoder config fixes the size).
    """
    directory = Path(directory)
    path = next((directory / n for n in PREPROCESSOR_NAMES if (directory / n).is_file()), None)
    if path is None:
        return {"background": "keep", "mean": list(IMAGENET_MEAN), "std": list(IMAGENET_STD)}
    data = read_json_object(path, "a VideoMAE image processor config")
    if data.get("do_rescale", True) is not True:
        raise ValueError(f"{path}: do_rescale is {data['do_rescale']!r}; the frames are prepared as pixels/255, so "
                         f"only a processor that rescales by 1/255 fits (set do_rescale: true)")
    factor = data.get("rescale_factor", 1 / 255)
    if isinstance(factor, bool) or not isinstance(factor, int | float) or not math.isclose(factor * 255, 1.0,
                                                                                          rel_tol=1e-6):
        raise ValueError(f"{path}: rescale_factor is {factor!r}; the frames are prepared as pixels/255 (0.00392…), "
                         f"so another scale cannot be reproduced")
    if data.get("do_normalize", True) is False:
        return {"background": "keep", "mean": 0.0, "std": 1.0}
    mean = _channels(data.get("image_mean", _HF_PROCESSOR_DEFAULT), "image_mean", path)
    std = _channels(data.get("image_std", _HF_PROCESSOR_DEFAULT), "image_std", path)
    if min(std) <= 0:
        raise ValueError(f"{path}: image_std must be > 0, got {std}")
    return {"background": "keep", "mean": mean, "std": std}


def _channels(value: Any, name: str, path: Path) -> list[float]:
    """Three per-channel numbers (one number stands for all three, as in transformers)."""
    if isinstance(value, int | float) and not isinstance(value, bool):
        return [float(value)] * 3
    if (isinstance(value, list | tuple) and len(value) == 3
            and all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)):
        return [float(v) for v in value]
    raise ValueError(f"{path}: {name} must be one number or three (R, G, B), got {value!r}")
