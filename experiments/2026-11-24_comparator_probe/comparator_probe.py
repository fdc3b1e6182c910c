"""Can a comparator learn SFD/SOI from a trained model's tactile features? Three parameterisations, by gradient.

Usage: python benchmarks/comparator_probe.py [--run runs/quickstart] [--model DIR] [--steps 1500]

The model's question-conditioned encoder output (what its projector receives) is computed once per video of the
train and test SFD/SOI items and kept fixed. A comparator scores each video as its features along a direction and
picks the highest score; it is trained with Adam on the train items' gold picks (cross-entropy over the videos)
and scored on the test items (held-out objects). The direction is
- *from the question*: a linear map of the mean question embedding (as ``encoder.cross_video``'s comparator), with
  LayerNorm per video or with per-dimension standardisation;
- *per attribute*: one learned direction per attribute, chosen by the item's gold attribute and signed by its
  comparative (more/most: +, less/least: −), on standardised features;
- *per attribute, read from the question*: the same directions, with the test items' attribute and comparative
  predicted from the mean question embedding by two linear classifiers fitted on the train items.
It tells whether the comparisons fail on the features or on how the question chooses the direction.
Results: benchmarks/results/comparator_probe.{json,md}.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp

ATTRIBUTES = ("hardness", "protrusion", "elasticity", "friction")


def _features(model, processor, bench: Path, cache: Path, split: str) -> dict:
    import torch

    from tacreasoner.tasks.bench import load_bench
    from tacreasoner.train.data import VideoBank, bench_video_root, comparison_winner, video_key

    info, items = load_bench(bench, split)
    items = [i for i in items if i.task in ("SFD", "SOI")]
    root = bench_video_root(bench, info)
    keys = [[video_key(v, root, i.id) for v in i.videos] for i in items]
    bank = VideoBank(processor.video_config, processor.sensor_types)
    bank.build([k for ks in keys for k in ks], cache_dir=cache)
    embed = model.get_input_embeddings()
    feats, questions = [], []
    with torch.no_grad():
        for item, ks in zip(items, keys, strict=True):
            enc = processor.encode_conversation(processor.messages(item.question), add_generation_prompt=True)
            ids, mask = torch.tensor([enc.input_ids]), torch.tensor([enc.question_mask])
            q = model.question_vectors(ids, embed(ids), None, mask)
            videos = bank.batch(ks)
            f = model.tactile_encoder(videos["pixel_values"], q.repeat(len(ks), 1), videos["sensor_ids"])
            feats.append(f.flatten(1))
            questions.append(q[0])
    return {"items": items, "feats": feats, "questions": torch.stack(questions),
            "winner": torch.tensor([comparison_winner(i) for i in items]),
            "attribute": [ATTRIBUTES.index(i.gold["attribute"]) for i in items],
            "sign": [1.0 if i.gold["direction"] in ("more", "most") else -1.0 for i in items]}


def _read_from_question(train: dict, data: dict) -> dict:
    """``data``'s attribute and comparative sign as predicted from its question embedding (ridge classifiers)."""
    x_train, x = train["questions"].numpy(), data["questions"].numpy()
    mu, sd = x_train.mean(0), x_train.std(0) + 1e-6
    a, b = (x_train - mu) / sd, (x - mu) / sd

    def fit(labels: np.ndarray, classes: int) -> np.ndarray:
        w = np.linalg.solve(a.T @ a + 10.0 * np.eye(a.shape[1]), a.T @ np.eye(classes)[labels])
        return (b @ w).argmax(1)

    attribute = fit(np.array(train["attribute"]), len(ATTRIBUTES))
    more = fit(np.array([int(s > 0) for s in train["sign"]]), 2)
    return {"attribute": [int(v) for v in attribute], "sign": [1.0 if v else -1.0 for v in more],
            "read_right": float(np.mean((attribute == np.array(data["attribute"]))
                                        & ((more * 2 - 1) == np.array(data["sign"]))))}


def _train_and_score(train: dict, test: dict, kind: str, steps: int) -> dict:
    import torch
    from torch import nn
    from torch.nn import functional as F

    torch.manual_seed(0)
    width, qdim = train["feats"][0].shape[1], train["questions"].shape[1]
    stacked = torch.cat(train["feats"])
    mu, sd = stacked.mean(0), stacked.std(0) + 1e-6
    norm = nn.LayerNorm(width)
    from_question = nn.Sequential(nn.LayerNorm(qdim), nn.Linear(qdim, width))
    per_attribute = nn.Parameter(torch.zeros(len(ATTRIBUTES), width))

    def scores(data: dict, n: int) -> torch.Tensor:
        f = data["feats"][n]
        if kind == "question, LayerNorm":
            return norm(f) @ from_question(data["questions"][n]) / width ** 0.5
        f = (f - mu) / sd
        if kind == "question, standardised":
            return f @ from_question(data["questions"][n]) / width ** 0.5
        return f @ (data["sign"][n] * per_attribute[data["attribute"][n]]) / width ** 0.5

    per_attr = kind.startswith("per attribute")
    params = [per_attribute] if per_attr else [*from_question.parameters(), *norm.parameters()]
    opt = torch.optim.AdamW(params, lr=1e-2 if per_attr else 1e-3, weight_decay=0.1 if per_attr else 0.0)
    gen = torch.Generator().manual_seed(0)
    for _ in range(steps):
        batch = torch.randint(0, len(train["feats"]), (16,), generator=gen).tolist()
        loss = sum(F.cross_entropy(scores(train, n)[None], train["winner"][n][None]) for n in batch) / len(batch)
        opt.zero_grad()
        loss.backward()
        opt.step()

    def accuracy(data: dict) -> dict:
        if kind == "per attribute, read from the question":
            data = {**data, **_read_from_question(train, data)}
        with torch.no_grad():
            right = [int(scores(data, n).argmax()) == int(data["winner"][n]) for n in range(len(data["feats"]))]
        tasks = [i.task for i in data["items"]]
        out = {t: float(np.mean([r for r, tt in zip(right, tasks, strict=True) if tt == t])) for t in ("SFD", "SOI")}
        return out | ({"question read right": data["read_right"]} if "read_right" in data else {})

    return {"train": accuracy(train), "test": accuracy(test)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--run", type=Path, default=Path("runs/quickstart"))
    parser.add_argument("--model", type=Path, default=None)
    parser.add_argument("--steps", type=int, default=1500)
    args = parser.parse_args()

    import torch

    from tacreasoner.evaluate.predict import load_trained

    torch.set_num_threads(1)
    model_dir = args.model or args.run / "model"
    model, processor = load_trained(model_dir, device="cpu")
    base = getattr(model, "get_base_model", lambda: model)()
    bench, cache = args.run / "bench", args.run / "video_cache"
    train, test = (_features(base, processor, bench, cache, split) for split in ("train", "test"))
    kinds = ("question, LayerNorm", "question, standardised", "per attribute", "per attribute, read from the question")
    results = {kind: _train_and_score(train, test, kind, args.steps) for kind in kinds}
    info = stamp()
    md = header_md("Comparator probe: can SFD/SOI be learnt from the tactile features by gradient?", info)
    md += (f"Model: `{model_dir}` (its question-conditioned encoder output, fixed). {len(train['items'])} train and "
           f"{len(test['items'])} test SFD/SOI items (test objects unseen); Adam, {args.steps} steps of 16 items. "
           "Direction *question*: a linear map of the mean question embedding; *per attribute*: a learned "
           "direction per attribute, chosen by the gold attribute and signed by the comparative; *read from the "
           "question*: the same, with the test items' attribute and comparative predicted from the question embedding "
           "by linear classifiers fitted on the train items. Chance: SFD 0.5, "
           "SOI 0.333; a Wilson lower bound above chance at n = 75 needs SFD 0.61, SOI 0.453.\n\n")
    md += md_table(["direction", "train SFD", "train SOI", "test SFD", "test SOI", "test attribute + comparative read"],
                   [[k, r["train"]["SFD"], r["train"]["SOI"], r["test"]["SFD"], r["test"]["SOI"],
                     r["test"].get("question read right", "–")] for k, r in results.items()])
    publish("comparator_probe", {**info, "model": str(model_dir), "steps": args.steps, "results": results}, md)


if __name__ == "__main__":
    main()
