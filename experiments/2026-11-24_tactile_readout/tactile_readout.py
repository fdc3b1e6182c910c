"""Is the tactile information in what the LLM receives? A linear read-out of a trained model's tactile tokens.

Usage: python benchmarks/tactile_readout.py [--run runs/quickstart] [--model runs/quickstart/model]

For the single-clip tasks (the four attributes, and RFOR: real vs fake), fits a ridge classifier on the train
split's clips and scores the test split's (held-out objects) using three feature sets of the trained model: the
frozen appearance tokens (F_app), the projector's output (what replaces the placeholders in the LLM's input), and
a pixel baseline (mean absolute background-subtracted intensity per frame). It sets the model's benchmark accuracy
on the same items beside them: a read-out far above the model's accuracy means the LLM does not use what it gets.
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

TASKS = ("TFA-hardness", "TFA-protrusion", "TFA-elasticity", "TFA-friction", "RFOR")


def _clip_features(model, processor, keys: list, cache: Path) -> dict[str, np.ndarray]:
    """Per clip: the frozen appearance tokens, the projector's output (no question) and the pixel baseline."""
    import torch

    from tacreasoner.train.data import VideoBank

    bank = VideoBank(processor.video_config, processor.sensor_types)
    bank.build(keys, cache_dir=cache)
    batch = bank.batch(keys)
    with torch.no_grad():
        app = model.tactile_encoder.appearance_tokens(batch["pixel_values"])
        question = torch.zeros(len(keys), model.config.text_hidden_size)  # no question: the attribute-free view
        projected = model.encode_videos(batch["pixel_values"], question, batch["sensor_ids"])
    pix = batch["pixel_values"].abs().mean(dim=(2, 3, 4))
    return {"appearance tokens": app.flatten(1).numpy(), "projector output": projected.flatten(1).numpy(),
            "pixel intensity per frame": pix.numpy()}


def _items(bench: Path, split: str, task: str) -> tuple[list, list]:
    """The split's items of ``task`` and, per item, its videos' keys."""
    from tacreasoner.tasks.bench import load_bench
    from tacreasoner.train.data import bench_video_root, video_key

    info, items = load_bench(bench, split)
    items = [i for i in items if i.task == task]
    root = bench_video_root(bench, info)
    return items, [[video_key(v, root, i.id) for v in i.videos] for i in items]


def _features(model, processor, bench: Path, split: str, task: str, cache: Path) -> tuple[dict, np.ndarray, list]:
    items, keys = _items(bench, split, task)
    feats = _clip_features(model, processor, [k[0] for k in keys], cache)
    return feats, np.array([_label(i) for i in items]), items


def _label(item) -> int:
    """The class a read-out predicts: the attribute's level, or 1 for a real fruit and 0 for a fake one (RFOR)."""
    return int(item.gold["real"]) if item.task == "RFOR" else int(item.gold["level"])


def _ridge(x_train: np.ndarray, targets: np.ndarray, x_test: np.ndarray, lam: float) -> np.ndarray:
    """Ridge regression on standardised features: the test rows' predicted targets."""
    mu, sd = x_train.mean(0), x_train.std(0) + 1e-6
    a, b = (x_train - mu) / sd, (x_test - mu) / sd
    return b @ np.linalg.solve(a.T @ a + lam * np.eye(a.shape[1]), a.T @ targets)


def ridge_accuracy(x_train: np.ndarray, y_train: np.ndarray, x_test: np.ndarray, y_test: np.ndarray,
                   lam: float = 100.0) -> float:
    classes = int(max(y_train.max(), y_test.max())) + 1
    return float((_ridge(x_train, np.eye(classes)[y_train], x_test, lam).argmax(1) == y_test).mean())


def compare_by_scores(item, scores: list[float]) -> bool:
    """Whether comparing the videos' read-out scores answers an SFD/SOI item right."""
    gold = item.gold
    pick = int(np.argmax(scores)) if gold["direction"] in ("more", "most") else int(np.argmin(scores))
    if gold.get("kind") == "yesno":
        return (pick == 0) == gold["value"]
    return pick == gold["index"]


PAIRS = "projector output, fitted on SFD pairs"


def _pair_directions(model, processor, bench: Path, cache: Path) -> dict[str, tuple]:
    """Per attribute, a ridge direction fitted on the train SFD pairs: (first − second) → which has more of it."""
    items, keys = _items(bench, "train", "SFD")
    x = _clip_features(model, processor, [k for ks in keys for k in ks], cache)["projector output"]
    out = {}
    for attr in sorted({i.gold["attribute"] for i in items}):
        chosen = [n for n, i in enumerate(items) if i.gold["attribute"] == attr]
        diffs = np.stack([x[2 * n] - x[2 * n + 1] for n in chosen])
        more = np.array([1.0 if items[n].meta["ranks"][0] > items[n].meta["ranks"][1] else -1.0 for n in chosen])
        mu, sd = diffs.mean(0), diffs.std(0) + 1e-6
        a = (diffs - mu) / sd
        w = np.linalg.solve(a.T @ a + 100.0 * np.eye(a.shape[1]), a.T @ more)
        out[attr] = (mu, sd, w)
    return out


def comparison_ceiling(model, processor, bench: Path, cache: Path, tfa_train: dict, scored: dict) -> dict:
    """SFD/SOI answered by a linear score per video (ridge regression of the level on the train clips), compared.

    No reasoning and no discrete levels: a reader that compares continuous scores, so it bounds what a model
    reading these tokens can do on the comparisons without better tactile features. One more column fits the
    projector-output score on the train split's SFD pairs alone (the supervision a comparison-only learner gets)."""
    pairs = _pair_directions(model, processor, bench, cache)
    out = {}
    for task in ("SFD", "SOI"):
        items, keys = _items(bench, "test", task)
        flat = [k for ks in keys for k in ks]
        feats = _clip_features(model, processor, flat, cache)
        per_item = [len(ks) for ks in keys]
        starts = np.cumsum([0, *per_item])
        rows = {}
        for name, x in feats.items():
            right = {}
            for attr in sorted({i.gold["attribute"] for i in items}):
                train_x, train_y = tfa_train[f"TFA-{attr}"]
                chosen = [n for n, i in enumerate(items) if i.gold["attribute"] == attr]
                rows_x = np.concatenate([x[starts[n]:starts[n + 1]] for n in chosen])
                score = _ridge(train_x[name], train_y.astype(float)[:, None], rows_x, 100.0)[:, 0]
                offsets = np.cumsum([0, *(per_item[n] for n in chosen)])
                for j, n in enumerate(chosen):
                    right[n] = compare_by_scores(items[n], list(score[offsets[j]:offsets[j + 1]]))
            rows[name] = right
        right = {}
        x = feats["projector output"]
        for n, item in enumerate(items):
            attr = item.gold["attribute"]
            mu, sd, w = pairs[attr]
            right[n] = compare_by_scores(item, list(((x[starts[n]:starts[n + 1]] - mu) / sd) @ w))
        rows[PAIRS] = right
        model_right = {n: scored[i.id] for n, i in enumerate(items) if i.id in scored}
        attrs = sorted({i.gold["attribute"] for i in items})
        groups = {"all": list(range(len(items)))} | {
            a: [n for n, i in enumerate(items) if i.gold["attribute"] == a] for a in attrs}
        out[task] = {g: {"n": len(ns), **{name: float(np.mean([r[n] for n in ns])) for name, r in rows.items()},
                         "model_accuracy": float(np.mean([model_right[n] for n in ns]))
                         if len(model_right) == len(items) else None}
                     for g, ns in groups.items()}
    return out


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
    rows, payload, tfa_train = [], {}, {}
    for task in TASKS:
        train_x, train_y, _ = _features(model, processor, bench, "train", task, cache)
        tfa_train[task] = (train_x, train_y)
        test_x, test_y, items = _features(model, processor, bench, "test", task, cache)
        majority = float(np.mean(test_y == np.bincount(train_y).argmax()))
        result = {name: ridge_accuracy(train_x[name], train_y, test_x[name], test_y) for name in train_x}
        model_acc = np.mean([scored[i.id] for i in items]) if scored and all(i.id in scored for i in items) else None
        objects = len({i.objects[0] for i in items})
        payload[task] = {"n_train": len(train_y), "n_test": len(test_y), "test_objects": objects, "majority": majority,
                         **result, "model_accuracy": None if model_acc is None else float(model_acc)}
        rows.append([task, len(train_y), len(test_y), objects, majority, *result.values(),
                     "–" if model_acc is None else float(model_acc)])
    info = stamp()
    md = header_md("Tactile read-out: is the information in the tactile tokens?", info)
    md += (f"Model: `{model_dir}`. Ridge classifier (λ = 100, standardised features) fitted on the train split's "
           "clips, scored on the test split's clips (objects never seen in training). DynTAC-Sim-Bench (simulated). "
           "The last column is the model's own strict benchmark accuracy on the same test items (seed 0).\n\n")
    md += md_table(["task", "train clips", "test clips", "test objects", "majority", "appearance tokens",
                    "projector output", "pixel intensity per frame", "model (benchmark)"], rows)
    comparisons = comparison_ceiling(model, processor, bench, cache, tfa_train, scored)
    md += ("\n## Comparisons: is the order of two or three objects in the tokens?\n\n"
           "SFD and SOI test items answered without the LLM: a ridge regression of the attribute's level, fitted on "
           "the train split's single-clip items above, scores each video, and the item is answered by comparing the "
           "scores (continuous, so never a tie). The column fitted on SFD pairs learns each attribute's score from the "
           "train split's SFD items alone (first minus second video → which has more), the supervision a learner "
           "of comparisons alone gets. Chance: SFD 0.5, SOI 0.333. The last column is the model's own "
           "strict benchmark accuracy on the same items (seed 0).\n\n")
    names = list(next(iter(next(iter(comparisons.values())).values())))[1:-1]
    crows = [[task, group, r["n"], *(r[n] for n in names), "–" if r["model_accuracy"] is None else r["model_accuracy"]]
             for task, groups in comparisons.items() for group, r in groups.items()]
    md += md_table(["task", "attribute", "items", *names, "model (benchmark)"], crows)
    publish("tactile_readout", {**info, "model": str(model_dir), "tasks": payload, "comparisons": comparisons}, md)


if __name__ == "__main__":
    main()
