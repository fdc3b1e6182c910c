"""The gate's threshold: the largest lighting distance from R over every train-split clip of the seen style.

    python experiments/2026-11-30_sensor_gate/swap_above.py --bench runs/sens/bench \
        --gel-reference runs/sens/gel_mini.json --gel-image runs/sens/gel_image_mini.json \
        --model runs/mini_ctl/train/seed0/stage2/model --out runs/sens/gel_gate_mini.json

Writes the ``--gel-image`` file again with ``swap_above`` added (``video.gel_swap_above``, for
benchmarks/sensor_transfer.py's ``+gate`` preparations). The threshold reads train clips of the seen style only;
afterwards, for the report only (nothing is chosen from it), the share of val clips of each style beyond it.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from tacreasoner.data.readers import read_sim_dataset
from tacreasoner.model.video_processing import VideoProcessingConfig, measure_gel_swap_above


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--bench", type=Path, required=True)
    ap.add_argument("--gel-reference", type=Path, required=True)
    ap.add_argument("--gel-image", type=Path, required=True)
    ap.add_argument("--model", type=Path, required=True, help="a model whose frame preparation the gate follows")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--report-splits", nargs="+", default=["val"], help="splits whose share of swapped clips is "
                    "printed (test only after the choice, decision.md)")
    args = ap.parse_args()
    bench = json.loads((args.bench / "bench.json").read_text())
    seen = [s for s in bench["sensors"] if s != bench["heldout_sensor"]]
    reference = json.loads(args.gel_reference.read_text())
    swap = json.loads(args.gel_image.read_text())
    video = json.loads((args.model / "processor_config.json").read_text())["video"]
    config = VideoProcessingConfig.from_dict({**video, "orientation": "match", "gel_swap": "lighting",
                                              "gel_reference": {k: reference[k] for k in ("mean", "std")},
                                              "gel_image": swap["image"]})
    clips = list(read_sim_dataset(bench["data"]))
    train = [c for c in clips if bench["splits"].get(c.object_id) == "train" and c.sensor in seen]
    if args.out.is_file() and json.loads(args.out.read_text()).get("swap_above_clips") == len(train):
        above = json.loads(args.out.read_text())["swap_above"]  # measured already: only the report below
    else:
        above = measure_gel_swap_above(train, config)
    args.out.write_text(json.dumps({**swap, "swap_above": above, "swap_above_clips": len(train),
                                    "swap_above_split": "train", "swap_above_sensors": seen}))
    print(f"swap_above {above:.6f} (mean |smooth(map(rest)) - R| in [0, 1], {above * 255:.2f} grey levels) "
          f"from {len(train)} train clips ({', '.join(seen)})")
    for split in args.report_splits:  # report only: how the gate splits the clips of each style
        for sensor in bench["sensors"]:
            chosen = [c for c in clips if bench["splits"].get(c.object_id) == split and c.sensor == sensor]
            report(split, sensor, chosen, config, above)


def report(split: str, sensor: str, clips: list, config: VideoProcessingConfig, above: float) -> None:
    distances = np.array([measure_gel_swap_above([c], config) for c in clips])
    print(f"{split} {sensor}: {len(clips)} clips, {100 * np.mean(distances > above):.1f}% swapped; distance median "
          f"{np.median(distances) * 255:.2f}, range {distances.min() * 255:.2f}–{distances.max() * 255:.2f} "
          "grey levels")


if __name__ == "__main__":
    main()
