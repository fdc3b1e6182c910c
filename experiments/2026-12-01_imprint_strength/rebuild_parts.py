"""The imprint recipe's run folder up to training (data, LLM, encoder, swap), as the swap-train experiment built it.

    python experiments/2026-12-01_imprint_strength/rebuild_parts.py --out runs/swt

``runs/`` did not survive into the session that answered this experiment's question (2026-12-01, evening), so the
models are trained again from the same stages and seeds (rebuild.sh); ``train_seeds.py`` of the imprint-recipe
experiment then trains seeds 3–5 on what this leaves.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

from tacreasoner.recipes.quickstart import QuickstartRun, QuickstartSettings, Stage, quickstart_stages, run_stages
from tacreasoner.recipes.quickstart_parts import QuickstartPaths, swap_in_training


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    settings = replace(QuickstartSettings.load(), sensors=["mini"])
    stages = {s.name: s for s in quickstart_stages(QuickstartRun(out=args.out, seeds=3), settings)}
    paths = QuickstartPaths(args.out)
    run_stages([*(stages[n] for n in ("simulate", "benchmark", "llm", "encoder")),
                Stage("swap", "colour map + average gel at rest into the frame preparation",
                      lambda: swap_in_training(paths))])


if __name__ == "__main__":  # worker processes import this file
    main()
