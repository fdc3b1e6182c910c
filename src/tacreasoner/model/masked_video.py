"""Masked video reconstruction (VideoMAE pre-training) for the appearance branch.

Tube masking hides the same spatial positions in every time slice, so a masked tubelet cannot be
copied from its neighbour in time: the encoder has to model what the imprint looks like and how it
evolves. The encoder sees only the visible tubelets (cheap at high mask ratios); a light decoder
puts them back in place, with a shared mask token at every hidden position, and predicts the hidden
tubelets. The loss is the mean squared error on hidden tubelets only.

Where this departs from VideoMAE, and why (measured in docs/encoder-pretraining.md):

- **Target**: each tubelet's mean colour per frame (``target_pool`` = patch size), not its pixels
  normalised per patch. Background-subtracted tactile frames are flat where nothing touches, and the
  imprint shading inside one 8×8 patch is mostly sensor and codec noise at 64×64 (real GelSight
  clips: nearest-visible-neighbour guessing does worse than predicting zero). Per-patch
  normalisation turns that noise into the whole target; the pooled target keeps what is
  predictable, where and how strongly the gel is pressed, and how that changes over time.
- **Decoder**: a depthwise 3×3×3 convolution over the tubelet grid before the attention block
  (``decoder_conv``). Without it the decoder's attention first has to learn which tokens are
  neighbours, and within a CPU budget of ~1000 steps the loss stays on that plateau (the frozen
  features then barely beat random ones); with it, the loss falls from the first hundred steps.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import torch
from torch import nn
from torch.nn import functional as F

from tacreasoner.fields import reject_unknown_fields
from tacreasoner.model.appearance import AppearanceEncoder, TransformerBlock, init_vit_weights, sinusoid_table

__all__ = ["MaskedVideoConfig", "MaskedVideoModel", "MaskedVideoOutput", "pixel_targets", "tube_mask"]


@dataclass
class MaskedVideoConfig:
    """Decoder and objective; the encoder's shape comes from its TactileEncoderConfig."""

    mask_ratio: float = 0.9
    """Share of spatial positions hidden (in every time slice): VideoMAE's 0.9."""
    decoder_hidden_size: int = 64
    decoder_layers: int = 1
    decoder_heads: int = 4
    decoder_conv: bool = True
    """Mix each tubelet with its grid neighbours (depthwise conv) before the decoder's attention."""
    target_pool: int = 8
    """Average pool×pool pixel blocks of each tubelet before predicting it (1: every pixel, as VideoMAE;
    8 with 8-pixel patches: one colour per frame and tubelet)."""
    norm_target: bool = False
    """Normalise each target tubelet by its own mean and std (VideoMAE's ``norm_pix_loss``)."""
    target_std_floor: float = 0.5
    """With ``norm_target``: lower bound of that std in input units, so flat patches are not blown up."""

    def __post_init__(self) -> None:
        if not 0.0 < self.mask_ratio < 1.0:
            raise ValueError(f"masked video: mask_ratio must be in (0, 1), got {self.mask_ratio}")
        for name in ("decoder_hidden_size", "decoder_layers", "decoder_heads"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"masked video: {name} must be ≥ 1, got {getattr(self, name)}")
        if self.decoder_hidden_size % self.decoder_heads:
            raise ValueError(f"masked video: decoder_hidden_size {self.decoder_hidden_size} must be a multiple of "
                             f"decoder_heads {self.decoder_heads}")
        if self.target_pool < 1:
            raise ValueError(f"masked video: target_pool must be ≥ 1, got {self.target_pool}")
        if self.target_std_floor < 0:
            raise ValueError(f"masked video: target_std_floor must be ≥ 0, got {self.target_std_floor}")

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any] | None) -> MaskedVideoConfig:
        data = dict(data or {})
        reject_unknown_fields(cls, data, "masked video config: unknown keys", known="declared")
        return cls(**data)


def tube_mask(batch: int, grid: tuple[int, int, int], mask_ratio: float, *,
              generator: torch.Generator | None = None,
              device: torch.device | str | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """(keep_index, mask_index), each batch×k int64 into the t·h·w tubelets, sorted ascending.

    Per sample, ``round(mask_ratio·h·w)`` spatial positions are hidden (at least one kept and one
    hidden), and the same positions are hidden in every time slice.
    """
    t, h, w = grid
    per_slice = h * w
    n_mask = min(max(round(mask_ratio * per_slice), 1), per_slice - 1)
    order = torch.argsort(torch.rand(batch, per_slice, generator=generator), dim=1)
    hidden = torch.sort(order[:, :n_mask], dim=1).values
    shown = torch.sort(order[:, n_mask:], dim=1).values
    offsets = torch.arange(t)[None, :, None] * per_slice

    def tubes(spatial: torch.Tensor) -> torch.Tensor:
        return (offsets + spatial[:, None, :]).reshape(batch, -1).to(device)

    return tubes(shown), tubes(hidden)


def pixel_targets(pixel_values: torch.Tensor, tubelet_size: int, patch_size: int, *, normalise: bool = True,
                  std_floor: float = 0.0, pool: int = 1) -> torch.Tensor:
    """V×N×(tubelet·(patch/pool)²·3) reconstruction targets, (t, h, w) tubelet order like the encoder's tokens.

    Inside a tubelet the layout is VideoMAE's (tubelet, patch, patch, channel), after averaging
    pool×pool pixel blocks; with ``normalise`` each channel of a tubelet is centred and divided by
    max(its std, ``std_floor``).
    """
    v, t, c, h, w = pixel_values.shape
    cells = patch_size // pool
    x = pixel_values.float().reshape(v, t // tubelet_size, tubelet_size, c, h // patch_size, cells, pool,
                                     w // patch_size, cells, pool).mean(dim=(6, 9))
    x = x.permute(0, 1, 4, 6, 2, 5, 7, 3).reshape(v, -1, tubelet_size * cells * cells, c)
    if normalise:
        mean = x.mean(dim=2, keepdim=True)
        std = x.var(dim=2, unbiased=True, keepdim=True).sqrt()
        x = (x - mean) / (std.clamp(min=std_floor) + 1e-6)
    return x.reshape(v, x.shape[1], -1)


@dataclass
class MaskedVideoOutput:
    loss: torch.Tensor
    prediction: torch.Tensor
    """V×N_mask×(tubelet·patch·patch·3): predicted targets of the hidden tubelets."""
    target: torch.Tensor


def _gather(x: torch.Tensor, index: torch.Tensor) -> torch.Tensor:
    return torch.gather(x, 1, index[..., None].expand(-1, -1, x.shape[-1]))


class MaskedVideoModel(nn.Module):
    """AppearanceEncoder + light transformer decoder that reconstructs hidden tubelets."""

    def __init__(self, encoder: AppearanceEncoder, config: MaskedVideoConfig | None = None) -> None:
        super().__init__()
        self.encoder = encoder
        self.config = config = config or MaskedVideoConfig()
        enc = encoder.config
        dim = config.decoder_hidden_size
        self.encoder_to_decoder = nn.Linear(enc.hidden_size, dim, bias=False)
        self.mask_token = nn.Parameter(torch.zeros(1, 1, dim))
        self.decoder_blocks = nn.ModuleList(
            TransformerBlock(dim, config.decoder_heads, 4.0, 1e-6) for _ in range(config.decoder_layers))
        self.decoder_norm = nn.LayerNorm(dim, eps=1e-6)
        # Optional local mixing (depthwise 3×3×3 conv over the tubelet grid): hidden tubelets see their visible
        # neighbours at once instead of waiting for attention to learn where its neighbours are.
        self.local = nn.Sequential(nn.Conv3d(dim, dim, 3, padding=1, groups=dim), nn.GELU(),
                                   nn.Conv3d(dim, dim, 1)) if config.decoder_conv else None
        if enc.patch_size % config.target_pool:
            raise ValueError(f"masked video: target_pool {config.target_pool} must divide patch_size {enc.patch_size}")
        self.head = nn.Linear(dim, 3 * enc.tubelet_size * (enc.patch_size // config.target_pool) ** 2)
        for module in (self.encoder_to_decoder, self.decoder_blocks, self.decoder_norm, self.head):
            module.apply(init_vit_weights)
        if self.local is not None:
            nn.init.zeros_(self.local[-1].weight)  # starts as the identity: the residual adds nothing yet
            nn.init.zeros_(self.local[-1].bias)
        nn.init.trunc_normal_(self.mask_token, std=0.02)
        self._position_cache: dict[tuple[torch.device, torch.dtype], torch.Tensor] = {}

    def _decoder_positions(self, device: torch.device, dtype: torch.dtype) -> torch.Tensor:
        key = (device, dtype)
        if key not in self._position_cache:
            table = sinusoid_table(self.encoder.config.num_patches, self.config.decoder_hidden_size)
            self._position_cache[key] = table[None].to(device=device, dtype=dtype)
        return self._position_cache[key]

    def forward(self, pixel_values: torch.Tensor, keep_index: torch.Tensor | None = None,
                mask_index: torch.Tensor | None = None, *, generator: torch.Generator | None = None
                ) -> MaskedVideoOutput:
        """Mask (tube masking unless indices are given), encode the visible part, reconstruct the rest."""
        enc = self.encoder.config
        if (keep_index is None) != (mask_index is None):
            raise ValueError("give both keep_index and mask_index, or neither")
        if keep_index is None:
            keep_index, mask_index = tube_mask(len(pixel_values), enc.grid, self.config.mask_ratio,
                                               generator=generator, device=pixel_values.device)
        tokens = self.encoder(pixel_values, keep_index)  # V×(1+N_keep)×D, CLS first
        x = self.encoder_to_decoder(tokens)
        v, dim = len(x), x.shape[-1]
        # Every tubelet back in its (t, h, w) place: encoded where visible, the mask token where hidden.
        grid = self.mask_token.to(x.dtype).expand(v, enc.num_patches, -1).clone()
        grid = grid.scatter(1, keep_index[..., None].expand(-1, -1, dim), x[:, 1:])
        grid = grid + self._decoder_positions(x.device, x.dtype)
        if self.local is not None:
            t, h, w = enc.grid
            cube = grid.transpose(1, 2).reshape(v, dim, t, h, w)
            grid = grid + self.local(cube).reshape(v, dim, -1).transpose(1, 2)
        # The CLS token goes to the decoder too (as in MAE), so it is trained to summarise the clip.
        x = torch.cat([x[:, :1], grid], dim=1)
        for block in self.decoder_blocks:
            x = block(x)
        prediction = self.head(self.decoder_norm(_gather(x[:, 1:], mask_index)))
        with torch.no_grad():
            target = _gather(pixel_targets(pixel_values, enc.tubelet_size, enc.patch_size,
                                           normalise=self.config.norm_target,
                                           std_floor=self.config.target_std_floor, pool=self.config.target_pool),
                             mask_index)
        loss = F.mse_loss(prediction.float(), target)
        return MaskedVideoOutput(loss=loss, prediction=prediction, target=target)
