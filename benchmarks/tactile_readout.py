"""Is the tactile information in what the LLM receives? A linear read-out of a trained model's tactile tokens.

Usage: python benchmarks/tactile_readout.py [--run runs/quickstart] [--model runs/quickstart/model]

For the single-clip attribute tasks, fits a ridge classifier on the train split's clips and scores the test
split's (held-out objects) using three feature sets of the trained model: the frozen appearance tokens
(F_app), the projector's output (what replaces the placeholders in the LLM's input), and a pixel baseline
(mean absolute background-subtracted intensity per frame). It sets the model's benchmark accuracy on the
same items beside them: a read-out far above the model's accuracy means the LLM does not use what it gets.
Results: benchmarks/results/tactile_readout.{json,md}.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp

TASKS = ("TFA-hardness", "TFA-protrusion", "TFA-elasticity", "TFA-friction")


def _features(model, processor, bench: Path, split: str, task: str, cache: Path) -> tuple[dict, np.ndarray, list]:
    import torch

    from tacreasoner.tasks.bench import load_bench
    from tacreasoner.train.data import VideoBank, bench_video_root, video_key

    info, items = load_bench(bench, split)
    items = [i for i in items if i.task == task]
    root = bench_video_root(bench, info)
    keys = [video_key(i.videos[0], root, i.id) for i in items]
    bank = VideoBank(processor.video_config, processor.sensor_types)
    bank.build(keys, cache_dir=cache)
    batch = bank.batch(keys)
    with torch.no_grad():
        app = model.tactile_encoder.appearance_tokens(batch["pixel_values"])
        question = torch.zeros(len(keys), model.config.text_hidden_size)  # no question: the attribute-free view
        projected = model.encode_videos(batch["pixel_values"], question, batch["sensor_ids"])
    pix = batch["pixel_values"].abs().mean(dim=(2, 3, 4))
    labels = np.array([i.gold["level"] for i in items])
    return ({"appearance tokens": app.flatten(1).numpy(), "projector output": projected.flatten(1).numpy(),
             "pixel intensity per frame": pix.numpy()}, labels, items)


def ridge_accuracy(x_train: np.ndarray, y_train: np.ndarray, x_test: np.ndarray, y_test: np.ndarray,
                   lam: float = 100.0) -> float:
    mu, sd = x_train.mean(0), x_train.std(0) + 1e-6
    a, b = (x_train - mu) / sd, (x_test - mu) / sd
    targets = np.eye(3)[y_train]
    w = np.linalg.solve(a.T @ a + lam * np.eye(a.shape[1]), a.T @ targets)
    return float(((b @ w).argmax(1) == y_test).mean())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--run", type=Path, default=Path("runs/quickstart"))
    parser.add_argument("--model", type=Path, default=None)
    args = parser.parse_args()

    from tacreasoner.evaluate.predict import load_trained

    model_dir = args.model or args.run / "model"
    model, processor = load_trained(model_dir, device="cpu")
    bench, cache = args.run / "bench", args.run / "video_cache"
    scored = {}
    scored_path = args.run / "eval" / "test" / "scored" / "seed0.jsonl"
    if scored_path.is_file():
        for line in scored_path.read_text().splitlines():
            r = json.loads(line)
            scored[r["id"]] = r["correct"]
    rows, payload = [], {}
    for task in TASKS:
        train_x, train_y, _ = _features(model, processor, bench, "train", task, cache)
        test_x, test_y, items = _features(model, processor, bench, "test", task, cache)
        majority = float(np.mean(test_y == np.bincount(train_y, minlength=3).argmax()))
        result = {name: ridge_accuracy(train_x[name], train_y, test_x[name], test_y) for name in train_x}
        model_acc = np.mean([scored[i.id] for i in items]) if scored and all(i.id in scored for i in items) else None
        payload[task] = {"n_train": len(train_y), "n_test": len(test_y), "majority": majority, **result,
                         "model_accuracy": None if model_acc is None else float(model_acc)}
        rows.append([task, len(train_y), len(test_y), majority, *result.values(),
                     "–" if model_acc is None else float(model_acc)])
    info = stamp()
    md = header_md("Tactile read-out: is the information in the tactile tokens?", info)
    md += (f"Model: `{model_dir}`. Ridge classifier (λ = 100, standardised features) fitted on the train split's "
           "clips, scored on the test split's clips (objects never seen in training). DynTAC-Sim-Bench (simulated). "
           "The last column is the model's own strict benchmark accuracy on the same test items (seed 0).\n\n")
    md += md_table(["task", "train clips", "test clips", "majority", "appearance tokens", "projector output",
                    "pixel intensity per frame", "model (benchmark)"], rows)
    publish("tactile_readout", {**info, "model": str(model_dir), "tasks": payload}, md)


if __name__ == "__main__":
    main()
