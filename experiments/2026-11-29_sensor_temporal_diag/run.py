"""The control's stages (experiments/2026-11-29_sensor_varied/run.py, Mini corpus, 3 seeds) with config overrides.

    PYTHONPATH=src python experiments/2026-11-29_sensor_temporal_diag/run.py --out runs/tnorm \
        --set model.encoder.temporal_norm=true
(runs/tnorm's sim, bench, llm, encoder and video_cache linked to runs/mini_ctl's first, so both train on one corpus.)
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import yaml

from tacreasoner.recipes.quickstart import QuickstartRun, QuickstartSettings, quickstart_stages, run_stages


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = ap.parse_args()
    overrides = {k: yaml.safe_load(v) for k, v in (item.split("=", 1) for item in args.set)}
    settings = replace(QuickstartSettings.load(), sensors=["mini"])
    stages = quickstart_stages(QuickstartRun(out=args.out, seeds=3, overrides=overrides), settings)
    run_stages([s for s in stages if s.name in ("simulate", "benchmark", "llm", "encoder", "train")])


if __name__ == "__main__":
    main()
