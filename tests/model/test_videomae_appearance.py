"""A Hugging Face VideoMAE directory as ``model.appearance``, as it is: the ViT equals HF's, the model built on it
prepares frames with the VideoMAE image processor's numbers, and a directory that cannot be used is one clear error."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch
import transformers

from tacreasoner.model.appearance import AppearanceEncoder, load_appearance
from tacreasoner.model.build import appearance_video_settings, build_model
from tacreasoner.model.encoder_config import TactileEncoderConfig
from tacreasoner.model.videomae import IMAGENET_MEAN, IMAGENET_STD, videomae_video_settings
from tests.model.test_videomae import clips, save_hf
from tests.model.tinymodel import TACTILE_ID, TEXT_CONFIG

MEAN, STD = [0.45, 0.4, 0.35], [0.3, 0.25, 0.2]  # not ImageNet's, not transformers' default: read from the file


def save_processor(directory: Path, **kwargs: object) -> None:
    transformers.VideoMAEImageProcessor(image_mean=MEAN, image_std=STD, **kwargs).save_pretrained(directory)


def edit_json(path: Path, **changes: object) -> None:
    path.write_text(json.dumps({**json.loads(path.read_text()), **changes}))


@pytest.mark.parametrize("cls_name", ["VideoMAEModel", "VideoMAEForPreTraining", "VideoMAEForVideoClassification"])
def test_load_appearance_takes_a_videomae_directory(tmp_path: Path, cls_name: str) -> None:
    hf = save_hf(tmp_path, cls_name)
    base = hf if cls_name == "VideoMAEModel" else hf.videomae
    encoder = load_appearance(tmp_path).eval()
    assert isinstance(encoder, AppearanceEncoder)
    c = encoder.config
    assert (c.num_frames, c.image_size, c.patch_size, c.tubelet_size, c.hidden_size, c.num_layers, c.num_heads) == \
        (4, (16, 16), 8, 2, 32, 2, 4)
    x = clips()
    with torch.no_grad():
        torch.testing.assert_close(encoder(x, add_cls=False), base(x).last_hidden_state, rtol=1e-4, atol=1e-5)
        assert encoder(x).shape == (2, 9, 32)
    # VideoMAE has no CLS token: ours comes from a fixed seed, so two loads are the same encoder
    again = load_appearance(tmp_path, dtype=torch.bfloat16)
    assert again.cls_token.dtype == torch.bfloat16
    assert torch.equal(again.cls_token.float(), encoder.cls_token.bfloat16().float())
    assert AppearanceEncoder.from_pretrained(tmp_path).cls_token.equal(encoder.cls_token)


def test_config_override_keeps_the_weights_and_must_fit_them(tmp_path: Path) -> None:
    hf = save_hf(tmp_path)
    fields = {"num_frames": 4, "image_size": (16, 16), "patch_size": 8, "hidden_size": 32, "num_layers": 2,
              "num_heads": 4, "mlp_ratio": 2.0, "tokens_per_video": 1}
    longer = load_appearance(tmp_path, config=TactileEncoderConfig(**{**fields, "num_frames": 8}))
    assert longer.config.num_frames == 8  # the position table is computed, the weights do not depend on it
    assert torch.equal(longer.blocks[1].mlp.fc2.weight, hf.encoder.layer[1].output.dense.weight)
    with pytest.raises(ValueError, match=r"fc1\.bias needs \(128,\)"):
        load_appearance(tmp_path, config=TactileEncoderConfig(**{**fields, "mlp_ratio": 4.0}))


def test_a_model_built_on_a_videomae_directory(tmp_path: Path) -> None:
    """build_model(llm dir, appearance=VideoMAE dir): the ViT holds the checkpoint's weights, the processor prepares
    frames exactly as the checkpoint's own VideoMAEImageProcessor does, and the model runs on them."""
    from tokenizers import Tokenizer, models, pre_tokenizers
    from transformers import PreTrainedTokenizerFast, Qwen2Config, Qwen2ForCausalLM

    vmae = tmp_path / "videomae"
    hf = save_hf(vmae)
    save_processor(vmae)
    llm = tmp_path / "llm"
    vocab = {f"t{i}": i for i in range(TACTILE_ID)}
    vocab["[UNK]"] = TACTILE_ID
    raw = Tokenizer(models.WordLevel(vocab, unk_token="[UNK]"))
    raw.pre_tokenizer = pre_tokenizers.Whitespace()
    tokenizer = PreTrainedTokenizerFast(tokenizer_object=raw, unk_token="[UNK]", eos_token="t1", pad_token="t0")
    tokenizer.save_pretrained(llm)
    torch.manual_seed(0)
    Qwen2ForCausalLM(Qwen2Config(**TEXT_CONFIG)).save_pretrained(llm)

    model, processor = build_model(llm, appearance=vmae, encoder={"temporal_hidden_size": 32, "temporal_tokens": 2,
                                                                  "fusion_heads": 2, "tokens_per_video": 3})
    model.eval()
    enc = model.encoder_config
    assert (enc.backbone, enc.num_frames, enc.image_size, enc.hidden_size, enc.tokens_per_video) == \
        ("vit", 4, (16, 16), 32, 3)
    video = processor.video_config
    assert (list(video.mean), list(video.std), video.background) == (MEAN, STD, "keep")
    assert (video.num_frames, video.image_size) == (4, (16, 16))
    ours = model.tactile_encoder.appearance.state_dict()
    for key, value in load_appearance(vmae).state_dict().items():
        assert torch.equal(ours[key], value), key
    assert torch.equal(ours["patch_embed.proj.weight"], hf.embeddings.patch_embeddings.projection.weight)

    frames = np.random.default_rng(0).integers(0, 256, (4, 16, 16, 3), dtype=np.uint8)
    pixels = processor.preprocess_videos([frames])["pixel_values"]
    reference = transformers.VideoMAEImageProcessor.from_pretrained(vmae)(
        list(frames), do_resize=False, do_center_crop=False, return_tensors="pt")["pixel_values"]
    torch.testing.assert_close(pixels, reference.float(), rtol=1e-5, atol=1e-5)
    ids = torch.tensor([[5, 6, *[model.config.tactile_token_id] * 3, 7]])
    with torch.no_grad():
        torch.testing.assert_close(model.tactile_encoder.appearance(pixels, add_cls=False),
                                   hf(pixels).last_hidden_state, rtol=1e-4, atol=1e-5)
        logits = model(input_ids=ids, attention_mask=torch.ones_like(ids), pixel_values=pixels).logits
    assert logits.shape[:2] == (1, 6) and torch.isfinite(logits).all()


def test_the_frame_preparation_a_videomae_directory_asks_for(tmp_path: Path) -> None:
    save_hf(tmp_path)
    imagenet = appearance_video_settings(tmp_path)  # no preprocessor_config.json: what VideoMAE was trained with
    assert (imagenet["mean"], imagenet["std"], imagenet["background"]) == \
        (list(IMAGENET_MEAN), list(IMAGENET_STD), "keep")
    save_processor(tmp_path)
    assert appearance_video_settings(tmp_path)["mean"] == MEAN
    from tacreasoner.evaluate.retrieval import load_encoder

    _, video = load_encoder(tmp_path)  # retrieval embeds clips prepared as the model's processor prepares them
    assert (list(video.mean), list(video.std), video.background, video.num_frames) == (MEAN, STD, "keep", 4)
    processor_file = tmp_path / "preprocessor_config.json"
    edit_json(processor_file, do_normalize=False)
    assert (videomae_video_settings(tmp_path)["mean"], videomae_video_settings(tmp_path)["std"]) == (0.0, 1.0)
    edit_json(processor_file, do_normalize=True, image_mean=0.5, image_std=[0.5, 0.5, 0.5])
    assert videomae_video_settings(tmp_path)["mean"] == [0.5] * 3
    (tmp_path / "video_processing.json").write_text(json.dumps({"mean": 0.2, "std": 0.3}))
    assert appearance_video_settings(tmp_path)["mean"] == 0.2  # the project's own file wins
    (tmp_path / "video_processing.json").unlink()
    processor_file.rename(tmp_path / "video_preprocessor_config.json")  # VideoMAEVideoProcessor's name
    assert videomae_video_settings(tmp_path)["mean"] == [0.5] * 3


@pytest.mark.parametrize(("changes", "message"), [
    ({"do_rescale": False}, r"preprocessor_config\.json: do_rescale is False"),
    ({"rescale_factor": 1 / 127.5}, r"preprocessor_config\.json: rescale_factor is 0\.0078"),
    ({"image_mean": [0.5, 0.5]}, r"preprocessor_config\.json: image_mean must be one number or three"),
    ({"image_std": [0.5, 0.0, 0.5]}, r"preprocessor_config\.json: image_std must be > 0"),
])
def test_a_processor_config_that_cannot_be_reproduced_is_one_clear_error(tmp_path: Path, changes: dict[str, object],
                                                                         message: str) -> None:
    save_hf(tmp_path)
    save_processor(tmp_path)
    edit_json(tmp_path / "preprocessor_config.json", **changes)
    with pytest.raises(ValueError, match=message) as info:
        appearance_video_settings(tmp_path)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(("changes", "message"), [
    ({"num_channels": 1}, r"config\.json: num_channels is 1; the tactile encoder takes RGB"),
    ({"hidden_act": "gelu_new"}, r"config\.json: hidden_act 'gelu_new' is not supported"),
    ({"num_frames": 5}, r"config\.json: encoder config: num_frames \(5\) must be a multiple of tubelet_size"),
    ({"image_size": 20}, r"config\.json: encoder config: image height 20 must be a multiple of patch_size 8"),
    ({"num_hidden_layers": 3}, r"lacks weights for blocks\.2\."),
])
def test_a_videomae_directory_with_a_wrong_config_is_one_clear_error(tmp_path: Path, changes: dict[str, object],
                                                                     message: str) -> None:
    save_hf(tmp_path)
    edit_json(tmp_path / "config.json", **changes)
    with pytest.raises(ValueError, match=message) as info:
        load_appearance(tmp_path)
    assert "\n" not in str(info.value) and str(tmp_path) in str(info.value)


def test_other_directories_are_refused_by_name(tmp_path: Path) -> None:
    save_hf(tmp_path)
    (tmp_path / "model.safetensors").unlink()
    (tmp_path / "pytorch_model.bin").write_bytes(b"\x80\x04 never unpickled")
    with pytest.raises(ValueError, match=r"only pickled weights \(pytorch_model\.bin\)"):
        load_appearance(tmp_path)
    edit_json(tmp_path / "config.json", model_type="timesformer")
    with pytest.raises(ValueError, match=r"config\.json: a Hugging Face 'timesformer' model"):
        load_appearance(tmp_path)


def test_the_memory_plan_reads_a_videomae_directory_shape(tmp_path: Path) -> None:
    """`tacreasoner plan` counts the ViT a VideoMAE directory makes, not its config.json as an encoder config."""
    from transformers import Qwen2Config

    from tacreasoner.model.appearance import read_appearance_config
    from tacreasoner.train.config import TrainConfig
    from tacreasoner.train.memory_plan import plan_for_config

    vmae = tmp_path / "videomae"
    save_hf(vmae)
    assert read_appearance_config(vmae) == load_appearance(vmae).config
    Qwen2Config(**TEXT_CONFIG).save_pretrained(tmp_path / "llm")
    config = TrainConfig.from_dict({"model": {"llm": str(tmp_path / "llm"), "appearance": str(vmae)}})
    (plan,) = plan_for_config(config, stage=2, world_sizes=[1])
    assert not any("not found" in note for note in plan.notes)
    shape = {"num_frames": 4, "image_size": [16, 16], "patch_size": 8, "hidden_size": 32, "num_layers": 2,
             "num_heads": 4, "mlp_ratio": 2.0, "layer_norm_eps": 1e-6}
    spelled_out = TrainConfig.from_dict({"model": {"llm": str(tmp_path / "llm"), "encoder": shape}})
    (same,) = plan_for_config(spelled_out, stage=2, world_sizes=[1])
    assert plan.shapes.frozen_bytes == same.shapes.frozen_bytes
    assert plan.shapes.trainable_parts == same.shapes.trainable_parts
