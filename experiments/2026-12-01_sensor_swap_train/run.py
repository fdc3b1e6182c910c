"""Train the quickstart recipe on swapped frames: each clip's colours mapped to the train clips' gel at rest, then its
gel at rest replaced by their average one (criteria.md). 3 seeds, Mini clips, without scoring its own test split.

    PYTHONPATH=src python experiments/2026-12-01_sensor_swap_train/run.py --out runs/swt

The reference and the image are measured on the run's own train-split clips (no val, test or held-out-style clip)
and written into the appearance encoder's ``video_processing.json`` before Stage I, so training reads, and the
trained models record and answer with, the swapped frames. ``runs/swt/gel_image.json`` keeps the image for
``benchmarks/sensor_transfer.py --gel-image``; ``runs/swt/gel_reference.json`` the reference. The swap is the
quickstart's own ``swap`` stage since its adoption (``quickstart_parts.swap_in_training``, written here first).
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

from tacreasoner.recipes.quickstart import QuickstartRun, QuickstartSettings, Stage, quickstart_stages, run_stages
from tacreasoner.recipes.quickstart_parts import QuickstartPaths, swap_in_training


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
