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
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

import torch

from tacreasoner.jsonl import read_json_object
from tacreasoner.model.appearance import AppearanceEncoder, load_safetensors_strict

__all__ = ["encoder_config_from_videomae", "load_videomae", "map_videomae_key"]

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


def load_videomae(encoder: AppearanceEncoder, path: str | os.PathLike[str]) -> list[str]:
    """Copy a VideoMAE checkpoint's encoder weights into ``encoder``; returns our keys left freshly initialised.

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
