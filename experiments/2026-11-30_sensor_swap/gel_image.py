"""The training sensor's average gel at rest, prepared as a model prepares frames, from the benchmark's train clips
of the seen style only.

    python experiments/2026-11-30_sensor_swap/gel_image.py --bench runs/sens/bench \
        --model runs/mini_ctl/train/seed0/stage2/model --out runs/sens/gel_image_mini.json

Writes {image} (h×w×3 in [0, 1], a quarter of the model's resolution) for ``video.gel_image``
(benchmarks/sensor_transfer.py ``--preparations match+gel+swap --gel-image``). Clips are picked as
experiments/2026-11-30_sensor_colour/gel_reference.py picks them: no val or test clip, no clip of the held-out style.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from tacreasoner.data.readers import read_sim_dataset
from tacreasoner.model.video_processing import VideoProcessingConfig, measure_gel_image


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--bench", type=Path, required=True)
    ap.add_argument("--model", type=Path, required=True, help="a model whose frame preparation the image follows")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--max-clips", type=int, default=100)
    args = ap.parse_args()
    bench = json.loads((args.bench / "bench.json").read_text())
    seen = [s for s in bench["sensors"] if s != bench["heldout_sensor"]]
    clips = [c for c in read_sim_dataset(bench["data"])
             if bench["splits"].get(c.object_id) == "train" and c.sensor in seen][:args.max_clips]
    video = json.loads((args.model / "processor_config.json").read_text())["video"]
    config = VideoProcessingConfig.from_dict({**video, "orientation": "match"})
    image = measure_gel_image(clips, config)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps({"image": image, "clips": len(clips), "sensors": seen, "split": "train",
                                    "video": config.to_dict()}))
    print(f"{len(image)}×{len(image[0])} image from {len(clips)} train clips ({', '.join(seen)})")


if __name__ == "__main__":
    main()
