"""Cross-fitting the comparator: its copies fitted one by one vs together in one loop, side by side.

When Stage II starts, the read-out heads are fitted out of fold: one copy of the comparator per set of held-out
folds (25 with 5 folds), each by 1500 AdamW steps on small tensors, so the cost is Python and autograd overhead
per step, paid once per copy. ``fit_comparators`` runs all copies' steps in one loop (each copy's own batches,
statistics and directions; AdamW acts per element). This script times both ways in one process, alternating
which goes first, on comparisons shaped like the quickstart's (pairs and triples of 5×112 encoder outputs, 6
attributes, 60 objects), and checks that the two give the same readings.

    python benchmarks/heads_fit.py [--prompts 600 --rounds 3 --threads 1]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp
from tacreasoner.model.heads import ComparatorHead, CrossVideoFusion, HeadRows, crossfit


def comparisons(prompts: int, seed: int = 0) -> tuple[HeadRows, list[list[str]]]:
    """Pairs and triples of quickstart-shaped encoder outputs (tokens_per_video 5, hidden 112, question 576)."""
    g = torch.Generator().manual_seed(seed)
    videos, targets, objects = [], [], []
    for i in range(prompts):
        k = 2 + i % 2
        videos.append(torch.randn(k, 5, 112, generator=g))
        targets.append((int(torch.randint(0, k, (1,), generator=g)), i % 6, i % 2))
        objects.append([f"object{int(x)}" for x in torch.randint(0, 60, (k,), generator=g)])
    return HeadRows(videos=videos, questions=torch.randn(prompts, 576, generator=g), targets=targets), objects


def timed(rows: HeadRows, objects: list[list[str]], together: bool) -> tuple[float, list]:
    torch.manual_seed(0)
    head = ComparatorHead(CrossVideoFusion(112, 4, 4.0, 3, 576, 5, 6))
    saved = ComparatorHead.fit_rows_together
    if not together:
        del ComparatorHead.fit_rows_together
    try:
        start = time.perf_counter()
        out = crossfit(head, rows, objects, 5, seed=0)
        return time.perf_counter() - start, out.readings
    finally:
        ComparatorHead.fit_rows_together = saved


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--prompts", type=int, default=600, help="comparisons (the quickstart's train split: ~600-900)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--threads", type=int, default=1, help="torch threads (Stage II's set-up on a 2-core machine: 1-2)")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    rows, objects = comparisons(args.prompts)
    times: dict[str, list[float]] = {"one by one": [], "together": []}
    differences = []
    for r in range(args.rounds):
        order = [False, True] if r % 2 == 0 else [True, False]
        readings = {}
        for together in order:
            seconds, readings[together] = timed(rows, objects, together)
            times["together" if together else "one by one"].append(round(seconds, 2))
        differences.append(max(float((a - b).abs().max()) for a, b in zip(readings[True], readings[False], strict=True)
                               if a is not None))
    info = stamp()
    best = {k: min(v) for k, v in times.items()}
    payload = {**info, "prompts": args.prompts, "threads": args.threads, "copies": 25, "fit_steps": 1500,
               "seconds": times, "speedup_best": round(best["one by one"] / best["together"], 2),
               "max_reading_difference": max(differences)}
    rows_md = [[k, " / ".join(f"{s:.1f}" for s in v), f"{best[k]:.1f}"] for k, v in times.items()]
    md = (header_md("Cross-fitting the comparator: copies one by one vs together", info)
          + f"{args.prompts} quickstart-shaped comparisons, 5 folds (25 copies), 1500 AdamW steps each, "
          f"{args.threads} torch thread(s), {args.rounds} rounds alternating which way goes first.\n\n"
          + md_table(["way", "seconds per round", "best"], rows_md)
          + f"\nSpeed-up (best of each): **{payload['speedup_best']}x**. The two ways' readings differ by at most "
          f"{payload['max_reading_difference']:.1e} (float rounding: the same batches, statistics and steps).\n")
    publish("heads_fit", payload, md)


if __name__ == "__main__":
    main()
