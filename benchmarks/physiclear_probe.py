"""Frozen-encoder linear probe on PhysiCLeAR: train objects → val objects, in Octopi's description columns.

The row "frozen-encoder linear probe" of the PhysiCLeAR table (issue 28): the appearance encoder's features of each
labelled clip (frozen, as Stages I and II use it), one multinomial logistic regression per property fitted on the
train objects' clips and scored on the val objects' clips (hardness, roughness, bumpiness; combined = all three
right for a clip). Which feature (CLS token, mean patch token, per-time-slice means) and which L2 strength are chosen
by object-level cross-validation on the **train** objects only; val is scored once with the chosen pair. Each val clip
is one item, as in the benchmark's TFA items (which ask each clip once), so the numbers sit beside the models'.

    python benchmarks/physiclear_probe.py --encoder runs/quickstart/encoder [--data ../shared/data/physiclear]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp
from encoder_pretrain import FEATURES, features

ATTRIBUTES = ("hardness", "roughness", "bumpiness")
L2_GRID = (1e-3, 1e-2, 1e-1, 1.0)


def choose_on_train(feats: dict[str, np.ndarray], y: dict[str, np.ndarray], groups: np.ndarray,
                    seed: int) -> tuple[str, float, dict[str, float]]:
    """(feature, l2) with the best mean object-level 5-fold CV accuracy over the three properties (train only)."""
    from tacreasoner.evaluate.probe import cross_validate_probe

    scores = {}
    for name, x in feats.items():
        for l2 in L2_GRID:
            scores[f"{name}@{l2:g}"] = float(np.mean([cross_validate_probe(x, y[a], groups, n_splits=5, seed=seed,
                                                                           l2=l2).accuracy for a in ATTRIBUTES]))
    best = max(scores, key=lambda k: (scores[k], -float(k.split("@")[1])))  # ties: the stronger penalty
    name, l2 = best.split("@")
    return name, float(l2), scores


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--encoder", type=Path, default=Path("runs/quickstart/encoder"))
    ap.add_argument("--data", type=Path, default=None, help="PhysiCLeAR folder (default: ../shared/data/physiclear)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the cross-validation folds")
    ap.add_argument("--name", default="physiclear_probe")
    args = ap.parse_args()

    import torch

    from tacreasoner.data.readers import read_physiclear
    from tacreasoner.evaluate.probe import LinearProbe
    from tacreasoner.intervals import wilson_interval
    from tacreasoner.model.appearance import AppearanceEncoder
    from tacreasoner.model.video_processing import VideoProcessingConfig, preprocess_video

    info = stamp()
    start = time.perf_counter()
    clips = [c for c in read_physiclear(args.data, on_error="raise") if c.labels.get("physiclear")]
    split = {name: [c for c in clips if c.split == name] for name in ("train", "val")}
    if not split["train"] or not split["val"]:
        raise SystemExit("the PhysiCLeAR folder needs labelled train and val objects")
    encoder = AppearanceEncoder.from_pretrained(args.encoder)
    video = VideoProcessingConfig(num_frames=encoder.config.num_frames, image_size=encoder.config.image_size)
    feats, labels = {}, {}
    for name, part in split.items():
        videos = torch.from_numpy(np.stack([preprocess_video(c, video) for c in part]))
        feats[name] = features(encoder, videos)
        labels[name] = {a: np.asarray([c.labels["physiclear"][a] for c in part]) for a in ATTRIBUTES}
    groups = np.asarray([c.object_id for c in split["train"]])
    feature, l2, cv = choose_on_train(feats["train"], labels["train"], groups, args.seed)
    right = {}
    for a in ATTRIBUTES:
        probe = LinearProbe(l2=l2).fit(feats["train"][feature], labels["train"][a])
        right[a] = probe.predict(feats["val"][feature]) == labels["val"][a]
    right["combined"] = np.all([right[a] for a in ATTRIBUTES], axis=0)
    n = len(split["val"])
    table = {}
    for column, hits in right.items():
        k = int(hits.sum())
        low, high = wilson_interval(k, n)
        table[column] = {"n": n, "accuracy": k / n, "ci_low": low, "ci_high": high,
                         "chance": 1 / 27 if column == "combined" else 1 / 3}
    seconds = time.perf_counter() - start

    md = header_md("PhysiCLeAR: frozen-encoder linear probe, train objects → val objects", info)
    md += (f"Encoder `{args.encoder}` (frozen; {encoder.config.num_frames} frames of {encoder.config.image_size}); "
           f"{len(split['train'])} train clips of {len({c.object_id for c in split['train']})} objects, "
           f"{n} val clips of {len({c.object_id for c in split['val']})} objects; {seconds:.0f} s. Feature and L2 "
           f"chosen by object-level 5-fold cross-validation on the train objects (mean accuracy over the three "
           f"properties): **{feature}** ({FEATURES[feature]}), L2 {l2:g}. Val scored once.\n\n")
    md += md_table(["property", "val accuracy %", "95% Wilson", "chance %"],
                   [[c, f"{100 * t['accuracy']:.1f}", f"{100 * t['ci_low']:.0f}–{100 * t['ci_high']:.0f}",
                     f"{100 * t['chance']:.1f}"] for c, t in table.items()])
    md += "\nCross-validated train accuracy per (feature, L2) candidate:\n\n"
    md += md_table(["candidate", "train CV accuracy %"], [[k, f"{100 * v:.1f}"] for k, v in cv.items()])
    publish(args.name, {**info, "encoder": str(args.encoder), "feature": feature, "l2": l2, "train_cv": cv,
                        "val": table, "seconds": round(seconds, 1)}, md)


if __name__ == "__main__":
    main()
