"""The appearance branch: a VideoMAE-style ViT over space-time tubelets, plus a learned CLS token.

Its parameters map one to one onto Hugging Face ``VideoMAEModel``'s (see :mod:`tacreasoner.model.videomae`),
so a VideoMAE or VTV-LLM checkpoint can initialise it; the CLS token is the one thing VideoMAE lacks.
The position code is VideoMAE's fixed sinusoid table over the flattened (t, h, w) tubelet index, so
time is encoded without learned parameters and a VideoMAE checkpoint sees the positions it was
trained with. Without a checkpoint the project pre-trains it itself (:mod:`tacreasoner.model.masked_video`).
"""

from __future__ import annotations

import os
from pathlib import Path

import torch
from torch import nn
from torch.nn import functional as F

from tacreasoner.model.appearance_io import (
    CONFIG_NAME,
    WEIGHTS_NAME,
    load_checked,
    load_safetensors_strict,
    read_own_config,
    save_appearance,
)
from tacreasoner.model.encoder_config import TactileEncoderConfig

__all__ = ["CONFIG_NAME", "WEIGHTS_NAME", "AppearanceEncoder", "TransformerBlock", "TubeletEmbedding",
           "build_appearance", "init_vit_weights", "load_appearance", "load_safetensors_strict", "num_parameters",
           "patchify", "read_appearance_config", "save_appearance", "sinusoid_table", "videomae_appearance"]



def sinusoid_table(n_positions: int, dim: int) -> torch.Tensor:
    """VideoMAE's fixed table (n_positions × dim, float32): sin on even, cos on odd channels.

    Computed in float64 like the numpy original, so the values equal Hugging Face's to the last bit
    of float32.
    """
    position = torch.arange(n_positions, dtype=torch.float64)[:, None]
    exponent = 2 * (torch.arange(dim, dtype=torch.float64) // 2) / dim
    angles = position / torch.pow(torch.tensor(10000.0, dtype=torch.float64), exponent)
    table = torch.empty(n_positions, dim, dtype=torch.float64)
    table[:, 0::2] = torch.sin(angles[:, 0::2])
    table[:, 1::2] = torch.cos(angles[:, 1::2])
    return table.float()


def patchify(pixel_values: torch.Tensor, tubelet_size: int, patch_size: int) -> torch.Tensor:
    """V×T×C×H×W → V×N×(C·tubelet·patch·patch), N in (t, h, w) order, values in Conv3d weight order (C, t, p, p)."""
    v, t, c, h, w = pixel_values.shape
    x = pixel_values.reshape(v, t // tubelet_size, tubelet_size, c, h // patch_size, patch_size,
                             w // patch_size, patch_size)
    x = x.permute(0, 1, 4, 6, 3, 2, 5, 7)  # V, t', h', w', C, tubelet, p, p
    return x.reshape(v, -1, c * tubelet_size * patch_size * patch_size)


class TubeletEmbedding(nn.Module):
    """Conv3d with kernel = stride = (tubelet, patch, patch), applied as a matmul over gathered tubelets.

    Gathering first means masked pre-training embeds only the visible tubelets; the result is the
    Conv3d's (same weights, same layout as VideoMAE's ``patch_embeddings.projection``).
    """

    def __init__(self, config: TactileEncoderConfig) -> None:
        super().__init__()
        self.tubelet_size, self.patch_size = config.tubelet_size, config.patch_size
        kernel = (config.tubelet_size, config.patch_size, config.patch_size)
        self.proj = nn.Conv3d(3, config.hidden_size, kernel_size=kernel, stride=kernel)

    def forward(self, pixel_values: torch.Tensor, keep_index: torch.Tensor | None = None) -> torch.Tensor:
        patches = patchify(pixel_values, self.tubelet_size, self.patch_size)
        if keep_index is not None:
            patches = torch.gather(patches, 1, keep_index[..., None].expand(-1, -1, patches.shape[-1]))
        weight = self.proj.weight.reshape(self.proj.out_channels, -1)
        return F.linear(patches, weight, self.proj.bias)


class SelfAttention(nn.Module):
    """VideoMAE's attention: q/k/v without bias terms of their own, a query and a value bias, none on the key."""

    def __init__(self, hidden_size: int, num_heads: int, qkv_bias: bool) -> None:
        super().__init__()
        self.num_heads = num_heads
        self.query = nn.Linear(hidden_size, hidden_size, bias=False)
        self.key = nn.Linear(hidden_size, hidden_size, bias=False)
        self.value = nn.Linear(hidden_size, hidden_size, bias=False)
        self.q_bias = nn.Parameter(torch.zeros(hidden_size)) if qkv_bias else None
        self.v_bias = nn.Parameter(torch.zeros(hidden_size)) if qkv_bias else None
        self.proj = nn.Linear(hidden_size, hidden_size)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        b, n, d = x.shape

        def heads(t: torch.Tensor) -> torch.Tensor:
            return t.reshape(b, n, self.num_heads, d // self.num_heads).transpose(1, 2)

        q = heads(F.linear(x, self.query.weight, self.q_bias))
        k = heads(self.key(x))
        v = heads(F.linear(x, self.value.weight, self.v_bias))
        out = F.scaled_dot_product_attention(q, k, v)
        return self.proj(out.transpose(1, 2).reshape(b, n, d))


class Mlp(nn.Module):
    def __init__(self, hidden_size: int, inner: int) -> None:
        super().__init__()
        self.fc1 = nn.Linear(hidden_size, inner)
        self.fc2 = nn.Linear(inner, hidden_size)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.fc2(F.gelu(self.fc1(x)))


class TransformerBlock(nn.Module):
    """Pre-norm block: x + Attn(LN(x)), then x + MLP(LN(x)) (VideoMAE's ``layernorm_before/after``)."""

    def __init__(self, hidden_size: int, num_heads: int, mlp_ratio: float, eps: float, qkv_bias: bool = True) -> None:
        super().__init__()
        self.norm1 = nn.LayerNorm(hidden_size, eps=eps)
        self.attn = SelfAttention(hidden_size, num_heads, qkv_bias)
        self.norm2 = nn.LayerNorm(hidden_size, eps=eps)
        self.mlp = Mlp(hidden_size, round(hidden_size * mlp_ratio))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = x + self.attn(self.norm1(x))
        return x + self.mlp(self.norm2(x))


def init_vit_weights(module: nn.Module) -> None:
    """Truncated-normal(0.02) weights and zero biases (VideoMAE/ViT), unit LayerNorms."""
    if isinstance(module, nn.Linear | nn.Conv3d):
        nn.init.trunc_normal_(module.weight, std=0.02)
        if module.bias is not None:
            nn.init.zeros_(module.bias)
    elif isinstance(module, nn.LayerNorm):
        nn.init.ones_(module.weight)
        nn.init.zeros_(module.bias)


class AppearanceEncoder(nn.Module):
    """pixel_values V×T×3×H×W → V×(1+N)×D tokens, CLS first, then the N tubelet tokens in (t, h, w) order.

    ``keep_index`` (V×N_keep, indices into the N tubelets) embeds and runs only those tubelets, for
    masked pre-training; the output is then V×(1+N_keep)×D in the order given.
    """

    def __init__(self, config: TactileEncoderConfig) -> None:
        super().__init__()
        self.config = config
        self.patch_embed = TubeletEmbedding(config)
        self.cls_token = nn.Parameter(torch.zeros(1, 1, config.hidden_size))
        self.blocks = nn.ModuleList(
            TransformerBlock(config.hidden_size, config.num_heads, config.mlp_ratio, config.layer_norm_eps,
                             config.qkv_bias) for _ in range(config.num_layers))
        self.norm = nn.LayerNorm(config.hidden_size, eps=config.layer_norm_eps)
        self.gradient_checkpointing = False
        # Not a buffer: it is fixed, never saved, and must survive meta-device construction (HF loading).
        self._position_cache: dict[tuple[torch.device, torch.dtype], torch.Tensor] = {}
        self.apply(init_vit_weights)
        # MAE: the patch projection initialised like a Linear layer (xavier) — 5× trunc-normal(0.02) here, so
        # small tactile imprints are not drowned by the unit-scale position code at the start.
        nn.init.xavier_uniform_(self.patch_embed.proj.weight.view(self.patch_embed.proj.out_channels, -1))
        nn.init.trunc_normal_(self.cls_token, std=0.02)

    @property
    def hidden_size(self) -> int:
        return self.config.hidden_size

    def position_embeddings(self, device: torch.device, dtype: torch.dtype) -> torch.Tensor:
        """1×N×D sinusoid table (cached per device and dtype)."""
        key = (device, dtype)
        if key not in self._position_cache:
            table = sinusoid_table(self.config.num_patches, self.config.hidden_size)
            self._position_cache[key] = table[None].to(device=device, dtype=dtype)
        return self._position_cache[key]

    def forward(self, pixel_values: torch.Tensor, keep_index: torch.Tensor | None = None, *,
                add_cls: bool = True) -> torch.Tensor:
        """``add_cls=False`` runs the tubelet tokens alone, exactly as VideoMAE does (V×N×D, no CLS)."""
        self._check(pixel_values, keep_index)
        pixel_values = pixel_values.to(self.cls_token.dtype)
        x = self.patch_embed(pixel_values, keep_index)
        pos = self.position_embeddings(x.device, x.dtype).expand(len(x), -1, -1)
        if keep_index is not None:
            pos = torch.gather(pos, 1, keep_index[..., None].expand(-1, -1, pos.shape[-1]))
        x = x + pos
        if add_cls:
            x = torch.cat([self.cls_token.expand(len(x), -1, -1), x], dim=1)
        for block in self.blocks:
            if self.gradient_checkpointing and self.training and torch.is_grad_enabled():
                x = torch.utils.checkpoint.checkpoint(block, x, use_reentrant=False)
            else:
                x = block(x)
        return self.norm(x)

    def _check(self, pixel_values: torch.Tensor, keep_index: torch.Tensor | None) -> None:
        c = self.config
        expected = (c.num_frames, 3, *c.image_size)
        if pixel_values.ndim != 5 or tuple(pixel_values.shape[1:]) != expected:
            raise ValueError(f"AppearanceEncoder: pixel_values must be videos×{'×'.join(map(str, expected))}, "
                             f"got {tuple(pixel_values.shape)}")
        if keep_index is not None:
            if keep_index.ndim != 2 or len(keep_index) != len(pixel_values):
                raise ValueError(f"AppearanceEncoder: keep_index must be videos×N_keep ({len(pixel_values)}×…), "
                                 f"got {tuple(keep_index.shape)}")
            if keep_index.dtype != torch.long:
                raise ValueError(f"AppearanceEncoder: keep_index must be int64, got {keep_index.dtype}")

    # ------------------------------------------------------------------ save / load (HF conventions)
    def save_pretrained(self, save_directory: str | os.PathLike[str]) -> Path:
        """``config.json`` (the encoder config) + ``model.safetensors``; returns the directory."""
        return save_appearance(self, save_directory)

    @classmethod
    def from_pretrained(cls, directory: str | os.PathLike[str], *, dtype: torch.dtype | None = None,
                        config: TactileEncoderConfig | None = None) -> AppearanceEncoder:
        """Load a directory written by :meth:`save_pretrained` (or a Hugging Face VideoMAE one, see
        :func:`load_appearance`); every key and shape is checked.

        ``config`` overrides the saved config (e.g. another ``num_frames``: the weights do not depend on it).
        """
        model = load_appearance(directory, dtype=dtype, config=config)
        if not isinstance(model, cls):
            raise ValueError(f"{directory}: holds a {config_backbone(model)} backbone, not the ViT")
        return model


def config_backbone(model: nn.Module) -> str:
    return getattr(getattr(model, "config", None), "backbone", "vit")


def build_appearance(config: TactileEncoderConfig) -> nn.Module:
    """The appearance branch ``config.backbone`` names, freshly initialised (the ViT) or unloaded (a backbone)."""
    if config.backbone == "efficientnet_lite0":
        from tacreasoner.model.efficientnet import EfficientNetAppearance

        return EfficientNetAppearance(config)
    return AppearanceEncoder(config)


def load_appearance(directory: str | os.PathLike[str], *, dtype: torch.dtype | None = None,
                    config: TactileEncoderConfig | None = None) -> nn.Module:
    """The appearance branch saved in ``directory`` (the ViT or a backbone, as its config.json says); every key and
    shape is checked. ``config`` overrides the saved config.

    A Hugging Face VideoMAE directory (config.json with ``"model_type": "videomae"``, as ``VideoMAEModel`` /
    ``VideoMAEForPreTraining`` / ``VideoMAEForVideoClassification.save_pretrained`` write it) is taken as it is, so a
    VideoMAE-Base needs no conversion: :func:`tacreasoner.model.videomae.videomae_appearance` builds the ViT."""
    from tacreasoner.model.videomae import is_videomae_dir

    directory = Path(directory)
    if is_videomae_dir(directory):
        encoder = videomae_appearance(directory, config)
        return encoder.to(dtype) if dtype is not None else encoder
    return load_checked(build_appearance(config or read_own_config(directory)), directory, dtype)


def videomae_appearance(directory: str | os.PathLike[str], config: TactileEncoderConfig | None = None,
                        ) -> AppearanceEncoder:
    """The appearance ViT of a Hugging Face VideoMAE directory, shaped by its config.json and filled by
    :func:`load_videomae`; the CLS token VideoMAE lacks starts from :data:`CLS_SEED`.

    ``config`` overrides the shape read from config.json (e.g. another ``num_frames``: the weights do not depend
    on it); the weights must still fit it, and the checkpoint must still be an RGB, exact-GELU VideoMAE.
    """
    from tacreasoner.model.videomae import (
        CLS_SEED,
        encoder_config_from_videomae,
        load_videomae,
        videomae_encoder_config,
    )

    directory = Path(directory)
    if config is None:
        config = videomae_encoder_config(directory)
    else:
        path = directory / "config.json"
        encoder_config_from_videomae(path)  # still a VideoMAE of RGB frames with exact GELU
        if config.backbone != "vit":
            raise ValueError(f"{path}: a VideoMAE checkpoint fills the ViT, not backbone {config.backbone!r}")
    encoder = AppearanceEncoder(config)
    fresh = load_videomae(encoder, directory)
    if "cls_token" in fresh:
        generator = torch.Generator().manual_seed(CLS_SEED)
        with torch.no_grad():
            encoder.cls_token.copy_(0.02 * torch.randn(encoder.cls_token.shape, generator=generator))
    return encoder


def read_appearance_config(directory: str | os.PathLike[str]) -> TactileEncoderConfig:
    """The encoder config of an appearance directory (ours or a VideoMAE one) without loading its weights: its shape,
    for planning memory or checking a config before the model is built."""
    from tacreasoner.model.videomae import is_videomae_dir, videomae_encoder_config

    directory = Path(directory)
    return videomae_encoder_config(directory) if is_videomae_dir(directory) else read_own_config(directory)


def num_parameters(module: nn.Module) -> int:
    return sum(p.numel() for p in module.parameters())

