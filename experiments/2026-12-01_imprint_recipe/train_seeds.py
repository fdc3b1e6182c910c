"""Train more seeds of a recipe whose run folder is already built (data, LLM, encoder), reusing its parts.

    python experiments/2026-12-01_imprint_recipe/train_seeds.py --out runs/swt --seeds 3 4 5

Each seed is the quickstart's training config pointed at ``--out`` (``quickstart_config``): the same corpus, LLM and
encoder (with whatever frame preparation its ``video_processing.json`` records), only the seed differs.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from tacreasoner.recipes.quickstart import quickstart_config
from tacreasoner.recipes.quickstart_parts import QuickstartPaths
from tacreasoner.train.run import train_stages


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", type=Path, required=True, help="a run folder with sim/, bench/, llm/ and encoder/")
    ap.add_argument("--seeds", type=int, nargs="+", required=True)
    args = ap.parse_args()
    paths = QuickstartPaths(args.out)
    for seed in args.seeds:
        info = train_stages(quickstart_config(paths, seed))
        took = ", ".join(f"{k} {v:.0f} s" for k, v in info["seconds"].items()) or "already trained"
        print(f"seed {seed}: {took} → {info['model']}", flush=True)


if __name__ == "__main__":  # worker processes import this file
    main()
