"""Train a SmolLM2 recipe end to end on this machine's CPU and time it: Stage I, Stage II, then answer val once.

The issue's bar: the SmolLM2 recipe trains end to end in at most 60 minutes on 2 CPU cores. Each stage runs as
``tacreasoner train`` in its own process (as a user would run it); the wall time of each, its own train_seconds
(run.json), the peak resident memory of the processes, and the val score (strict) are written to
``benchmarks/results/<name>.{json,md}``. Only val is answered: the recipe is not chosen from it here, and test is
scored once per final recipe elsewhere.

    python benchmarks/smollm2_cpu_recipe.py --config configs/smollm2-135m-cpu.yaml
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp


def _run(args: list[str], log: Path) -> float:
    """Run ``python -m tacreasoner ARGS`` with output to ``log``; its wall seconds (a failure stops the benchmark)."""
    start = time.perf_counter()
    with log.open("w") as out:
        done = subprocess.run([sys.executable, "-m", "tacreasoner", *args], stdout=out, stderr=subprocess.STDOUT,
                              check=False)
    if done.returncode != 0:
        raise SystemExit(f"`tacreasoner {' '.join(args)}` failed (exit {done.returncode}); see {log}")
    return time.perf_counter() - start


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", default="configs/smollm2-135m-cpu.yaml")
    ap.add_argument("--out", type=Path, default=Path("runs/train/smollm2-cpu-timed"), help="output_dir of the run")
    ap.add_argument("--bench", type=Path, default=Path("runs/quickstart/bench"))
    ap.add_argument("--name", default="smollm2_cpu_recipe")
    ap.add_argument("--set", action="append", default=[], help="extra --set overrides for both stages")
    args = ap.parse_args()
    if args.out.exists():
        raise SystemExit(f"{args.out} exists: choose another --out (the timing must start from nothing)")
    info = stamp()
    args.out.mkdir(parents=True)
    sets = [x for s in [f"output_dir={args.out}", *args.set] for x in ("--set", s)]
    wall = {}
    for stage in (1, 2):
        wall[f"stage{stage}"] = _run(["train", "--stage", str(stage), "--config", args.config, *sets],
                                     args.out / f"stage{stage}.log")
    runs = {f"stage{s}": json.loads((args.out / f"stage{s}" / "run.json").read_text()) for s in (1, 2)}
    peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    wall["val"] = _run(["evaluate", "--model", str(args.out / "stage2" / "model"), "--bench", str(args.bench),
                        "--split", "val", "--out", str(args.out / "eval" / "val")], args.out / "eval_val.log")
    report = json.loads((args.out / "eval" / "val" / "report.json").read_text())
    train_total = wall["stage1"] + wall["stage2"]
    payload = {**info, "config": args.config, "overrides": args.set, "cores": os.cpu_count(),
               "wall_seconds": wall, "train_wall_seconds": train_total, "within_60_minutes": train_total <= 3600,
               "stages": {k: {"steps": r.get("steps_done"), "train_seconds": r.get("train_seconds"),
                              "examples": r.get("examples"), "threads": r.get("threads"),
                              "mixed_precision": r.get("mixed_precision")} for k, r in runs.items()},
               "peak_rss_mb": peak_mb, "val": {"average": report["average"]["value"],
                                               "overall": report["overall"]["accuracy"],
                                               "tasks": {t["task"]: t["accuracy"] for t in report["tasks"]}}}
    md = header_md("SmolLM2 recipe trained end to end on this machine's CPU", info)
    md += (f"Config: `{args.config}`{' with ' + ', '.join(args.set) if args.set else ''}; "
           f"{os.cpu_count()} cores; each stage a separate `tacreasoner train` process.\n\n")
    rows = [[k, f"{payload['stages'][k]['steps']}", f"{wall[k] / 60:.1f}",
             f"{payload['stages'][k]['train_seconds'] / payload['stages'][k]['steps']:.2f}",
             payload["stages"][k]["mixed_precision"]] for k in ("stage1", "stage2")]
    md += md_table(["stage", "steps", "wall (min)", "s / step (training loop)", "precision"], rows)
    md += (f"\n**Both stages: {train_total / 60:.1f} minutes** (target ≤ 60: "
           f"{'met' if train_total <= 3600 else 'NOT met'}); peak resident memory {peak_mb:.0f} MB; answering val "
           f"took {wall['val'] / 60:.1f} more minutes.\n\n")
    md += (f"Val (DynTAC-Sim-Bench, strict, one seed; the recipe was not chosen from it): Average "
           f"**{100 * report['average']['value']:.1f}%**, item accuracy "
           f"{100 * report['overall']['accuracy']:.1f}%.\n\n")
    md += md_table(["task", "val %"], [[t["task"], 100 * t["accuracy"]] for t in report["tasks"]])
    publish(args.name, payload, md)


if __name__ == "__main__":
    main()
