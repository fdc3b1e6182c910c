"""Diagnosis (no choice rests on it): does contact state (OCSE) follow the imprint's strength?

    TACREASONER_VIDEO_WORKERS=1 PYTHONPATH=src python experiments/2026-12-01_sensor_swap_train/imprint_diag.py \
        --bench runs/sens/bench --models runs/swt/train/seed{0,1,2}/stage2/model --out runs/swt/imprint_diag

For the swap-trained models every prepared frame is R + (the clip's change from its own rest), R the Mini average gel
at rest. This scales that change by a gain g at answering (frame → R + g·(frame − R), exact through the per-channel
normalisation) and answers the val OCSE items of both styles at several gains, and reports how strong the change is
in each style (the mean over a clip's prepared frames of |frame − R|, over val clips). Reads val inputs only to
describe them; nothing is fitted. Writes ``diag.json`` in ``--out``.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
from pathlib import Path

import numpy as np


def ocse_bench(bench: Path, out: Path) -> Path:
    """A copy of ``bench`` holding only the OCSE items of val and val_heldout_sensor."""
    out.mkdir(parents=True, exist_ok=True)
    info = json.loads((bench / "bench.json").read_text())
    (out / "bench.json").write_text(json.dumps(info))
    for split in ("val", "val_heldout_sensor"):
        lines = [line for line in (bench / f"{split}.jsonl").read_text().splitlines() if '"task": "OCSE"' in line]
        (out / f"{split}.jsonl").write_text("\n".join(lines) + "\n")
    for split in ("train", "test", "test_heldout_sensor"):
        (out / f"{split}.jsonl").write_text("")
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--bench", type=Path, required=True)
    ap.add_argument("--models", type=Path, nargs="+", required=True)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--gains", type=float, nargs="+", default=[0.5, 0.75, 1.0, 1.5, 2.0])
    args = ap.parse_args()
    from tacreasoner.cli import app as cli
    from tacreasoner.model import processing, video_processing
    from tacreasoner.model.video_processing import VideoProcessingConfig

    original = video_processing.preprocess_video
    gain = {"g": 1.0}

    def scaled(video, config=None, **kw):  # the wrapped function's own signature
        out = original(video, config, **kw)
        if gain["g"] == 1.0:
            return out
        mean = np.asarray(config.mean, np.float32).reshape(1, 3, 1, 1)
        std = np.asarray(config.std, np.float32).reshape(1, 3, 1, 1)
        rest = ((video_processing._gel_image(config) - mean[0, :, 0, 0]) / std[0, :, 0, 0]).transpose(2, 0, 1)[None]
        return np.ascontiguousarray(rest + gain["g"] * (out - rest), dtype=np.float32)

    if os.environ.get("TACREASONER_VIDEO_WORKERS") != "1":
        raise SystemExit("run with TACREASONER_VIDEO_WORKERS=1: clips prepared in worker processes miss the gain")
    video_processing.preprocess_video = scaled
    processing.preprocess_video = scaled
    small = ocse_bench(args.bench, args.out / "bench")
    results: dict[str, dict] = {}
    for seed, model in enumerate(args.models):
        for split in ("val", "val_heldout_sensor"):
            for g in args.gains:
                gain["g"] = g
                folder = args.out / f"seed{seed}" / f"{split}_g{g}"
                if not (folder / "report.json").is_file():
                    shutil.rmtree(folder, ignore_errors=True)
                    try:
                        cli(["evaluate", "--model", str(model), "--bench", str(small), "--split", split, "--out",
                             str(folder), "--dtype", "float32"], prog_name="tacreasoner", standalone_mode=False)
                    except SystemExit as exc:
                        if exc.code:
                            raise
                report = json.loads((folder / "report.json").read_text())
                results.setdefault(split, {}).setdefault(str(g), []).append(100 * report["average"]["value"])
                print(f"seed {seed} {split} gain {g}: OCSE {results[split][str(g)][-1]:.1f}", flush=True)
    gain["g"] = 1.0
    saved = json.loads((args.models[0] / "processor_config.json").read_text())
    config = VideoProcessingConfig.from_dict(saved["video"])
    rest = video_processing._gel_image(config)
    strength: dict[str, list[float]] = {}
    data = Path(json.loads((args.bench / "bench.json").read_text())["data"])
    for split in ("val", "val_heldout_sensor"):
        for line in (small / f"{split}.jsonl").read_text().splitlines():
            clip = data / json.loads(line)["videos"][0]["path"]
            frames = original(str(clip), config)
            unnormalised = frames.transpose(0, 2, 3, 1) * np.asarray(config.std) + np.asarray(config.mean)
            strength.setdefault(split, []).append(float(np.abs(unnormalised - rest).mean()) * 255)
    summary = {"ocse_by_gain": {s: {g: [float(np.mean(v)), v] for g, v in by.items()} for s, by in results.items()},
               "change_from_R_grey_levels": {s: {"median": float(np.median(v)), "q25": float(np.percentile(v, 25)),
                                                 "q75": float(np.percentile(v, 75)), "clips": len(v)}
                                             for s, v in strength.items()}}
    (args.out / "diag.json").write_text(json.dumps(summary, indent=2))
    print(json.dumps(summary["change_from_R_grey_levels"], indent=1))
    for s, by in summary["ocse_by_gain"].items():
        print(s, {g: round(m[0], 1) for g, m in by.items()})


if __name__ == "__main__":
    main()
