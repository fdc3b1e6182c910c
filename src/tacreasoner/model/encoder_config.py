"""Settings of the dynamic-aware tactile encoder, one flat dataclass so every ablation is one field.

Kept free of torch so configs can be validated (and documented) without the model installed.
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass
from typing import Any

from tacreasoner.fields import reject_unknown_fields

__all__ = ["BACKBONES", "BACKBONE_LAYERS", "DEFAULT_SENSOR_TYPES", "TactileEncoderConfig"]

DEFAULT_SENSOR_TYPES = ("unknown", "mini", "digit", "tac3d")
BACKBONES = ("vit", "efficientnet_lite0")
"""The appearance branch: the VideoMAE-style ViT (pre-trained here or from a VideoMAE checkpoint), or a pretrained
image backbone applied per frame (:mod:`tacreasoner.model.efficientnet`)."""
BACKBONE_LAYERS = {"block112": (11, 112, False), "block320": (16, 320, False), "head": (16, 1280, True)}
"""Where EfficientNet-Lite0 is cut: (MBConv blocks kept, channels, with the 1×1 head convolution). block112's map has
stride 16, the others 32."""


@dataclass
class TactileEncoderConfig:
    """Appearance ViT (VideoMAE-style) + temporal difference branch + fusion; defaults are the tiny CPU model."""

    # --- input (the video processor must produce exactly this)
    num_frames: int = 8
    image_size: tuple[int, int] = (64, 64)
    """(height, width) after resizing."""
    # --- appearance branch (frozen in Stages I and II)
    backbone: str = "vit"
    """``vit``: ViT over space-time tubelets (the fields below); ``efficientnet_lite0``: ImageNet's EfficientNet-Lite0
    per frame, its feature map at ``backbone_layer`` as the tokens (hidden_size = that layer's channels)."""
    backbone_layer: str = "block112"
    """For ``efficientnet_lite0``: one of ``BACKBONE_LAYERS``."""
    patch_size: int = 8
    tubelet_size: int = 2
    hidden_size: int = 128
    num_layers: int = 4
    num_heads: int = 4
    mlp_ratio: float = 4.0
    layer_norm_eps: float = 1e-6
    qkv_bias: bool = True
    # --- temporal branch: frame differences → light encoder → question-steered pooling
    use_temporal: bool = True
    temporal_hidden_size: int = 128
    temporal_tokens: int = 4
    """Length of the aggregated temporal sequence F̄_temp (time is what it is for, so more than one)."""
    question_conditioning: bool = True
    temporal_norm: bool = False
    """Each clip's difference tokens (the stem's output less its output for no change, which its biases set) scaled
    to unit RMS over time and channels before the time embedding is added. Without it the part of the stem's
    spatial average that small frame differences move is tiny beside that constant and the time embedding, and a
    trained branch's output barely depends on the clip (a still clip changed the shipped
    encoder's output by 1e-7, relative; experiments/2026-11-29_sensor_temporal_diag). Scaling per clip also takes
    a sensor's contrast (gel lighting, gain) out of the motion signal; the clip's magnitude of change is left to the
    appearance branch."""
    standardize_appearance: bool = False
    """Each channel of the frozen appearance tokens is centred and scaled by its mean and standard deviation over the
    training clips (measured when Stage I starts, no labels read, then kept in the model), as a linear probe
    standardises its features: a frozen backbone's clip-to-clip differences are small beside each channel's offset,
    and the projector learns them far more easily once they are unit-sized (docs/real-data.md)."""
    # --- fusion (Q = appearance, K = V = temporal) and output
    fusion_heads: int = 4
    tokens_per_video: int = 5
    """Tactile tokens handed to the LLM per video: 1 = CLS only (paper-faithful), n = CLS + n−1 pooled patch tokens."""
    sensor_embedding: bool = False
    sensor_types: tuple[str, ...] = DEFAULT_SENSOR_TYPES
    video_slots: int = 0
    """Places told apart by a learned vector and linear map on each video's projected tokens (``VideoSlots``;
    0 = none); at least the most videos one prompt may hold (3 on DynTAC-Sim-Bench)."""
    cross_video: int = 0
    """Most videos of one prompt that see each other through ``CrossVideoFusion`` (one attention layer over all of a
    prompt's video tokens, in the projector; 0 = off), with a comparator whose pick is written into the tokens: they
    then carry how the videos compare. The layer trains with the projector in Stages I and II; the comparator is
    fitted when Stage II starts (``train.comparator``) and frozen; docs/training.md."""
    cross_video_attributes: tuple[str, ...] = ("hardness", "protrusion", "elasticity", "friction", "roughness",
                                               "bumpiness")
    """The attributes the cross-video comparator keeps a direction for (the comparisons' ``gold.attribute``)."""
    cross_video_loss: float = 0.0
    """Weight of the comparator's losses (pick, attribute, comparative) in Stage I's training loss. 0: the comparator
    is only fitted, on the frozen encoder's features, when Stage II starts (``train.comparator``); trained jointly
    at 1.0 it held Stage I's loss at 1.0–1.8 (0.23 without) and still did not learn to pick (docs/training.md)."""
    cross_video_names: bool = True
    """With ``cross_video``: a prompt listing as many named options ("(A) kitchen sponge (B) fake apple …") as it
    holds videos gets the assignment of names to videos that best fits the videos' features (a ridge map from a
    video's features to its name's embedding, fitted with the comparator), written into its tokens instead of the
    comparator's pick (OSC; docs/training.md)."""
    clip_reader: bool = False
    """The video of a one-video prompt carries in its tokens, per trait (attribute levels, real or fake, contact
    state), a vector for the level a ridge read-out of its encoder output gives (``ClipReader``, in the projector),
    fitted when Stage II starts on the training clips' gold (``train.reader``) and frozen: Stage II keeps the
    single-clip readings Stage I had (docs/training.md)."""
    clip_reader_traits: tuple[str, ...] = ()
    """What the clip reader reads (its traits' names; the trainer fills them from the training data's labels,
    ``train.reader``): the model knows no benchmark's vocabulary."""
    clip_reader_levels: int = 0
    """The most levels of one clip-reader trait."""
    option_marker: str = ""
    """A regular expression matching the marker before each listed option of a question (e.g. ``\\(([A-Z])\\)``
    for "(A) kitchen sponge (B) fake apple"): the processor marks each option's name tokens for the name matcher.
    Empty: options are not read. The trainer sets it from the benchmark's format when the matcher is on."""
    video_labels: bool = False
    """Prompts holding several videos name each before its tokens ("Video 2: "), as the reasoning names them: the
    LLM can then find a video's tokens by its name (the processor's job; kept here so a saved model keeps it)."""

    def __post_init__(self) -> None:
        self.image_size = tuple(int(v) for v in self.image_size)  # type: ignore[assignment]
        self.sensor_types = tuple(str(s) for s in self.sensor_types)
        self.cross_video_attributes = tuple(str(a) for a in self.cross_video_attributes)
        self.clip_reader_traits = tuple(str(t) for t in self.clip_reader_traits)
        self.validate()

    # ------------------------------------------------------------------ derived sizes
    @property
    def grid(self) -> tuple[int, int, int]:
        """Token grid (time, height, width): ViT tubelets, or frames × the backbone's feature-map cells."""
        h, w = self.image_size
        if self.backbone == "efficientnet_lite0":
            stride = 16 if self.backbone_layer == "block112" else 32
            return self.num_frames, -(-h // stride), -(-w // stride)
        return self.num_frames // self.tubelet_size, h // self.patch_size, w // self.patch_size

    @property
    def num_patches(self) -> int:
        t, h, w = self.grid
        return t * h * w

    # ------------------------------------------------------------------ checks and (de)serialisation
    def validate(self) -> None:
        def positive(name: str) -> None:
            value = getattr(self, name)
            if not isinstance(value, int | float) or isinstance(value, bool) or value <= 0:
                raise ValueError(f"encoder config: {name} must be a positive number, got {value!r}")

        for name in ("num_frames", "patch_size", "tubelet_size", "hidden_size", "num_layers", "num_heads",
                     "mlp_ratio", "temporal_hidden_size", "temporal_tokens", "fusion_heads", "tokens_per_video"):
            positive(name)
        if len(self.image_size) != 2 or min(self.image_size) <= 0:
            raise ValueError(f"encoder config: image_size must be (height, width) > 0, got {self.image_size!r}")
        if self.num_frames < 2:
            raise ValueError("encoder config: num_frames must be ≥ 2 (the temporal branch needs frame differences)")
        if self.backbone not in BACKBONES:
            raise ValueError(f"encoder config: backbone {self.backbone!r} is not one of {', '.join(BACKBONES)}")
        if self.backbone == "efficientnet_lite0":
            if self.backbone_layer not in BACKBONE_LAYERS:
                raise ValueError(f"encoder config: backbone_layer {self.backbone_layer!r} is not one of "
                                 f"{', '.join(BACKBONE_LAYERS)}")
            channels = BACKBONE_LAYERS[self.backbone_layer][1]
            if self.hidden_size != channels:
                raise ValueError(f"encoder config: hidden_size must be {channels}, the channels of efficientnet_lite0 "
                                 f"at {self.backbone_layer}, got {self.hidden_size}")
        else:
            if self.num_frames % self.tubelet_size:
                raise ValueError(f"encoder config: num_frames ({self.num_frames}) must be a multiple of "
                                 f"tubelet_size ({self.tubelet_size})")
            for side, name in zip(self.image_size, ("height", "width"), strict=True):
                if side % self.patch_size:
                    raise ValueError(f"encoder config: image {name} {side} must be a multiple of patch_size "
                                     f"{self.patch_size}")
        for width, heads, what in ((self.hidden_size, self.num_heads, "hidden_size/num_heads"),
                                   (self.hidden_size, self.fusion_heads, "hidden_size/fusion_heads")):
            if width % heads:
                raise ValueError(f"encoder config: {what} must divide evenly, got {width}/{heads}")
        if self.tokens_per_video - 1 > self.num_patches:
            raise ValueError(f"encoder config: tokens_per_video {self.tokens_per_video} needs more patch tokens than "
                             f"the {self.num_patches} the ViT makes")
        if not isinstance(self.video_slots, int) or isinstance(self.video_slots, bool) or self.video_slots < 0:
            raise ValueError(f"encoder config: video_slots must be a whole number ≥ 0, got {self.video_slots!r}")
        if not isinstance(self.cross_video, int) or isinstance(self.cross_video, bool) or self.cross_video < 0:
            raise ValueError(f"encoder config: cross_video must be a whole number ≥ 0, got {self.cross_video!r}")
        if not isinstance(self.cross_video_loss, (int, float)) or isinstance(self.cross_video_loss, bool) \
                or not self.cross_video_loss >= 0:
            raise ValueError(f"encoder config: cross_video_loss must be a number ≥ 0, got {self.cross_video_loss!r}")
        if not isinstance(self.clip_reader, bool):
            raise ValueError(f"encoder config: clip_reader must be true or false, got {self.clip_reader!r}")
        if self.clip_reader and not self.clip_reader_traits:
            raise ValueError("encoder config: clip_reader needs clip_reader_traits (the traits it reads; `tacreasoner "
                             "train` fills them from the benchmark's labels)")
        if self.clip_reader_traits and (not isinstance(self.clip_reader_levels, int) or self.clip_reader_levels < 2):
            raise ValueError(f"encoder config: clip_reader_levels must be a whole number ≥ 2 with clip_reader_traits, "
                             f"got {self.clip_reader_levels!r}")
        if self.option_marker:
            try:
                re.compile(self.option_marker)
            except re.error as exc:
                raise ValueError(f"encoder config: option_marker {self.option_marker!r} is not a regular "
                                 f"expression ({exc})") from None
        if not isinstance(self.cross_video_names, bool):
            raise ValueError(f"encoder config: cross_video_names must be true or false, got {self.cross_video_names!r}")
        if not isinstance(self.standardize_appearance, bool):
            raise ValueError(f"encoder config: standardize_appearance must be true or false, got "
                             f"{self.standardize_appearance!r}")
        if not isinstance(self.video_labels, bool):
            raise ValueError(f"encoder config: video_labels must be true or false, got {self.video_labels!r}")
        if not self.sensor_types:
            raise ValueError("encoder config: sensor_types must not be empty")
        if not self.cross_video_attributes:
            raise ValueError("encoder config: cross_video_attributes must not be empty")

    def sensor_index(self, sensor: str | None) -> int:
        """Index into ``sensor_types``; ``mini+markers``/``digit@30`` map to their base style, others to 0."""
        base = (sensor or "unknown").split("+")[0].split("@")[0].lower()
        return self.sensor_types.index(base) if base in self.sensor_types else 0

    def to_dict(self) -> dict[str, Any]:
        out = dataclasses.asdict(self)
        out["image_size"] = list(self.image_size)
        out["sensor_types"] = list(self.sensor_types)
        out["cross_video_attributes"] = list(self.cross_video_attributes)
        out["clip_reader_traits"] = list(self.clip_reader_traits)
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any] | None, what: str = "encoder config: unknown keys") -> TactileEncoderConfig:
        data = dict(data or {})
        reject_unknown_fields(cls, data, what, known="declared")
        return cls(**data)

    def replace(self, **changes: Any) -> TactileEncoderConfig:
        return dataclasses.replace(self, **changes)

