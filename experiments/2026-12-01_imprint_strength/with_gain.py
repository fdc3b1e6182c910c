"""A model folder answering with the imprint swap and a sensor's imprint gain (links to the weights; criteria.md).

    python experiments/2026-12-01_imprint_strength/with_gain.py --model M --gain G.json --out DIR
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from tacreasoner.model.video_processing import VideoProcessingConfig


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--model", type=Path, required=True)
    ap.add_argument("--gain", type=Path, required=True, help="gain.py's output")
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    config = json.loads((args.model / "processor_config.json").read_text())
    gain = json.loads(args.gain.read_text())["imprint_gain"]
    config["video"] = VideoProcessingConfig.from_dict(
        {**config["video"], "gel_swap": "imprint", "imprint_gain": gain}).to_dict()
    args.out.mkdir(parents=True, exist_ok=True)
    for f in args.model.iterdir():
        target = args.out / f.name
        if f.name != "processor_config.json" and not target.exists():
            target.symlink_to(f.resolve())
    (args.out / "processor_config.json").write_text(json.dumps(config, indent=2))
    print(f"{args.out}: gel_swap imprint, imprint_gain {gain}")


if __name__ == "__main__":
    main()
