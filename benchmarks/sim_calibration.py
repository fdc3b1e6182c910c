"""Does calibrating the simulator's contact signal to PhysiCLeAR help an encoder read real video?

Issue 28's sim-to-real point: simulated Mini clips show about three times the real clips' contact signal
(benchmarks/results/sim_realism.md); ``mini+physiclear`` scales it down to the real level. For each sensor style
(the default ``mini`` and the calibrated ``mini+physiclear``) and each seed, this simulates the quickstart's 100
objects × 5 clips, pre-trains the appearance encoder on them plus every PhysiCLeAR clip (`tacreasoner
pretrain-encoder`, 400 steps, the quickstart's recipe) and runs the frozen-encoder linear probe
(`physiclear_probe.py`: feature and L2 chosen by cross-validation on the train objects, then scored once on the val
objects). Every step is a `tacreasoner` command or the probe script, skipped when its output exists.

    python benchmarks/sim_calibration.py [--seeds 0 1 2] [--work runs/sim_calibration]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp

COLUMNS = ("hardness", "roughness", "bumpiness", "combined")


def run(command: list[str], log: Path) -> float:
    """Run one step, its output to ``log``; seconds taken. A failed step stops the benchmark with its log's name."""
    start = time.perf_counter()
    with log.open("w") as out:
        if subprocess.run(command, stdout=out, stderr=subprocess.STDOUT).returncode:
            raise SystemExit(f"step failed: {' '.join(command)} (see {log})")
    return time.perf_counter() - start


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sensors", nargs="+", default=["mini", "mini+physiclear"])
    ap.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    ap.add_argument("--work", type=Path, default=Path("runs/sim_calibration"))
    ap.add_argument("--steps", type=int, default=400, help="encoder pre-training steps (the quickstart's 400)")
    ap.add_argument("--name", default="sim_calibration")
    args = ap.parse_args()
    info = stamp()
    tr = [sys.executable, "-m", "tacreasoner"]
    probe_script = str(Path(__file__).resolve().parent / "physiclear_probe.py")
    (args.work / "logs").mkdir(parents=True, exist_ok=True)
    results: dict[str, list[dict]] = {}
    seconds: dict[str, float] = {}
    for sensor in args.sensors:
        tag = sensor.replace("+", "_")
        sim = args.work / f"sim_{tag}"
        if not (sim / "dataset.json").exists():
            seconds[f"simulate {sensor}"] = run([*tr, "simulate", "--out", str(sim), "--objects", "100", "--repeats",
                                                      "5", "--sensors", sensor], args.work / "logs" / f"sim_{tag}.log")
        for seed in args.seeds:
            encoder, probe = args.work / f"encoder_{tag}_s{seed}", args.work / f"probe_{tag}_s{seed}"
            if not (encoder / "model.safetensors").exists():
                seconds[f"encoder {sensor} seed {seed}"] = run(
                    [*tr, "pretrain-encoder", "--out", str(encoder), "--data", str(sim), "--steps", str(args.steps),
                          "--seed", str(seed), "--resume"], args.work / "logs" / f"encoder_{tag}_s{seed}.log")
            if not probe.with_suffix(".json").exists():
                run([sys.executable, probe_script, "--encoder", str(encoder), "--name", str(probe.resolve())],
                    args.work / "logs" / f"probe_{tag}_s{seed}.log")
            results.setdefault(sensor, []).append(json.loads(probe.with_suffix(".json").read_text()))

    def mean_sd(values: list[float]) -> str:
        return f"{np.mean(values):.1f} ± {np.std(values, ddof=1) if len(values) > 1 else 0.0:.1f}"

    rows = []
    for sensor, probes in results.items():
        train_cv = [100 * max(p["train_cv"].values()) for p in probes]
        rows.append([f"`{sensor}`", mean_sd(train_cv),
                     *(mean_sd([100 * p["val"][c]["accuracy"] for p in probes]) for c in COLUMNS)])
    md = header_md("Simulator calibration: does a real-level contact signal help the encoder read PhysiCLeAR?", info)
    md += (f"Per sensor style: 100 simulated objects × 5 clips plus every PhysiCLeAR clip (labels unused), encoder "
           f"pre-trained {args.steps} steps per seed (seeds {', '.join(map(str, args.seeds))}), then the "
           "frozen-encoder linear probe (benchmarks/physiclear_probe.py): train CV = the chosen (feature, L2)'s "
           "object-level 5-fold "
           "accuracy on PhysiCLeAR's train objects, mean over the three properties (the choice criterion); val = "
           "PhysiCLeAR's 7 val objects, 36 clips, scored once per encoder. Mean ± sd over seeds, %. Step times (s): "
           + ", ".join(f"{k} {v:.0f}" for k, v in seconds.items()) + ".\n\n")
    md += md_table(["simulated sensor", "train CV (choice)", *(f"val {c}" for c in COLUMNS)], rows)
    md += ("\nThe simulated statistics beside the real ones: [sim_realism.md](sim_realism.md). Val has 7 objects: "
           "a difference of one object is about 14 points on a column.\n")
    publish(args.name, {**info, "sensors": args.sensors, "seeds": args.seeds, "steps": args.steps,
                        "seconds": seconds, "probes": results}, md)


if __name__ == "__main__":
    main()
