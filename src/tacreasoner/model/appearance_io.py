"""Reading and writing an appearance branch's folder (``config.json`` + ``model.safetensors``): shared by every
backbone (the ViT, EfficientNet-Lite0, VideoMAE's weights), so none of them has to import another to be saved or
loaded. Weights are only ever read from safetensors, never unpickled."""

from __future__ import annotations

import json
import os
from pathlib import Path

import torch
from torch import nn

from tacreasoner.jsonl import read_json_object
from tacreasoner.model.encoder_config import TactileEncoderConfig

__all__ = ["CONFIG_NAME", "WEIGHTS_NAME", "check_state", "load_checked", "load_safetensors_strict", "read_own_config",
           "save_appearance"]

CONFIG_NAME = "config.json"
WEIGHTS_NAME = "model.safetensors"


def save_appearance(model: nn.Module, save_directory: str | os.PathLike[str]) -> Path:
    """Any appearance branch as ``config.json`` (its encoder config) + ``model.safetensors``; returns the directory."""
    from safetensors.torch import save_file

    out = Path(save_directory)
    out.mkdir(parents=True, exist_ok=True)
    (out / CONFIG_NAME).write_text(json.dumps(model.config.to_dict(), indent=2) + "\n", encoding="utf-8")
    state = {k: v.detach().contiguous().cpu() for k, v in model.state_dict().items()}
    tmp = out / f".{WEIGHTS_NAME}.tmp"
    save_file(state, str(tmp), metadata={"format": "pt"})
    os.replace(tmp, out / WEIGHTS_NAME)
    return out


def read_own_config(directory: Path) -> TactileEncoderConfig:
    path = directory / CONFIG_NAME
    data = read_json_object(path, "an AppearanceEncoder directory written by save_pretrained / "
                                  "`tacreasoner pretrain-encoder`, or a Hugging Face VideoMAE directory")
    if "model_type" in data:  # no field of ours: another Hugging Face model, which the key check would only list
        raise ValueError(f"{path}: a Hugging Face {data['model_type']!r} model; the appearance branch takes a "
                         f"`pretrain-encoder` / `encoder get` output or a VideoMAE directory")
    return TactileEncoderConfig.from_dict(data, what=f"{path}: unknown encoder config keys")


def load_safetensors_strict(directory: Path) -> dict[str, torch.Tensor]:
    """``model.safetensors`` (or its sharded index) of ``directory``; never a pickle."""
    from safetensors import SafetensorError
    from safetensors.torch import load_file

    single, index = directory / WEIGHTS_NAME, directory / f"{WEIGHTS_NAME}.index.json"
    try:
        if single.is_file():
            return load_file(str(single))
        if index.is_file():
            shards = sorted(set(json.loads(index.read_text(encoding="utf-8"))["weight_map"].values()))
            state: dict[str, torch.Tensor] = {}
            for shard in shards:
                state.update(load_file(str(directory / shard)))
            return state
    except (SafetensorError, OSError, ValueError, KeyError) as exc:
        raise ValueError(f"{directory}: weights cannot be read ({exc})") from exc
    pickles = [p.name for p in (directory / "pytorch_model.bin", directory / "model.pt") if p.is_file()]
    if pickles:
        raise ValueError(f"{directory}: only pickled weights ({', '.join(pickles)}); they are never unpickled here. "
                         f"Convert them to {WEIGHTS_NAME} with safetensors where you trust the file")
    raise FileNotFoundError(f"{single}: no such file")


def check_state(expected: dict[str, torch.Tensor], found: dict[str, torch.Tensor], where: Path) -> None:
    missing = [k for k in expected if k not in found]
    unexpected = [k for k in found if k not in expected]
    if missing or unexpected:
        parts = ([f"missing {', '.join(missing)}"] if missing else []) + \
                ([f"unexpected {', '.join(unexpected)}"] if unexpected else [])
        raise ValueError(f"{where}: weights do not match the config: {'; '.join(parts)}")
    for key, tensor in expected.items():
        if tuple(found[key].shape) != tuple(tensor.shape):
            raise ValueError(f"{where}: {key} has shape {tuple(found[key].shape)}, the config needs "
                             f"{tuple(tensor.shape)}")


def load_checked(model: nn.Module, directory: Path, dtype: torch.dtype | None = None) -> nn.Module:
    """``model`` with the weights of ``directory``, every key and shape checked first."""
    state = load_safetensors_strict(directory)
    check_state(model.state_dict(), state, directory / WEIGHTS_NAME)
    model.load_state_dict(state)
    return model.to(dtype) if dtype is not None else model
