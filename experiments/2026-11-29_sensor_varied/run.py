"""Train the quickstart recipe on a varied-look Mini corpus, 3 seeds, without scoring its own test split.

    PYTHONPATH=src python experiments/2026-11-29_sensor_varied/run.py --out runs/var --reuse runs/qs_stepwise
    (experiments/2026-11-29_sensor_half_varied: the same with --sensors mini+varied50 --out runs/var50)
    (experiments/2026-11-29_sensor_temporal_diag: --sensors mini --out runs/tnorm
     --set model.encoder.temporal_norm=true)
then
    python benchmarks/sensor_transfer.py --bench runs/sens/bench --out runs/var/eval_sens --preparations match \
        --models runs/var/train/seed{0,1,2}/stage2/model
"""

from __future__ import annotations

import argparse
import shutil
from dataclasses import replace
from pathlib import Path

from tacreasoner.cli.app import parse_overrides
from tacreasoner.recipes.quickstart import QuickstartRun, QuickstartSettings, quickstart_stages, run_stages


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--reuse", type=Path, help="a quickstart folder whose llm/ and encoder/ are copied (same settings)")
    ap.add_argument("--sensors", default="mini+varied", help="the training corpus's simulated sensor")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a training config override")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    if args.reuse:
        for part in ("llm", "encoder"):
            if not (args.out / part).exists():
                shutil.copytree(args.reuse / part, args.out / part)
    settings = replace(QuickstartSettings.load(), sensors=[args.sensors])
    stages = quickstart_stages(QuickstartRun(out=args.out, seeds=3, overrides=parse_overrides(args.set)), settings)
    run_stages([s for s in stages if s.name in ("simulate", "benchmark", "llm", "encoder", "train")])


if __name__ == "__main__":  # worker processes import this file
    main()
