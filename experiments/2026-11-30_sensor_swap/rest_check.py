"""Do the simulator's rest frames tell real from fake objects (a shortcut RFOR could learn from the background)?

Train-split Mini clips only. As run 2026-11-30 18:56 from the main checkout:
    .venv/bin/python experiments/2026-11-30_sensor_swap/rest_check.py
160 clips: a nearest-centroid read-out of a coarse rest image across 5 object folds, 0.500 against the majority's
0.531; the rest frames' channel means and contrasts correlate with ``real`` at |r| <= 0.18.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from tacreasoner.data.readers import read_sim_dataset
from tacreasoner.data.sampling import background_frame


def main() -> None:
    splits = json.loads(Path("runs/sens/bench/bench.json").read_text())["splits"]
    clips = [c for c in read_sim_dataset("runs/sens/sim") if c.sensor == "mini"
             and splits.get(c.object_id) == "train" and c.labels.get("real") is not None][:160]
    rests = [background_frame(c.frames, c.phases).astype(np.float64) / 255 for c in clips]
    real = np.array([float(c.labels["real"]) for c in clips])
    stats = np.array([np.concatenate([r.reshape(-1, 3).mean(0), r.reshape(-1, 3).std(0)]) for r in rests])
    print(len(clips), "clips; real share", real.mean().round(3))
    for j, name in enumerate(["mean_r", "mean_g", "mean_b", "std_r", "std_g", "std_b"]):
        print(name, "corr with real", round(float(np.corrcoef(stats[:, j], real)[0, 1]), 3))
    coarse = np.array([r[::40, ::40].ravel() for r in rests])
    objects = sorted({c.object_id for c in clips})
    fold = np.array([objects.index(c.object_id) % 5 for c in clips])
    hits: list[bool] = []
    for k in range(5):
        train, test = fold != k, fold == k
        z = (coarse - coarse[train].mean(0)) / (coarse[train].std(0) + 1e-6)
        c1, c0 = z[train & (real == 1)].mean(0), z[train & (real == 0)].mean(0)
        guess = (np.linalg.norm(z[test] - c1, axis=1) < np.linalg.norm(z[test] - c0, axis=1)).astype(float)
        hits += list(guess == real[test])
    print("coarse rest image -> real, nearest centroid, 5 object folds:", round(float(np.mean(hits)), 3),
          "majority", round(float(max(real.mean(), 1 - real.mean())), 3))


if __name__ == "__main__":
    main()
