"""AppearanceEncoder: shapes, masking path, Conv3d equivalence, save/load and its errors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch

from tacreasoner.model.appearance import AppearanceEncoder, patchify, sinusoid_table
from tacreasoner.model.encoder_config import TactileEncoderConfig

CFG = TactileEncoderConfig(num_frames=4, image_size=(16, 24), patch_size=8, tubelet_size=2, hidden_size=32,
                           num_layers=2, num_heads=4, tokens_per_video=1, fusion_heads=4)


@pytest.fixture()
def encoder() -> AppearanceEncoder:
    torch.manual_seed(0)
    return AppearanceEncoder(CFG).eval()


def videos(n: int = 2) -> torch.Tensor:
    return torch.randn(n, CFG.num_frames, 3, *CFG.image_size, generator=torch.Generator().manual_seed(1))


def test_output_shapes(encoder: AppearanceEncoder) -> None:
    assert CFG.grid == (2, 2, 3)
    with torch.no_grad():
        assert encoder(videos(3)).shape == (3, 1 + 12, 32)
        assert encoder(videos(3), add_cls=False).shape == (3, 12, 32)
        keep = torch.tensor([[0, 5, 7], [1, 2, 11], [3, 4, 6]])
        assert encoder(videos(3), keep).shape == (3, 1 + 3, 32)


def test_keep_index_selects_tokens(encoder: AppearanceEncoder) -> None:
    x = videos()
    with torch.no_grad():
        full = encoder(x)
        all_kept = encoder(x, torch.arange(12).repeat(2, 1))
        perm = torch.stack([torch.randperm(12, generator=torch.Generator().manual_seed(s)) for s in range(2)])
        permuted = encoder(x, perm)
    torch.testing.assert_close(all_kept, full, rtol=1e-5, atol=1e-5)
    # Attention is permutation-equivariant once positions are added: a permuted keep_index permutes the tokens.
    torch.testing.assert_close(permuted[:, 1:], torch.stack([full[i, 1:][perm[i]] for i in range(2)]),
                               rtol=1e-5, atol=1e-5)
    torch.testing.assert_close(permuted[:, 0], full[:, 0], rtol=1e-5, atol=1e-5)


def test_tubelet_embedding_is_the_conv3d(encoder: AppearanceEncoder) -> None:
    x = videos()
    conv = encoder.patch_embed.proj
    expected = conv(x.permute(0, 2, 1, 3, 4)).flatten(2).transpose(1, 2)
    with torch.no_grad():
        torch.testing.assert_close(encoder.patch_embed(x), expected, rtol=1e-5, atol=1e-5)
    assert patchify(x, 2, 8).shape == (2, 12, 3 * 2 * 8 * 8)


def test_sinusoid_table_matches_videomae() -> None:
    from transformers.models.videomae.modeling_videomae import get_sinusoid_encoding_table

    torch.testing.assert_close(sinusoid_table(12, 32)[None], get_sinusoid_encoding_table(12, 32))


def test_bad_inputs_are_clear_errors(encoder: AppearanceEncoder) -> None:
    with pytest.raises(ValueError, match=r"videos×4×3×16×24"):
        encoder(torch.zeros(1, 4, 3, 16, 16))
    with pytest.raises(ValueError, match="keep_index"):
        encoder(videos(), torch.zeros(3, 2, dtype=torch.long))
    with pytest.raises(ValueError, match="int64"):
        encoder(videos(), torch.zeros(2, 2, dtype=torch.int32))


def test_bfloat16(encoder: AppearanceEncoder) -> None:
    model = encoder.to(torch.bfloat16)
    with torch.no_grad():
        out = model(videos(), torch.tensor([[0, 1], [2, 3]]))
    assert out.dtype == torch.bfloat16 and torch.isfinite(out.float()).all()


def test_save_and_load_give_identical_outputs(encoder: AppearanceEncoder, tmp_path: Path) -> None:
    encoder.save_pretrained(tmp_path)
    assert json.loads((tmp_path / "config.json").read_text())["hidden_size"] == 32
    loaded = AppearanceEncoder.from_pretrained(tmp_path).eval()
    assert loaded.config == CFG
    with torch.no_grad():
        torch.testing.assert_close(loaded(videos()), encoder(videos()), rtol=0, atol=0)
    assert AppearanceEncoder.from_pretrained(tmp_path, dtype=torch.bfloat16).cls_token.dtype == torch.bfloat16


def test_load_errors_name_the_file_or_field(encoder: AppearanceEncoder, tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match=r"config\.json"):
        AppearanceEncoder.from_pretrained(tmp_path)
    encoder.save_pretrained(tmp_path)
    (tmp_path / "model.safetensors").unlink()
    with pytest.raises(FileNotFoundError, match=r"model\.safetensors"):
        AppearanceEncoder.from_pretrained(tmp_path)
    (tmp_path / "pytorch_model.bin").write_bytes(b"not a pickle, and never read as one")
    with pytest.raises(ValueError, match=r"pytorch_model\.bin.*never unpickled"):
        AppearanceEncoder.from_pretrained(tmp_path)
    (tmp_path / "model.safetensors").write_bytes(b"garbage")
    with pytest.raises(ValueError, match="cannot be read"):
        AppearanceEncoder.from_pretrained(tmp_path)


def test_mismatched_weights_name_key_and_shapes(encoder: AppearanceEncoder, tmp_path: Path) -> None:
    encoder.save_pretrained(tmp_path)
    config = json.loads((tmp_path / "config.json").read_text())
    (tmp_path / "config.json").write_text(json.dumps({**config, "mlp_ratio": 2.0}))
    with pytest.raises(ValueError, match=r"blocks\.0\.mlp\.fc1\.weight has shape \(128, 32\).*\(64, 32\)"):
        AppearanceEncoder.from_pretrained(tmp_path)
    (tmp_path / "config.json").write_text(json.dumps({**config, "num_layers": 3}))
    with pytest.raises(ValueError, match=r"missing blocks\.2\."):
        AppearanceEncoder.from_pretrained(tmp_path)
    (tmp_path / "config.json").write_text(json.dumps({**config, "hidden_sise": 3}))
    with pytest.raises(ValueError, match="hidden_sise"):
        AppearanceEncoder.from_pretrained(tmp_path)
