"""Mini val under ``match+gel+light``: are the RFOR/OCSE items lost on clips whose own lighting is far from R?

As run 2026-11-30 19:10 from the main checkout, after run.sh's second run (a diagnosis of answers already made;
nothing is chosen from it): .venv/bin/python experiments/2026-11-30_sensor_swap/light_diag.py. Uses the module's
private helpers on purpose, to measure exactly the perturbation the swap adds to a clip: R − smooth(map(rest)).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from tacreasoner.data.readers import read_sim_dataset
from tacreasoner.data.sampling import background_frame, resize_keep_aspect
from tacreasoner.model.video_processing import VideoProcessingConfig, _gel_image, _smoothed, _to_gel_reference

ROOT = Path("runs/mini_ctl/eval_sens")
TASKS = ("RFOR", "OCSE", "TFA-hardness")


def scored(path: Path) -> dict[str, bool]:
    return {r["id"]: r["correct"] for r in map(json.loads, path.read_text().splitlines())}


def main() -> None:
    video = json.loads((ROOT / "seed0/model_match+gel+light/processor_config.json").read_text())["video"]
    config = VideoProcessingConfig.from_dict(video)
    items = [json.loads(line) for line in Path("runs/sens/bench/val.jsonl").read_text().splitlines()]
    clips = {c.clip_id: c for c in read_sim_dataset("runs/sens/sim") if c.sensor == "mini"}
    target = _gel_image(config)
    distance: dict[str, float] = {}

    def far(clip_id: str) -> float:  # mean |R − smooth(map(rest))|: what the swap adds to every frame
        if clip_id not in distance:
            clip = clips[clip_id]
            rest = background_frame(clip.frames, clip.phases)
            prepared = resize_keep_aspect(rest, *config.image_size, mode=config.resize_mode).astype(np.float32) / 255
            mapped = _to_gel_reference(prepared[None], rest, config.gel_reference)[0]
            distance[clip_id] = float(np.abs(_smoothed(mapped, config) - target).mean())
        return distance[clip_id]

    rows = []
    for seed in range(3):
        before = scored(ROOT / f"seed{seed}/val_match+gel/scored/val.jsonl")
        after = scored(ROOT / f"seed{seed}/val_match+gel+light/scored/val.jsonl")
        rows += [(it["task"], np.mean([far(v["clip_id"]) for v in it["videos"]]), before[it["id"]], after[it["id"]])
                 for it in items if it["task"] in TASKS]
    values = np.array([r[1] for r in rows])
    median = float(np.median(values))
    print(f"added lighting, mean |R - smooth(rest)| in [0, 1]: median {median:.4f}, range {values.min():.4f} to "
          f"{values.max():.4f}")
    for task in TASKS:
        for name, near in (("nearer", True), ("farther", False)):
            part = [r for r in rows if r[0] == task and (r[1] <= median) == near]
            print(f"{task} {name} half: {len(part)} answers (3 seeds), match+gel "
                  f"{100 * np.mean([r[2] for r in part]):.1f}, light {100 * np.mean([r[3] for r in part]):.1f}")


if __name__ == "__main__":
    main()
