"""How strong is an imprint in each sensor style, as the trained parts see it? (train objects only)

    python experiments/2026-12-01_imprint_strength/diag.py [--objects 70]

The imprint recipe trains on Mini frames whose change from rest is colour-mapped (``gel_swap`` whole) and answers a
DIGIT clip with its change unmapped (``gel_swap: imprint``). For the same train objects seen in both styles (the
two-style corpus `runs/sens` simulates every object in both; the benchmark asks only val and test objects in DIGIT),
this prints per channel the mean absolute change from rest over the 8 sampled frames, as each preparation gives it,
and the DIGIT/Mini ratio per object. No val or test clip is read.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from tacreasoner.model.video_processing import VideoProcessingConfig, _gel_image, preprocess_video


def change(path: Path, config: VideoProcessingConfig) -> np.ndarray:
    """Per channel, the mean absolute change from the gel at rest in the prepared frames (unit scale)."""
    out = preprocess_video(str(path), config)  # T×3×H×W, normalised
    unit = out * np.asarray(config.std, np.float32)[:, None, None] + np.asarray(config.mean, np.float32)[:, None, None]
    gel = _gel_image(config).transpose(2, 0, 1)
    return np.abs(unit - gel[None]).mean(axis=(0, 2, 3))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--objects", type=int, default=70)
    args = ap.parse_args()
    video = json.loads(Path("runs/swt/encoder/video_processing.json").read_text())
    whole = VideoProcessingConfig.from_dict(video)
    imprint = VideoProcessingConfig.from_dict({**video, "gel_swap": "imprint"})
    splits = json.loads(Path("runs/sens/bench/bench.json").read_text())["splits"]
    train = sorted(o for o, s in splits.items() if s == "train")[: args.objects]
    rows = {"Mini, whole (trained)": [], "DIGIT, whole": [], "DIGIT, imprint (answered)": [], "Mini, imprint": []}
    for obj in train:
        mini, digit = (Path(f"runs/sens/sim/clips/{s}/{obj}_0.mp4") for s in ("mini", "digit"))
        rows["Mini, whole (trained)"].append(change(mini, whole))
        rows["Mini, imprint"].append(change(mini, imprint))
        rows["DIGIT, whole"].append(change(digit, whole))
        rows["DIGIT, imprint (answered)"].append(change(digit, imprint))
    base = np.stack(rows["Mini, whole (trained)"])
    print(f"{len(train)} train objects, repeat 0 of each, both styles\n")
    print("| preparation | mean |change| R, G, B (×100) | ratio to Mini trained, median over objects (R, G, B) |")
    print("|---|---|---|")
    for name, values in rows.items():
        v = np.stack(values)
        ratio = np.median(v / np.maximum(base, 1e-6), axis=0)
        print(f"| {name} | {', '.join(f'{100 * x:.2f}' for x in v.mean(0))} | "
              f"{', '.join(f'{x:.2f}' for x in ratio)} |")


if __name__ == "__main__":
    main()
