"""Pre-train the appearance branch by masked video reconstruction on any tactile video (no labels needed).

Read top to bottom: gather clips (train and unlabelled objects only, unless asked otherwise) → preprocess each
clip once into a few jittered samples held in memory (decoding is the slow part on CPU, so it is never repeated per
step) → train
:class:`~tacreasoner.model.masked_video.MaskedVideoModel` with AdamW and a warmup + cosine schedule,
checkpointing atomically → save the encoder with ``save_pretrained``.

Every step's batch, flips and mask are drawn from a generator seeded by (seed, step), so a resumed
run draws exactly what the uninterrupted run would have drawn.

Output directory::

    config.json, model.safetensors   the AppearanceEncoder (AppearanceEncoder.from_pretrained)
    video_processing.json            the VideoProcessingConfig its inputs were prepared with
    pretrain_config.json             settings of the run (encoder, decoder, optimisation, data counts, and the
                                     clips per split it read: ``splits_seen``, ``evaluation_clips_seen``)
    pretrain_log.jsonl               {"step", "loss", "lr", "elapsed_s"} every log_every steps
    checkpoints/step-<n>/            resumable training state (encoder + decoder + optimizer)
"""

from __future__ import annotations

import json
import os
import time
from collections import Counter
from collections.abc import Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch

from tacreasoner.data.clip import TactileClip
from tacreasoner.data.readers import UNLABELLED
from tacreasoner.data.readers import VIDEO_SUFFIXES as READER_VIDEO_SUFFIXES
from tacreasoner.model.appearance import AppearanceEncoder
from tacreasoner.model.encoder_config import TactileEncoderConfig
from tacreasoner.model.masked_video import MaskedVideoConfig, MaskedVideoModel, tube_mask
from tacreasoner.model.video_processing import VideoProcessingConfig, preprocess_video
from tacreasoner.progress import ProgressBar
from tacreasoner.train.loop import StepLoop, StepStats
from tacreasoner.train.state import (
    cosine_with_warmup,
    latest_checkpoint,
    load_checkpoint,
    save_checkpoint,
)
from tacreasoner.train.threads import free_threads

__all__ = ["DEFAULTS", "DEFAULT_SPLITS", "UNSPLIT", "PretrainDefaults", "PretrainingClips",
           "gather_pretraining_clips", "preprocess_clips", "pretrain_encoder", "splits_seen", "video_config_for"]

CHECKPOINTS = "checkpoints"
LOG_NAME = "pretrain_log.jsonl"
VIDEO_CONFIG_NAME = "video_processing.json"
RUN_CONFIG_NAME = "pretrain_config.json"
# The data layer's video files, plus containers PyAV also reads that only appear as loose unlabelled video.
VIDEO_SUFFIXES = (*READER_VIDEO_SUFFIXES, ".mkv", ".webm")


@dataclass(frozen=True)
class PretrainDefaults:
    """Chosen so the default run takes ~3 minutes on 2 CPU cores (see docs/encoder-pretraining.md)."""

    steps: int = 1000
    batch_size: int = 32
    lr: float = 1e-3
    mask_ratio: float = 0.9
    samples_per_clip: int = 4
    weight_decay: float = 0.05
    warmup_ratio: float = 0.05


DEFAULTS = PretrainDefaults()


# ---------------------------------------------------------------------------------------------- data


DEFAULT_SPLITS = ("train", UNLABELLED)
UNSPLIT = "every split"
"""The split recorded for simulated clips read without a benchmark (asked for with every split)."""
"""What encoder pre-training reads by default: the training objects and objects without labels, never val or test."""


@dataclass
class PretrainingClips:
    """The clips pre-training will read, one line per source saying what was taken, and how many clips of each
    split (clips of loose video folders count as unlabelled)."""

    clips: list[TactileClip]
    notes: list[str]

    @property
    def splits(self) -> dict[str, int]:
        return dict(sorted(Counter(c.split or UNLABELLED for c in self.clips).items()))


def gather_pretraining_clips(paths: Iterable[str | os.PathLike[str]] = (), *, physiclear: bool = True,
                             min_frames: int = 8, splits: Iterable[str] = DEFAULT_SPLITS,
                             bench: str | os.PathLike[str] | None = None) -> PretrainingClips:
    """Clips of the chosen ``splits`` (default: train and unlabelled objects only) from simulator datasets (a
    directory with ``manifest.jsonl``), labelled folders in PhysiCLeAR's layout (``labels.json``), loose video files
    and folders (no split known: unlabelled), plus PhysiCLeAR's when ``physiclear`` and it is present.

    A simulator dataset's clips carry no split of their own: ``bench`` (a ``build-bench`` directory built from
    it) names each object's split. Without it a simulator dataset is refused unless every split is asked for, so
    an encoder never silently pre-trains on the clips it is later scored on."""
    from tacreasoner.data.readers import default_physiclear_dir, load_clips, read_physiclear, read_sim_dataset

    wanted = _check_splits(splits)
    clips: list[TactileClip] = []
    notes: list[str] = []
    for raw in paths:
        path = Path(raw)
        if path.is_dir() and (path / "manifest.jsonl").is_file():
            found = list(read_sim_dataset(path, min_frames=min_frames))
            kept = _keep(_with_bench_splits(found, path, bench, wanted), wanted)
            notes.append(f"{path}: {len(kept)} of {len(found)} simulated clips ({_split_text(kept)})")
        elif path.is_dir() and (path / "labels.json").is_file():
            found = list(read_physiclear(path, min_frames=min_frames))
            kept = _keep(found, wanted)
            notes.append(f"{path}: {len(kept)} of {len(found)} clips ({_split_text(kept)})")
        elif path.is_dir():
            _refuse_inside_labelled_folder(path)
            videos = sorted(p for p in path.rglob("*") if p.is_file() and p.suffix.lower() in VIDEO_SUFFIXES)
            if not videos:
                raise ValueError(f"{path}: no simulator manifest.jsonl, no labels.json and no video files "
                                 f"({', '.join(VIDEO_SUFFIXES)}) inside")
            report = load_clips(videos, min_frames=min_frames)
            kept = _loose(list(report.clips), path, wanted)
            notes.append(f"{path}: {len(kept)} of {len(videos)} videos, no split known: unlabelled" +
                         (f" ({len(report.skipped)} skipped)" if report.skipped else ""))
        elif path.is_file():
            _refuse_inside_labelled_folder(path.parent)
            kept = _loose(list(load_clips([path], on_error="raise", min_frames=min_frames).clips), path, wanted)
            notes.append(f"{path}: 1 video, no split known: unlabelled")
        else:
            raise FileNotFoundError(f"{path}: no such file or directory")
        clips += kept
    if physiclear:
        root = default_physiclear_dir()
        if root is None:
            notes.append("PhysiCLeAR: not found (set TACREASONER_PHYSICLEAR); skipped")
        else:
            found = list(read_physiclear(root, min_frames=min_frames))
            kept = _keep(found, wanted)
            clips += kept
            notes.append(f"PhysiCLeAR {root}: {len(kept)} of {len(found)} real clips ({_split_text(kept)}; "
                         "labels unused)")
    return PretrainingClips(clips, notes)


def _check_splits(splits: Iterable[str]) -> frozenset[str]:
    wanted = frozenset("unlabelled" if s.strip().lower() in ("unlabeled", "unlabelled") else s.strip().lower()
                       for s in splits if s.strip())
    if not wanted:
        raise ValueError("encoder pre-training: no split chosen (the default is train and unlabelled)")
    return wanted


def _keep(clips: list[TactileClip], wanted: frozenset[str]) -> list[TactileClip]:
    return [c for c in clips if c.split == UNSPLIT or (c.split or UNLABELLED) in wanted]


def _loose(clips: list[TactileClip], path: Path, wanted: frozenset[str]) -> list[TactileClip]:
    if UNLABELLED not in wanted:
        raise ValueError(f"{path}: loose videos have no split and count as unlabelled, which --splits leaves out")
    for clip in clips:
        clip.split = UNLABELLED
    return clips


def _split_text(clips: list[TactileClip]) -> str:
    counts = Counter(c.split or UNLABELLED for c in clips)
    return ", ".join(f"{split} {n}" for split, n in sorted(counts.items())) or "none"


def _refuse_inside_labelled_folder(path: Path) -> None:
    """A folder of videos inside a labelled folder would bring its val and test clips in unnoticed."""
    for parent in (path, *path.resolve().parents):
        if (parent / "labels.json").is_file():
            raise ValueError(f"{path}: inside the labelled folder {parent} (labels.json): pass --data {parent} so "
                             "that only the chosen splits' objects (train and unlabelled by default) are read")


def _with_bench_splits(clips: list[TactileClip], data: Path, bench: str | os.PathLike[str] | None,
                       wanted: frozenset[str]) -> list[TactileClip]:
    """Each simulated clip's split from ``bench``'s object → split map (held-out-sensor clips are test objects')."""
    if bench is None:
        if {"train", "val", "test", UNLABELLED} <= wanted:
            for clip in clips:
                clip.split = UNSPLIT
            return clips
        raise ValueError(f"{data}: simulated clips carry no split; pass --bench <a build-bench directory made from "
                         f"it> so that only its train objects are read, or ask for every split "
                         f"(--splits train,val,test,unlabelled: recorded in pretrain_config.json)")
    info_path = Path(bench) / "bench.json"
    if not info_path.is_file():
        raise FileNotFoundError(f"{info_path}: no such file (--bench must be a `tacreasoner build-bench` directory)")
    info = json.loads(info_path.read_text(encoding="utf-8"))
    split_of = info.get("splits")
    if not isinstance(split_of, dict) or not split_of:
        raise ValueError(f"{info_path}: field 'splits' (object → split) is missing or empty")
    built_from = info.get("data")
    if built_from and Path(built_from).resolve() != data.resolve():
        raise ValueError(f"{info_path}: was built from {built_from}, not from {data.resolve()}")
    unknown = sorted({c.object_id for c in clips} - set(split_of))
    if unknown:
        raise ValueError(f"{info_path}: field 'splits' has no split for {len(unknown)} object(s) of {data} "
                         f"(e.g. {unknown[0]!r}); rebuild the benchmark from this dataset")
    for clip in clips:
        clip.split = str(split_of[clip.object_id])
    return clips


def splits_seen(encoder_dir: str | os.PathLike[str]) -> dict[str, int] | None:
    """Clips per split an encoder was pre-trained on (``pretrain_config.json``); None when it does not say (an
    encoder from before the split was recorded, or not pre-trained here)."""
    path = Path(encoder_dir) / RUN_CONFIG_NAME
    if not path.is_file():
        return None
    seen = json.loads(path.read_text(encoding="utf-8")).get("splits_seen")
    return dict(seen) if isinstance(seen, dict) else None


def video_config_for(encoder_config: TactileEncoderConfig,
                     video_config: VideoProcessingConfig | None = None) -> VideoProcessingConfig:
    """The processing config for this encoder; a given one must produce its input shape."""
    if video_config is None:
        return VideoProcessingConfig(num_frames=encoder_config.num_frames, image_size=encoder_config.image_size)
    if (video_config.num_frames, tuple(video_config.image_size)) != (encoder_config.num_frames,
                                                                     tuple(encoder_config.image_size)):
        raise ValueError(f"video processing makes {video_config.num_frames} frames of {tuple(video_config.image_size)} "
                         f"but the encoder takes {encoder_config.num_frames} of {tuple(encoder_config.image_size)}")
    return video_config


def _preprocess_one(job: tuple[TactileClip, VideoProcessingConfig, list[int], bool]) -> np.ndarray:
    clip, config, seeds, drop_cache = job
    try:
        out = np.stack([preprocess_video(clip, config, seed=s) for s in seeds]).astype(np.float16)
    except ValueError as exc:
        raise ValueError(f"clip {clip.clip_id!r}: {exc}") from None
    if drop_cache:  # worker process: each clip is decoded once, keeping it would only hold memory
        from tacreasoner.data.cache import clear_cache

        clear_cache()
    return out


def preprocess_clips(clips: Sequence[TactileClip], config: VideoProcessingConfig, samples_per_clip: int,
                     seed: int, *, workers: int = 1, progress: Any = None) -> torch.Tensor:
    """(len(clips)·samples_per_clip)×T×3×H×W float16: every clip decoded once, sampled with different frame jitter.

    float16 halves the memory (1000 clips × 4 samples at 8×64×64 ≈ 0.8 GB); the values are normalised
    pixels, well inside its range and precision.
    """
    jobs = [(clip, config, [seed * 1_000_003 + i * samples_per_clip + k for k in range(samples_per_clip)],
             workers > 1) for i, clip in enumerate(clips)]
    out = np.empty((len(clips) * samples_per_clip, config.num_frames, 3, *config.image_size), np.float16)

    def place(i: int, arr: np.ndarray) -> None:
        out[i * samples_per_clip:(i + 1) * samples_per_clip] = arr
        if progress is not None:
            progress(i + 1)

    if workers > 1 and len(clips) > 1:
        import multiprocessing

        with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
            for i, arr in enumerate(pool.map(_preprocess_one, jobs, chunksize=4)):
                place(i, arr)
    else:
        for i, job in enumerate(jobs):
            place(i, _preprocess_one(job))
    return torch.from_numpy(out)


# ---------------------------------------------------------------------------------------------- training


def _batch(data: torch.Tensor, seed: int, step: int, batch_size: int, grid: tuple[int, int, int],
           mask_ratio: float) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """The step's samples (randomly flipped), keep and mask indices: a pure function of (seed, step)."""
    rng = np.random.default_rng([seed, step])
    idx = rng.choice(len(data), size=batch_size, replace=len(data) < batch_size)
    x = data[torch.from_numpy(idx)].float()
    flips = rng.random((batch_size, 2)) < 0.5
    for dim, column in ((-1, 0), (-2, 1)):
        chosen = torch.from_numpy(np.flatnonzero(flips[:, column]))
        if len(chosen):
            x[chosen] = x[chosen].flip(dim)
    generator = torch.Generator().manual_seed(int(rng.integers(2**62)))
    keep, mask = tube_mask(batch_size, grid, mask_ratio, generator=generator)
    return x, keep, mask


def _optimizer(model: torch.nn.Module, lr: float, weight_decay: float) -> torch.optim.AdamW:
    """AdamW (MAE's betas); no decay on biases, norms, CLS and mask tokens."""
    decay, no_decay = [], []
    for name, param in model.named_parameters():
        (no_decay if param.ndim < 2 or name.endswith(("cls_token", "mask_token")) else decay).append(param)
    return torch.optim.AdamW([{"params": decay, "weight_decay": weight_decay},
                              {"params": no_decay, "weight_decay": 0.0}], lr=lr, betas=(0.9, 0.95))


def pretrain_encoder(
    clips: Sequence[TactileClip],
    out_dir: str | os.PathLike[str],
    *,
    encoder_config: TactileEncoderConfig | None = None,
    video_config: VideoProcessingConfig | None = None,
    steps: int = DEFAULTS.steps,
    batch_size: int = DEFAULTS.batch_size,
    lr: float = DEFAULTS.lr,
    mask_ratio: float = DEFAULTS.mask_ratio,
    seed: int = 0,
    resume: bool = False,
    progress: bool = True,
    masked_config: MaskedVideoConfig | None = None,
    samples_per_clip: int = DEFAULTS.samples_per_clip,
    weight_decay: float = DEFAULTS.weight_decay,
    warmup_ratio: float = DEFAULTS.warmup_ratio,
    workers: int | None = None,
    threads: int | None = None,
    log_every: int = 10,
    checkpoint_every: int | None = None,
) -> Path:
    """Masked-video pre-training of an AppearanceEncoder on ``clips``; returns ``out_dir`` (see the module doc).

    ``resume``: continue from the newest checkpoint in ``out_dir/checkpoints`` (a fresh start when
    there is none; nothing to do when it already reached ``steps``). Without it, a directory holding
    checkpoints is refused rather than overwritten. ``mask_ratio`` overrides ``masked_config``'s.
    ``threads=None`` leaves out cores that other processes keep busy (the torch setting is restored after).
    """
    out = Path(out_dir)
    encoder_config = encoder_config or TactileEncoderConfig()
    video_config = video_config_for(encoder_config, video_config)
    masked_config = MaskedVideoConfig.from_dict({**(masked_config or MaskedVideoConfig()).to_dict(),
                                                 "mask_ratio": mask_ratio})
    for name, value in (("steps", steps), ("batch_size", batch_size), ("samples_per_clip", samples_per_clip),
                        ("log_every", log_every)):
        if int(value) < 1:
            raise ValueError(f"pretrain_encoder: {name} must be ≥ 1, got {value}")
    if lr <= 0:
        raise ValueError(f"pretrain_encoder: lr must be > 0, got {lr}")
    if not clips:
        raise ValueError("pretrain_encoder: no clips to pre-train on")
    checkpoint_every = checkpoint_every or max(50, steps // 4)
    workers = min(2, os.cpu_count() or 1) if workers is None else max(1, int(workers))
    seen = dict(sorted(Counter(c.split or UNLABELLED for c in clips).items()))
    run = {"splits_seen": seen, "evaluation_clips_seen": sorted(set(seen) - set(DEFAULT_SPLITS)),
           "encoder": encoder_config.to_dict(), "masked_video": masked_config.to_dict(),
           "video_processing": video_config.to_dict(), "batch_size": batch_size, "lr": lr, "seed": seed,
           "samples_per_clip": samples_per_clip, "weight_decay": weight_decay, "warmup_ratio": warmup_ratio}

    ckpt_dir = out / CHECKPOINTS
    latest = latest_checkpoint(ckpt_dir) if ckpt_dir.is_dir() else None
    if latest is not None and not resume:
        raise ValueError(f"{out} already holds pre-training checkpoints ({latest.name}): resume them "
                         "(--resume / resume=True) or choose another output directory")

    torch.manual_seed(seed)
    model = MaskedVideoModel(AppearanceEncoder(encoder_config), masked_config)
    optimizer = _optimizer(model, lr, weight_decay)
    scheduler = cosine_with_warmup(optimizer, max(1, round(warmup_ratio * steps)), steps)
    start = 0
    if latest is not None:
        weights, state = load_checkpoint(latest, optimizer, scheduler)
        saved = state.extra.get("run", {})
        changed = sorted(k for k in run if saved.get(k) != run[k])
        if changed:
            raise ValueError(f"{latest}: was made with different settings ({', '.join(changed)}): resume with the "
                             f"settings in {out / RUN_CONFIG_NAME} or choose another output directory")
        model.load_state_dict(weights)
        start = state.step

    out.mkdir(parents=True, exist_ok=True)
    bar = ProgressBar(progress)
    t0 = time.perf_counter()
    threads_before = torch.get_num_threads()
    torch.set_num_threads(free_threads() if threads is None else max(1, int(threads)))
    try:
        data = None
        if start < steps:
            bar.stage("preprocessing clips", len(clips), unit="clips")
            data = preprocess_clips(clips, video_config, samples_per_clip, seed, workers=workers,
                                    progress=bar.update)
        t_pre = time.perf_counter() - t0
        (out / RUN_CONFIG_NAME).write_text(json.dumps({**run, "steps": steps, "n_clips": len(clips),
                                                       "n_samples": len(clips) * samples_per_clip},
                                                      indent=2) + "\n", encoding="utf-8")
        if data is not None:
            _train(model, optimizer, scheduler, data, out, run, start, steps, batch_size, seed, log_every,
                   checkpoint_every, bar, t_pre)
    finally:
        bar.close()
        torch.set_num_threads(threads_before)
    model.encoder.save_pretrained(out)
    (out / VIDEO_CONFIG_NAME).write_text(json.dumps(video_config.to_dict(), indent=2) + "\n", encoding="utf-8")
    return out


def _train(model: MaskedVideoModel, optimizer: torch.optim.Optimizer, scheduler: Any, data: torch.Tensor, out: Path,
           run: dict, start: int, steps: int, batch_size: int, seed: int, log_every: int, checkpoint_every: int,
           bar: ProgressBar, t_pre: float) -> None:
    grid, ratio = model.encoder.config.grid, model.config.mask_ratio
    bar.stage("pre-training encoder", steps, start, unit="steps")
    model.train()

    def step(index: int) -> StepStats:
        x, keep, mask = _batch(data, seed, index, batch_size, grid, ratio)
        loss = model(x, keep, mask).loss
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
        optimizer.step()
        scheduler.step()
        return StepStats(loss.item())

    loop = StepLoop(steps, start, log_every, checkpoint_every, log=out / LOG_NAME, bar=bar,
                    describe=lambda: {"lr": float(optimizer.param_groups[0]["lr"])},
                    extra={"preprocess_s": round(t_pre, 2)})
    loop.run(step, checkpoint=lambda done, _loss, _elapsed: save_checkpoint(
        out / CHECKPOINTS, done, model.state_dict(), optimizer, scheduler, extra={"run": run}))
    model.eval()
