"""The pretrained image backbone of the appearance branch: EfficientNet-Lite0's packaged ImageNet weights, cut at a
layer, frozen with its own batch-norm statistics, saved and loaded as an appearance folder, inside a TacReasoner
model whose processor prepares frames the way the folder says."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch
from typer.testing import CliRunner

from tacreasoner.cli import app
from tacreasoner.model.appearance import AppearanceEncoder, load_appearance
from tacreasoner.model.efficientnet import (
    EfficientNetAppearance,
    backbone_settings,
    imagenet_weights_path,
    load_imagenet_weights,
)
from tacreasoner.model.encoder_config import TactileEncoderConfig
from tests.model.tinymodel import TACTILE_ID, TEXT_CONFIG


def small(layer: str = "block112", size: tuple[int, int] = (48, 64)) -> TactileEncoderConfig:
    return backbone_settings(layer, size, 4, "contact", "keep")[0]


def test_the_packaged_imagenet_weights_are_what_the_backbone_holds() -> None:
    model = EfficientNetAppearance(small("head"))
    info = load_imagenet_weights(model)
    assert info["tensors"] == len(model.state_dict())
    state = torch.load(imagenet_weights_path(), map_location="cpu", weights_only=True)
    assert torch.equal(model.stem[0].weight, state["_conv_stem.weight"])
    assert torch.equal(model.blocks[10]._project_conv.weight, state["_blocks.10._project_conv.weight"])
    assert torch.equal(model.head[1].running_var, state["_bn1.running_var"])
    # cut earlier, the network keeps the first blocks only (and their weights)
    cut = EfficientNetAppearance(small("block112"))
    load_imagenet_weights(cut)
    assert len(cut.blocks) == 11 and cut.head is None
    assert torch.equal(cut.blocks[3]._depthwise_conv.weight, state["_blocks.3._depthwise_conv.weight"])


def test_tokens_are_every_frame_cell_after_their_clip_mean_and_batch_norm_stays_frozen() -> None:
    config = small("block112", (48, 64))
    model = EfficientNetAppearance(config)
    load_imagenet_weights(model)
    x = torch.randn(2, 4, 3, 48, 64, generator=torch.Generator().manual_seed(0))
    assert config.grid == (4, 3, 4) and config.num_patches == 48
    model.train()  # a training loop's model.train() must not switch batch norm to batch statistics
    assert not model.training and not model.stem[1].training
    before = model.stem[1].running_mean.clone()
    with torch.no_grad():
        tokens = model(x)
        again = model(x[:1])
    assert tokens.shape == (2, 1 + 48, 112)
    torch.testing.assert_close(tokens[:, 0], tokens[:, 1:].mean(dim=1))
    torch.testing.assert_close(again[0], tokens[0], rtol=1e-4, atol=1e-5)  # each clip on its own: no batch stats
    assert torch.equal(model.stem[1].running_mean, before)
    with pytest.raises(ValueError, match=r"pixel_values must be videos×4×3×48×64"):
        model(torch.zeros(1, 4, 3, 32, 32))


def test_frames_go_through_in_chunks_with_the_same_tokens(monkeypatch) -> None:
    """Evaluation batches of 3-video prompts ran out of memory when every frame went through at once."""
    import tacreasoner.model.efficientnet as effnet

    model = EfficientNetAppearance(small())
    load_imagenet_weights(model)
    x = torch.randn(3, 4, 3, 48, 64, generator=torch.Generator().manual_seed(1))
    seen: list[int] = []
    features = model.frame_features
    monkeypatch.setattr(model, "frame_features", lambda frames: seen.append(len(frames)) or features(frames))
    with torch.no_grad():
        whole = model(x)
        monkeypatch.setattr(effnet, "FRAME_CHUNK", 5)
        seen.clear()
        chunked = model(x)
    assert seen == [5, 5, 2]
    torch.testing.assert_close(chunked, whole, rtol=1e-4, atol=1e-5)


def test_encoder_get_writes_an_appearance_folder_that_loads(tmp_path: Path) -> None:
    out = tmp_path / "effnet"
    result = CliRunner().invoke(app, ["encoder", "get", "efficientnet-lite0", "--out", str(out), "--layer",
                                      "block320", "--size", "96x128", "--frames", "4"])
    assert result.exit_code == 0, result.output
    video = json.loads((out / "video_processing.json").read_text())
    assert video["background"] == "keep" and video["mean"] == [0.485, 0.456, 0.406] and video["num_frames"] == 4
    assert video["orientation"] == "match", "a DIGIT's portrait frames are turned by default"
    loaded = load_appearance(out)
    assert isinstance(loaded, EfficientNetAppearance) and loaded.config.hidden_size == 320
    reference = EfficientNetAppearance(loaded.config)
    load_imagenet_weights(reference)
    for key, value in reference.state_dict().items():
        assert torch.equal(loaded.state_dict()[key], value), key
    with pytest.raises(ValueError, match="not the ViT"):
        AppearanceEncoder.from_pretrained(out)
    bad = CliRunner().invoke(app, ["encoder", "get", "resnet50", "--out", str(tmp_path / "x")])
    assert bad.exit_code == 2 and "unknown backbone 'resnet50'" in bad.stderr
    bad = CliRunner().invoke(app, ["encoder", "get", "efficientnet-lite0", "--out", str(tmp_path / "x"),
                                   "--size", "big"])
    assert bad.exit_code == 2 and "expected HEIGHTxWIDTH" in bad.stderr
    bad = CliRunner().invoke(app, ["encoder", "get", "efficientnet-lite0", "--out", str(tmp_path / "x"),
                                   "--colour", "magnitude"])
    assert bad.exit_code == 2 and "colour 'magnitude' needs background 'subtract'" in bad.stderr


def test_config_checks_name_the_field() -> None:
    with pytest.raises(ValueError, match="hidden_size must be 112"):
        TactileEncoderConfig(backbone="efficientnet_lite0", backbone_layer="block112", hidden_size=128)
    with pytest.raises(ValueError, match="backbone_layer 'block40' is not one of"):
        TactileEncoderConfig(backbone="efficientnet_lite0", backbone_layer="block40", hidden_size=112)
    with pytest.raises(ValueError, match="backbone 'resnet' is not one of"):
        TactileEncoderConfig(backbone="resnet")


def test_a_damaged_weights_file_is_one_clear_error(tmp_path: Path) -> None:
    bad = tmp_path / "weights.pth"
    bad.write_bytes(b"not a torch file")
    with pytest.raises(ValueError, match="not a readable EfficientNet-Lite0 weights file"):
        load_imagenet_weights(EfficientNetAppearance(small()), bad)


def test_a_model_on_the_backbone_prepares_frames_as_the_folder_says(tmp_path: Path) -> None:
    """build_model with an appearance folder: the encoder takes the folder's shape, the processor its frame
    preparation (the sensor image, ImageNet's scale), and the model answers with the backbone's tokens."""
    from tokenizers import Tokenizer, models, pre_tokenizers
    from transformers import PreTrainedTokenizerFast, Qwen2Config, Qwen2ForCausalLM

    from tacreasoner.model.build import build_model

    folder = tmp_path / "effnet"
    assert CliRunner().invoke(app, ["encoder", "get", "efficientnet-lite0", "--out", str(folder), "--size", "48x64",
                                    "--frames", "4"]).exit_code == 0
    vocab = {f"t{i}": i for i in range(TACTILE_ID)}
    vocab["[UNK]"] = TACTILE_ID
    raw = Tokenizer(models.WordLevel(vocab, unk_token="[UNK]"))
    raw.pre_tokenizer = pre_tokenizers.Whitespace()
    tokenizer = PreTrainedTokenizerFast(tokenizer_object=raw, unk_token="[UNK]", eos_token="t1", pad_token="t0")
    torch.manual_seed(0)
    llm = Qwen2ForCausalLM(Qwen2Config(**TEXT_CONFIG))
    model, processor = build_model(llm, tokenizer=tokenizer, appearance=folder,
                                   encoder={"temporal_hidden_size": 32, "temporal_tokens": 2, "fusion_heads": 2,
                                            "tokens_per_video": 3})
    enc = model.encoder_config
    assert (enc.backbone, enc.backbone_layer, enc.hidden_size, enc.image_size) == \
        ("efficientnet_lite0", "block112", 112, (48, 64))
    assert processor.video_config.background == "keep" and processor.video_config.sampling == "contact"
    frames = np.random.default_rng(0).integers(0, 255, (10, 48, 64, 3), dtype=np.uint8)
    pixels = processor.preprocess_videos([frames])["pixel_values"]
    mean = torch.tensor([0.485, 0.456, 0.406])[:, None, None]
    std = torch.tensor([0.229, 0.224, 0.225])[:, None, None]
    assert float(((pixels[0] * std + mean) * 255).min()) > -1e-3  # the frames themselves, not frame − background
    loaded = load_appearance(folder)
    for key, value in loaded.state_dict().items():
        assert torch.equal(model.tactile_encoder.appearance.state_dict()[key], value), key
    ids = torch.tensor([[5, 6, *[model.config.tactile_token_id] * 3, 7]])
    with torch.no_grad():
        logits = model(input_ids=ids, attention_mask=torch.ones_like(ids), pixel_values=pixels).logits
    assert logits.shape[:2] == (1, 6) and torch.isfinite(logits).all()
