"""Encoder pre-training: outputs, falling loss, exact resume, refusals, and the CLI command."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch
from typer.testing import CliRunner

from tacreasoner.cli import app
from tacreasoner.data.clip import TactileClip
from tacreasoner.model.appearance import AppearanceEncoder
from tacreasoner.model.encoder_config import TactileEncoderConfig
from tacreasoner.model.masked_video import MaskedVideoConfig
from tacreasoner.model.video_processing import VideoProcessingConfig
from tacreasoner.train.pretrain_encoder import preprocess_clips, pretrain_encoder

CFG = TactileEncoderConfig(num_frames=4, image_size=(32, 32), patch_size=8, tubelet_size=2, hidden_size=32,
                           num_layers=2, num_heads=2, tokens_per_video=1, fusion_heads=2)
SMALL_DECODER = MaskedVideoConfig(decoder_hidden_size=32, decoder_layers=1, decoder_heads=2)


def blob_clip(i: int, n_frames: int = 12) -> TactileClip:
    """A grey gel, then a coloured imprint that grows and drifts: smooth, so masked parts are predictable."""
    rng = np.random.default_rng(i)
    yy, xx = np.mgrid[0:48, 0:48].astype(np.float32)
    cy, cx, colour = rng.uniform(12, 36), rng.uniform(12, 36), rng.uniform(-60, 60, size=3)
    frames = np.full((n_frames, 48, 48, 3), 128.0, np.float32)
    for t in range(1, n_frames):
        r = 4 + 10 * t / n_frames
        blob = np.exp(-((yy - cy - t) ** 2 + (xx - cx) ** 2) / (2 * r * r))
        frames[t] += blob[..., None] * colour
    return TactileClip(clip_id=f"blob_{i}", object_id=f"blob_{i % 5}", fps=25.0,
                       frames_in_memory=np.clip(frames, 0, 255).astype(np.uint8))


CLIPS = [blob_clip(i) for i in range(10)]


def run(out: Path, **kwargs: object) -> Path:
    settings = {"encoder_config": CFG, "steps": 6, "batch_size": 8, "lr": 2e-3, "mask_ratio": 0.5, "seed": 0,
                "progress": False, "masked_config": SMALL_DECODER, "samples_per_clip": 2, "workers": 1,
                "log_every": 1, "checkpoint_every": 3, **kwargs}
    return pretrain_encoder(CLIPS, out, **settings)


def log_of(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "pretrain_log.jsonl").read_text().splitlines()]


def test_outputs_and_falling_loss(tmp_path: Path) -> None:
    out = run(tmp_path / "run", steps=100, checkpoint_every=1000)
    for name in ("config.json", "model.safetensors", "video_processing.json", "pretrain_config.json"):
        assert (out / name).is_file(), name
    assert json.loads((out / "video_processing.json").read_text())["num_frames"] == 4
    assert [p.name for p in (out / "checkpoints").iterdir()] == ["step-00000100"]
    losses = [r["loss"] for r in log_of(out)]
    assert len(losses) == 100
    assert np.mean(losses[-20:]) < 0.8 * np.mean(losses[:20])  # measured 0.54–0.63 over seeds 0–3
    encoder = AppearanceEncoder.from_pretrained(out)
    assert encoder.config == CFG
    with torch.no_grad():
        assert encoder(torch.zeros(1, 4, 3, 32, 32)).shape == (1, 1 + 32, 32)


def test_resume_continues_exactly(tmp_path: Path) -> None:
    full = run(tmp_path / "full")
    assert sorted(p.name for p in (full / "checkpoints").iterdir()) == ["step-00000003", "step-00000006"]
    # A run killed after its step-3 checkpoint: resuming redoes steps 4–6 exactly as the uninterrupted run did.
    crashed = tmp_path / "crashed"
    run(crashed)
    import shutil

    shutil.rmtree(crashed / "checkpoints" / "step-00000006")
    (crashed / "model.safetensors").unlink()
    run(crashed, resume=True)
    assert [r["step"] for r in log_of(crashed)] == [1, 2, 3, 4, 5, 6]
    assert log_of(crashed) != [] and [r["loss"] for r in log_of(crashed)] == [r["loss"] for r in log_of(full)]
    a, b = AppearanceEncoder.from_pretrained(full), AppearanceEncoder.from_pretrained(crashed)
    for key, value in a.state_dict().items():
        torch.testing.assert_close(b.state_dict()[key], value, rtol=0, atol=0)
    # Resuming a finished run does nothing more; a longer run continues from the last step.
    run(crashed, resume=True)
    assert len(log_of(crashed)) == 6
    run(crashed, resume=True, steps=8)
    assert [r["step"] for r in log_of(crashed)][-2:] == [7, 8]


def test_refusals(tmp_path: Path) -> None:
    out = run(tmp_path / "run", steps=3)
    with pytest.raises(ValueError, match="already holds pre-training checkpoints"):
        run(out, steps=3)
    with pytest.raises(ValueError, match=r"different settings.*batch_size"):
        run(out, steps=4, batch_size=4, resume=True)
    with pytest.raises(ValueError, match="no clips"):
        pretrain_encoder([], tmp_path / "empty", encoder_config=CFG, progress=False)
    with pytest.raises(ValueError, match="encoder takes 4"):
        pretrain_encoder(CLIPS, tmp_path / "x", encoder_config=CFG, video_config=VideoProcessingConfig(),
                         progress=False)


def test_preprocessing_in_worker_processes_matches(tmp_path: Path) -> None:
    config = VideoProcessingConfig(num_frames=4, image_size=(32, 32))
    serial = preprocess_clips(CLIPS[:3], config, 2, seed=1, workers=1)
    parallel = preprocess_clips(CLIPS[:3], config, 2, seed=1, workers=2)
    assert serial.shape == (6, 4, 3, 32, 32) and serial.dtype == torch.float16
    assert torch.equal(serial, parallel)
    assert not torch.equal(serial[0], serial[1])  # two jittered samples of one clip differ


def test_cli(tmp_path: Path) -> None:
    from tacreasoner.video_io import write_video

    videos = tmp_path / "videos"
    videos.mkdir()
    for clip in CLIPS[:2]:
        write_video(videos / f"{clip.clip_id}.mp4", clip.frames, fps=25)
    out = tmp_path / "enc"
    runner = CliRunner()
    args = ["pretrain-encoder", "--data", str(videos), "--no-physiclear", "--out", str(out), "--steps", "2",
            "--batch-size", "2"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    assert "2 of 2 videos" in result.output and (out / "model.safetensors").is_file()
    again = runner.invoke(app, args)
    assert again.exit_code == 2 and "--resume" in again.stderr
    assert runner.invoke(app, [*args, "--resume"]).exit_code == 0
    missing = runner.invoke(app, ["pretrain-encoder", "--data", str(tmp_path / "nope"), "--no-physiclear",
                                  "--out", str(out)])
    assert missing.exit_code == 2 and "nope" in missing.stderr


def test_cli_defaults_are_the_library_defaults() -> None:
    import inspect

    from tacreasoner.cli.model import pretrain_encoder_cmd
    from tacreasoner.train.pretrain_encoder import DEFAULTS

    params = inspect.signature(pretrain_encoder_cmd).parameters
    assert (params["steps"].default, params["batch_size"].default, params["mask_ratio"].default) == \
        (DEFAULTS.steps, DEFAULTS.batch_size, DEFAULTS.mask_ratio)


# ------------------------------------------------------------------ which clips pre-training reads (issue 37)


def labelled_folder(root: Path) -> Path:
    """A PhysiCLeAR-shaped folder: one object per split (train, val, test, unlabelled), two clips each."""
    from tacreasoner.video_io import write_video

    (root / "videos").mkdir(parents=True)
    objects = {}
    for k, split in enumerate(("train", "val", "test", "unlabeled")):
        videos = []
        for j in range(2):
            rel = f"videos/{split}obj_{j}.mp4"
            write_video(root / rel, blob_clip(2 * k + j).frames, fps=25)
            videos.append(rel)
        entry = {"split": split, "videos": videos}
        if split != "unlabeled":
            entry.update(name=f"a {split} object", hardness=k % 3, roughness=1, bumpiness=0)
        objects[f"{split}obj"] = entry
    (root / "labels.json").write_text(json.dumps({"objects": objects}))
    return root


def test_pretraining_reads_only_train_and_unlabelled_clips_by_default(tmp_path: Path) -> None:
    from tacreasoner.train.pretrain_encoder import gather_pretraining_clips

    folder = labelled_folder(tmp_path / "clips")
    gathered = gather_pretraining_clips([folder], physiclear=False, min_frames=4)
    assert gathered.splits == {"train": 2, "unlabelled": 2}
    assert {c.object_id for c in gathered.clips} == {"trainobj", "unlabeledobj"}
    asked = gather_pretraining_clips([folder], physiclear=False, min_frames=4, splits=["train", "val"])
    assert asked.splits == {"train": 2, "val": 2}
    # a folder of videos inside a labelled folder would bring val and test in unnoticed: refused
    with pytest.raises(ValueError, match="inside the labelled folder"):
        gather_pretraining_clips([folder / "videos"], physiclear=False)


def test_the_run_records_the_splits_it_read(tmp_path: Path) -> None:
    from tacreasoner.train.pretrain_encoder import gather_pretraining_clips, splits_seen

    folder = labelled_folder(tmp_path / "clips")
    honest = gather_pretraining_clips([folder], physiclear=False, min_frames=4)
    out = pretrain_encoder(honest.clips, tmp_path / "honest", encoder_config=CFG, steps=2, batch_size=2,
                           progress=False, masked_config=SMALL_DECODER, samples_per_clip=1, workers=1)
    run_config = json.loads((out / "pretrain_config.json").read_text())
    assert run_config["splits_seen"] == {"train": 2, "unlabelled": 2} and run_config["evaluation_clips_seen"] == []
    asked = gather_pretraining_clips([folder], physiclear=False, min_frames=4, splits=["train", "val", "test"])
    out = pretrain_encoder(asked.clips, tmp_path / "asked", encoder_config=CFG, steps=2, batch_size=2,
                           progress=False, masked_config=SMALL_DECODER, samples_per_clip=1, workers=1)
    assert splits_seen(out) == {"test": 2, "train": 2, "val": 2}
    assert json.loads((out / "pretrain_config.json").read_text())["evaluation_clips_seen"] == ["test", "val"]


def test_simulated_clips_take_their_split_from_the_benchmark(small_sim_dataset: Path, tmp_path: Path) -> None:
    from tacreasoner.tasks.bench import build_bench
    from tacreasoner.train.pretrain_encoder import gather_pretraining_clips

    with pytest.raises(ValueError, match="carry no split; pass --bench"):
        gather_pretraining_clips([small_sim_dataset], physiclear=False)
    bench = tmp_path / "bench"
    build_bench("sim", small_sim_dataset, bench, seed=0)
    split_of = json.loads((bench / "bench.json").read_text())["splits"]
    gathered = gather_pretraining_clips([small_sim_dataset], physiclear=False, bench=bench)
    assert gathered.clips and set(gathered.splits) == {"train"}
    assert {split_of[c.object_id] for c in gathered.clips} == {"train"}
    # every train object's clips, of every sensor style (the held-out style belongs to test objects only)
    assert {c.object_id for c in gathered.clips} == {o for o, s in split_of.items() if s == "train"}
    everything = gather_pretraining_clips([small_sim_dataset], physiclear=False,
                                          splits=["train", "val", "test", "unlabelled"])
    assert everything.splits == {"every split": len(everything.clips)} and len(everything.clips) > len(gathered.clips)


def test_cli_pretrains_on_train_objects_and_says_what_it_read(tmp_path: Path) -> None:
    folder = labelled_folder(tmp_path / "clips")
    out = tmp_path / "enc"
    result = CliRunner().invoke(app, ["pretrain-encoder", "--data", str(folder), "--no-physiclear", "--out", str(out),
                                      "--steps", "2", "--batch-size", "2"])
    assert result.exit_code == 0, result.output
    assert "4 of 8 clips (train 2, unlabelled 2)" in " ".join(result.output.split())
    assert json.loads((out / "pretrain_config.json").read_text())["evaluation_clips_seen"] == []
    asked = CliRunner().invoke(app, ["pretrain-encoder", "--data", str(folder), "--no-physiclear", "--out",
                                     str(tmp_path / "enc2"), "--steps", "2", "--batch-size", "2",
                                     "--splits", "train,val"])
    assert asked.exit_code == 0, asked.output
    assert "reads val clips" in asked.output
