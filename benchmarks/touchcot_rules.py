"""TouchCoT with the offline rules teacher on DynTAC-Sim-Bench: size, throughput and acceptance.

Runs the user-facing commands: ``build-bench`` (train split, ``--per-task`` large enough for ≥10,000
samples; TSA is zero-shot and never in train) and ``build-cot`` (rules teacher), then reads the run
report. Reuses the simulated corpus of ``bench_baselines.py`` when present (simulates it otherwise).

    python benchmarks/touchcot_rules.py [--per-task 1200 --workers 2]
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp

REPO = Path(__file__).resolve().parents[1]


def run(*args: str) -> float:
    print("$ tacreasoner " + " ".join(args), flush=True)
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "tacreasoner", *args], check=True, cwd=REPO, stdout=subprocess.DEVNULL)
    return time.perf_counter() - start


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default="runs/bench/baselines/dyntac_sim")
    ap.add_argument("--work", default="runs/bench/touchcot")
    ap.add_argument("--per-task", type=int, default=1200)
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    work = REPO / args.work
    shutil.rmtree(work, ignore_errors=True)  # measure a cold build (no cue cache, no samples)
    commands = []
    if not (REPO / args.data / "manifest.jsonl").exists():
        sim = ["simulate", "--out", args.data, "--objects", "100", "--repeats", "5", "--sensors", "mini,digit"]
        run(*sim)
        commands.append(sim)
    bench = ["build-bench", "--source", "sim", "--data", args.data, "--out", f"{args.work}/bench",
             "--heldout-sensor", "digit", "--per-task", str(args.per_task)]
    t_bench = run(*bench)
    cot = ["build-cot", "--bench", f"{args.work}/bench", "--out", f"{args.work}/cot", "--teacher", "rules",
           "--workers", str(args.workers)]
    t_cot = run(*cot)
    commands += [bench, cot]
    report = json.loads((work / "cot" / "build_cot.json").read_text())
    stats = json.loads((work / "cot" / "touchcot" / "stats.json").read_text())

    info = stamp()
    rows = [[task, rate] for task, rate in report["acceptance_by_task"].items()]
    md = header_md("TouchCoT with the rules teacher on DynTAC-Sim-Bench (train split)", info)
    md += (f"**{report['accepted']} accepted samples** of {report['jobs']} generated "
           f"({report['rejected']} rejected) across {len(rows)} training tasks (TSA is zero-shot and excluded). "
           f"Training files: {stats['train']} train / {stats['val']} val samples, split by object "
           f"({stats['val_mixed']} val samples also show a train object, never the reverse).\n\n")
    md += (f"- build-cot wall time: {t_cot:.0f} s (stages: {report['seconds']}); generation throughput "
           f"{report['samples_per_second']} samples/s; end to end {report['jobs'] / t_cot:.0f} samples/s "
           f"including cue extraction for every clip.\n- build-bench: {t_bench:.0f} s.\n\n")
    md += "Acceptance rate per task:\n\n" + md_table(["task", "acceptance"], rows)
    md += "\nCommands:\n\n```\n" + "\n".join("tacreasoner " + " ".join(c) for c in commands) + "\n```\n"
    md += "\nSimulated data (DynTAC-Sim), not the paper's TouchCoT-10K.\n"
    payload = {**info, "settings": vars(args), "commands": commands, "build_cot": report,
               "seconds": {"build_bench": round(t_bench, 1), "build_cot": round(t_cot, 1)},
               "format_stats": {k: stats[k] for k in ("train", "val", "val_mixed", "warnings")}}
    publish("touchcot_rules", payload, md)


if __name__ == "__main__":
    main()
