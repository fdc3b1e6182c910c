"""Loading Hugging Face VideoMAE weights: outputs equal HF's, every mismatch is a clear error."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import torch
import transformers
from safetensors.torch import load_file, save_file

from tacreasoner.model.appearance import AppearanceEncoder
from tacreasoner.model.encoder_config import TactileEncoderConfig
from tacreasoner.model.videomae import encoder_config_from_videomae, load_videomae, map_videomae_key

HF_KWARGS = {"image_size": 16, "patch_size": 8, "num_frames": 4, "tubelet_size": 2, "hidden_size": 32,
             "num_hidden_layers": 2, "num_attention_heads": 4, "intermediate_size": 64, "layer_norm_eps": 1e-6,
             "decoder_hidden_size": 16, "decoder_num_hidden_layers": 1, "decoder_num_attention_heads": 2,
             "decoder_intermediate_size": 32}


def save_hf(directory: Path, cls_name: str = "VideoMAEModel", **overrides: object) -> torch.nn.Module:
    """A tiny random VideoMAE (biases and norms perturbed so no parameter is trivially zero/one), saved."""
    torch.manual_seed(0)
    config = transformers.VideoMAEConfig(**{**HF_KWARGS, "use_mean_pooling": False, **overrides})
    model = getattr(transformers, cls_name)(config).eval()
    with torch.no_grad():
        for param in model.parameters():
            param.add_(0.1 * torch.randn_like(param))
    model.save_pretrained(directory)
    return model


def ours_for(directory: Path, **changes: object) -> AppearanceEncoder:
    fields = encoder_config_from_videomae(directory)
    return AppearanceEncoder(TactileEncoderConfig(**{**fields, "tokens_per_video": 1, **changes})).eval()


def clips() -> torch.Tensor:
    return torch.randn(2, 4, 3, 16, 16, generator=torch.Generator().manual_seed(3))


@pytest.mark.parametrize("cls_name", ["VideoMAEModel", "VideoMAEForPreTraining"])
def test_outputs_equal_huggingface(tmp_path: Path, cls_name: str) -> None:
    hf = save_hf(tmp_path, cls_name)
    base = hf.videomae if cls_name == "VideoMAEForPreTraining" else hf
    ours = ours_for(tmp_path)
    assert load_videomae(ours, tmp_path) == ["cls_token"]
    x = clips()
    with torch.no_grad():
        expected = base(x).last_hidden_state
        torch.testing.assert_close(ours(x, add_cls=False), expected, rtol=1e-4, atol=1e-5)
        # Masked forward: HF drops masked tubelets with bool_masked_pos, we keep the visible ones by index.
        masked = torch.zeros(2, 8, dtype=torch.bool)
        masked[0, [1, 2, 6]] = masked[1, [0, 4, 5]] = True
        keep = torch.stack([torch.nonzero(~row).flatten() for row in masked])
        torch.testing.assert_close(ours(x, keep, add_cls=False), base(x, bool_masked_pos=masked).last_hidden_state,
                                   rtol=1e-4, atol=1e-5)
        assert ours(x).shape == (2, 9, 32)


def test_transformers5_bias_names_load_too(tmp_path: Path) -> None:
    hf = save_hf(tmp_path)
    state = load_file(str(tmp_path / "model.safetensors"))
    renamed = {k.replace("attention.attention.q_bias", "attention.attention.query.bias")
                .replace("attention.attention.v_bias", "attention.attention.value.bias"): v for k, v in state.items()}
    assert renamed != state
    save_file(renamed, str(tmp_path / "model.safetensors"))
    ours = ours_for(tmp_path)
    load_videomae(ours, tmp_path)
    with torch.no_grad():
        torch.testing.assert_close(ours(clips(), add_cls=False), hf(clips()).last_hidden_state, rtol=1e-4, atol=1e-5)


def test_mean_pooling_checkpoint_leaves_final_norm_fresh(tmp_path: Path) -> None:
    save_hf(tmp_path, use_mean_pooling=True)
    assert load_videomae(ours_for(tmp_path), tmp_path) == ["cls_token", "norm.weight", "norm.bias"]


def test_config_fields(tmp_path: Path) -> None:
    save_hf(tmp_path)
    fields = encoder_config_from_videomae(tmp_path)
    assert fields == {"num_frames": 4, "image_size": (16, 16), "patch_size": 8, "tubelet_size": 2, "hidden_size": 32,
                      "num_layers": 2, "num_heads": 4, "mlp_ratio": 2.0, "layer_norm_eps": 1e-6, "qkv_bias": True}
    old_style = {"model_type": "videomae", "qkv_bias": False, "image_size": [224, 160]}
    assert encoder_config_from_videomae(old_style)["qkv_bias"] is False
    assert encoder_config_from_videomae(old_style)["image_size"] == (224, 160)
    assert encoder_config_from_videomae(transformers.VideoMAEConfig(**HF_KWARGS))["hidden_size"] == 32
    with pytest.raises(ValueError, match="model_type is 'vit'"):
        encoder_config_from_videomae({"model_type": "vit"})
    with pytest.raises(FileNotFoundError, match=r"config\.json"):
        encoder_config_from_videomae(tmp_path / "nowhere")


def test_shape_mismatch_names_key_and_both_shapes(tmp_path: Path) -> None:
    save_hf(tmp_path)
    ours = ours_for(tmp_path, mlp_ratio=4.0)
    before = {k: v.clone() for k, v in ours.state_dict().items()}
    with pytest.raises(ValueError, match=r"encoder\.layer\.0\.intermediate\.dense\.bias has shape \(64,\) "
                                         r"but blocks\.0\.mlp\.fc1\.bias needs \(128,\)"):
        load_videomae(ours, tmp_path)
    assert all(torch.equal(v, before[k]) for k, v in ours.state_dict().items())  # nothing half-loaded


def test_depth_and_bias_mismatches(tmp_path: Path) -> None:
    save_hf(tmp_path)
    with pytest.raises(ValueError, match=r"encoder\.layer\.1\..*num_layers=1"):
        load_videomae(ours_for(tmp_path, num_layers=1), tmp_path)
    with pytest.raises(ValueError, match=r"lacks weights for blocks\.2\."):
        load_videomae(ours_for(tmp_path, num_layers=3), tmp_path)
    with pytest.raises(ValueError, match="q_bias"):
        load_videomae(ours_for(tmp_path, qkv_bias=False), tmp_path)


def test_pickle_only_directory_is_refused(tmp_path: Path) -> None:
    save_hf(tmp_path)
    ours = ours_for(tmp_path)
    (tmp_path / "model.safetensors").unlink()
    (tmp_path / "pytorch_model.bin").write_bytes(b"\x80\x04 never unpickled")
    with pytest.raises(ValueError, match=r"pytorch_model\.bin"):
        load_videomae(ours, tmp_path)
    with pytest.raises(FileNotFoundError, match="not a directory"):
        load_videomae(ours, tmp_path / "config.json")


def test_unknown_encoder_key_is_an_error() -> None:
    assert map_videomae_key("videomae.decoder.head.weight") is None
    assert map_videomae_key("fc_norm.weight") is None
    assert map_videomae_key("encoder.layer.3.output.dense.bias") == "blocks.3.mlp.fc2.bias"
    with pytest.raises(ValueError, match="relative_position"):
        map_videomae_key("encoder.layer.0.attention.relative_position_bias")


def test_sharded_checkpoint(tmp_path: Path) -> None:
    hf = save_hf(tmp_path)
    state = load_file(str(tmp_path / "model.safetensors"))
    keys = sorted(state)
    shards = {"model-1.safetensors": keys[: len(keys) // 2], "model-2.safetensors": keys[len(keys) // 2:]}
    for name, part in shards.items():
        save_file({k: state[k] for k in part}, str(tmp_path / name))
    (tmp_path / "model.safetensors").unlink()
    index = {"weight_map": {k: name for name, part in shards.items() for k in part}}
    (tmp_path / "model.safetensors.index.json").write_text(json.dumps(index))
    ours = ours_for(tmp_path)
    load_videomae(ours, tmp_path)
    with torch.no_grad():
        torch.testing.assert_close(ours(clips(), add_cls=False), hf(clips()).last_hidden_state, rtol=1e-4, atol=1e-5)
