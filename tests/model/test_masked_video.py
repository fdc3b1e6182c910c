"""Masked video reconstruction: tube masks, target layout, the model's loss and gradients."""

from __future__ import annotations

import pytest
import torch

from tacreasoner.model.appearance import AppearanceEncoder
from tacreasoner.model.encoder_config import TactileEncoderConfig
from tacreasoner.model.masked_video import MaskedVideoConfig, MaskedVideoModel, pixel_targets, tube_mask

CFG = TactileEncoderConfig(num_frames=6, image_size=(16, 32), patch_size=8, tubelet_size=2, hidden_size=32,
                           num_layers=1, num_heads=2, tokens_per_video=1, fusion_heads=2)


def test_tube_mask_hides_the_same_places_in_every_time_slice() -> None:
    grid = (3, 4, 5)
    keep, mask = tube_mask(7, grid, 0.75, generator=torch.Generator().manual_seed(0))
    assert keep.shape == (7, 3 * 5) and mask.shape == (7, 3 * 15)  # round(0.75·20) = 15 hidden per slice
    for k, m in zip(keep, mask, strict=True):
        assert sorted(torch.cat([k, m]).tolist()) == list(range(60))
        assert torch.equal(k, k.sort().values) and torch.equal(m, m.sort().values)
        slices = [set((m[(m // 20) == t] % 20).tolist()) for t in range(3)]
        assert slices[0] == slices[1] == slices[2]
    assert not all(torch.equal(mask[0], row) for row in mask[1:])  # samples get different masks
    again = tube_mask(7, grid, 0.75, generator=torch.Generator().manual_seed(0))
    assert torch.equal(again[1], mask)


def test_tube_mask_keeps_and_hides_at_least_one() -> None:
    keep, mask = tube_mask(2, (1, 2, 2), 0.99)
    assert keep.shape == (2, 1) and mask.shape == (2, 3)
    keep, mask = tube_mask(2, (1, 2, 2), 0.01)
    assert keep.shape == (2, 3) and mask.shape == (2, 1)


def test_targets_follow_the_token_order() -> None:
    x = torch.randn(2, 6, 3, 16, 32)
    raw = pixel_targets(x, 2, 8, normalise=False)
    assert raw.shape == (2, 3 * 2 * 4, 2 * 8 * 8 * 3)
    n = 1 * 8 + 1 * 4 + 2  # tubelet (t=1, h=1, w=2)
    block = x[1, 2:4, :, 8:16, 16:24].permute(0, 2, 3, 1)  # (tubelet, patch, patch, channel) like VideoMAE
    torch.testing.assert_close(raw[1, n], block.reshape(-1))
    pooled = pixel_targets(x, 2, 8, normalise=False, pool=8)
    torch.testing.assert_close(pooled[1, n], block.mean(dim=(1, 2)).reshape(-1))
    norm = pixel_targets(x, 2, 8).reshape(2, 24, 128, 3)
    torch.testing.assert_close(norm.mean(2), torch.zeros(2, 24, 3), atol=1e-5, rtol=0)
    torch.testing.assert_close(norm.std(2), torch.ones(2, 24, 3), atol=1e-3, rtol=0)
    floored = pixel_targets(x * 1e-3, 2, 8, std_floor=1.0)
    assert floored.abs().max() < 0.01  # flat patches are not blown up to unit variance


def test_model_loss_and_gradients() -> None:
    torch.manual_seed(0)
    model = MaskedVideoModel(AppearanceEncoder(CFG), MaskedVideoConfig(mask_ratio=0.75, decoder_hidden_size=16,
                                                                       decoder_layers=1, decoder_heads=2))
    x = torch.randn(3, 6, 3, 16, 32)
    out = model(x, generator=torch.Generator().manual_seed(1))
    # 6 of 8 places hidden in each of 3 slices; default target: one colour per frame of a tubelet (2 × 3 values)
    assert out.prediction.shape == out.target.shape == (3, 3 * 6, 2 * 3)
    out.loss.backward()
    assert torch.isfinite(out.loss)
    assert model.encoder.patch_embed.proj.weight.grad.abs().sum() > 0
    assert model.encoder.cls_token.grad.abs().sum() > 0  # the CLS token reaches the decoder


def test_given_indices_and_other_targets() -> None:
    videomae_like = MaskedVideoConfig(target_pool=1, norm_target=True, decoder_conv=False, decoder_hidden_size=16)
    out = MaskedVideoModel(AppearanceEncoder(CFG), videomae_like)(torch.randn(2, 6, 3, 16, 32))
    assert out.prediction.shape == (2, 3 * 7, 2 * 8 * 8 * 3) and torch.isfinite(out.loss)  # ratio 0.9: 7 of 8
    model = MaskedVideoModel(AppearanceEncoder(CFG), MaskedVideoConfig(target_pool=4, decoder_hidden_size=16))
    keep, mask = tube_mask(2, CFG.grid, 0.5)
    out = model(torch.randn(2, 6, 3, 16, 32), keep, mask)
    assert out.prediction.shape == (2, mask.shape[1], 2 * 2 * 2 * 3)
    with pytest.raises(ValueError, match="both keep_index and mask_index"):
        model(torch.randn(2, 6, 3, 16, 32), keep)


@pytest.mark.parametrize(("field", "value", "needle"), [("mask_ratio", 1.0, "mask_ratio"),
                                                        ("decoder_heads", 3, "multiple"),
                                                        ("target_pool", 0, "target_pool")])
def test_config_errors(field: str, value: object, needle: str) -> None:
    with pytest.raises(ValueError, match=needle):
        MaskedVideoConfig(**{field: value})
    with pytest.raises(ValueError, match="unknown keys"):
        MaskedVideoConfig.from_dict({"mask_ration": 0.9})


def test_bfloat16_autocast_and_weights() -> None:
    x = torch.randn(2, 6, 3, 16, 32)
    model = MaskedVideoModel(AppearanceEncoder(CFG), MaskedVideoConfig(decoder_hidden_size=16))
    with torch.autocast("cpu", dtype=torch.bfloat16):
        out = model(x)
    out.loss.backward()
    assert out.loss.dtype == torch.float32 and torch.isfinite(out.loss)
    out = model.to(torch.bfloat16)(x)
    out.loss.backward()
    assert torch.isfinite(out.loss)
