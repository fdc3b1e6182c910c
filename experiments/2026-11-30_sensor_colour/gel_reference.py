"""The training sensor's gel at rest, measured on the benchmark's train clips of the seen style only.

    python experiments/2026-11-30_sensor_colour/gel_reference.py --bench runs/sens/bench --out runs/sens/gel_mini.json

Writes {mean, std} (per RGB channel, in [0, 1]) for ``video.gel_reference`` (benchmarks/sensor_transfer.py
``--preparations match+gel --gel-reference``). Only train-split objects in the seen style are read: no val or test
clip, and no clip of the held-out style.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from tacreasoner.data.readers import read_sim_dataset
from tacreasoner.model.video_processing import measure_gel_reference


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--bench", type=Path, required=True)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--max-clips", type=int, default=100, help="the gel at rest barely differs between clips")
    args = ap.parse_args()
    bench = json.loads((args.bench / "bench.json").read_text())
    seen = [s for s in bench["sensors"] if s != bench["heldout_sensor"]]
    clips = [c for c in read_sim_dataset(bench["data"])
             if bench["splits"].get(c.object_id) == "train" and c.sensor in seen][:args.max_clips]
    reference = measure_gel_reference(clips)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({**reference, "clips": len(clips), "sensors": seen, "split": "train"}, indent=2))
    print(json.dumps(reference), f"from {len(clips)} train clips ({', '.join(seen)})")


if __name__ == "__main__":
    main()
