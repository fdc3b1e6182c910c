"""The DIGIT style's imprint gain for the imprint recipe's models, from the models' own train objects (criteria.md).

    python experiments/2026-12-01_imprint_strength/gain.py --out runs/swt/imprint_gain.json

Unlabelled clips only: the Mini clips of the 70 train objects of `runs/sens` as the models trained on them, and the
same objects' DIGIT clips (which no benchmark split asks about). No val or test object is read.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from tacreasoner.data.readers import read_sim_dataset
from tacreasoner.model.video_processing import VideoProcessingConfig, measure_imprint_gain


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--bench", type=Path, default=Path("runs/sens/bench"))
    ap.add_argument("--model", type=Path, default=Path("runs/swt/train/seed3/stage2/model"),
                    help="a model of the recipe (its processor config's video settings)")
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    started = time.time()
    info = json.loads((args.bench / "bench.json").read_text())
    train = {o for o, s in info["splits"].items() if s == "train"}
    clips = [c for c in read_sim_dataset(info["data"]) if c.object_id in train]
    mini = [c for c in clips if c.sensor == "mini"]
    digit = [c for c in clips if c.sensor == "digit"]
    video = json.loads((args.model / "processor_config.json").read_text())["video"]
    config = VideoProcessingConfig.from_dict({**video, "gel_swap": "imprint"})
    gain = measure_imprint_gain(digit, mini, config)
    own = measure_imprint_gain(mini[::5], mini, config)  # the training sensor against itself (a fifth of its clips)
    out = {"imprint_gain": gain, "mini_against_itself": own, "objects": len(train), "clips": {"mini": len(mini),
           "digit": len(digit)}, "bench": str(args.bench), "model": str(args.model),
           "seconds": round(time.time() - started)}
    args.out.write_text(json.dumps(out, indent=2) + "\n")
    print(json.dumps(out))


if __name__ == "__main__":
    main()
