"""Train the quickstart recipe on swapped frames: each clip's colours mapped to the train clips' gel at rest, then its
gel at rest replaced by their average one (criteria.md). 3 seeds, Mini clips, without scoring its own test split.

    PYTHONPATH=src python experiments/2026-12-01_sensor_swap_train/run.py --out runs/swt

The reference and the image are measured on the run's own train-split clips (no val, test or held-out-style clip)
and written into the appearance encoder's ``video_processing.json`` before Stage I, so training reads, and the
trained models record and answer with, the swapped frames. ``runs/swt/gel_image.json`` keeps the image for
``benchmarks/sensor_transfer.py --gel-image``; ``runs/swt/gel_reference.json`` the reference.
"""

from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path

from tacreasoner.recipes.quickstart import QuickstartRun, QuickstartSettings, Stage, quickstart_stages, run_stages
from tacreasoner.recipes.quickstart_parts import GEL_REFERENCE_CLIPS, QuickstartPaths, _train_clips, train_gel_reference


def swap_in_training(paths: QuickstartPaths) -> list[str]:
    """Write the colour reference and the average gel at rest into the encoder's frame preparation (once)."""
    from tacreasoner.model.video_processing import VideoProcessingConfig, measure_gel_image

    file = paths.encoder / "video_processing.json"
    video = json.loads(file.read_text(encoding="utf-8"))
    if "gel_image" in video:
        return [f"already swapped: {file}"]
    reference, line = train_gel_reference(paths)
    config = VideoProcessingConfig.from_dict({**video, "gel_reference": reference})
    clips = _train_clips(paths)[:GEL_REFERENCE_CLIPS]
    image = measure_gel_image(clips, config)
    (paths.root / "gel_image.json").write_text(json.dumps(
        {"image": image, "split": "train", "clips": [c.clip_id for c in clips], "video": config.to_dict()}) + "\n")
    swapped = VideoProcessingConfig.from_dict({**config.to_dict(), "gel_image": image})
    file.write_text(json.dumps(swapped.to_dict(), indent=2) + "\n", encoding="utf-8")
    return [line, f"average gel at rest of {len(clips)} train clips swapped into every frame → {file}"]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--sensors", default="mini", help="the training corpus's simulated sensor")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    settings = replace(QuickstartSettings.load(), sensors=[args.sensors])
    stages = {s.name: s for s in quickstart_stages(QuickstartRun(out=args.out, seeds=3), settings)}
    paths = QuickstartPaths(args.out)
    run_stages([*(stages[n] for n in ("simulate", "benchmark", "llm", "encoder")),
                Stage("swap", "colour map + average gel at rest into the frame preparation",
                      lambda: swap_in_training(paths)),
                stages["train"]])


if __name__ == "__main__":  # worker processes import this file
    main()
