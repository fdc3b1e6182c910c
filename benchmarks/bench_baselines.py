"""Random and majority-class baselines on DynTAC-Sim-Bench and on PhysiCLeAR's val split.

Produced with the same commands a user runs (``simulate``, ``build-bench``, ``baseline``, ``score``,
``compare``), so the numbers double as an end-to-end check of the benchmark tooling. Every model
result should be read against these rows.

    python benchmarks/bench_baselines.py [--objects 100 --repeats 5 --work runs/bench/baselines]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, publish, stamp

REPO = Path(__file__).resolve().parents[1]
PHYSICLEAR = Path("../shared/data/physiclear")
"""Relative to the repository root: commands run there, so the recorded commands are the ones to type."""


def run(*args: str) -> None:
    """One ``tacreasoner`` command, echoed so the result file shows exactly what produced it."""
    cmd = [sys.executable, "-m", "tacreasoner", *args]
    print("$ tacreasoner " + " ".join(args), flush=True)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, cwd=REPO)


def baselines(bench: Path, split: str, label: str, commands: list[str]) -> dict:
    """Both baselines on one split: predictions, report, and their McNemar comparison."""
    out: dict = {}
    preds = bench / "predictions"
    for kind in ("random", "majority"):
        path = preds / f"{split}_{kind}.jsonl"
        args = ["baseline", "--bench", str(bench), "--split", split, "--kind", kind, "--out", str(path)]
        run(*args)
        report_dir = bench / "reports" / f"{split}_{kind}"
        score_args = ["score", str(path), "--bench", str(bench), "--split", split, "--out", str(report_dir)]
        run(*score_args)
        commands += ["tacreasoner " + " ".join(args), "tacreasoner " + " ".join(score_args)]
        out[kind] = json.loads((REPO / report_dir / "report.json").read_text())
    cmp_dir = bench / "reports" / f"{split}_random_vs_majority"
    cmp_args = ["compare", str(preds / f"{split}_random.jsonl"), str(preds / f"{split}_majority.jsonl"),
                "--bench", str(bench), "--split", split, "--out", str(cmp_dir)]
    run(*cmp_args)
    commands.append("tacreasoner " + " ".join(cmp_args))
    out["comparison"] = json.loads((REPO / cmp_dir / "comparison.json").read_text())
    out["label"] = label
    return out


def table(result: dict) -> str:
    rows = {r["task"]: r for r in result["random"]["tasks"]}
    maj = {r["task"]: r for r in result["majority"]["tasks"]}
    lines = ["| task | n | chance | random | random 95% CI | majority | majority 95% CI |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for task, r in rows.items():
        m = maj[task]
        lines.append(f"| {task} | {r['n']} | {100 * r['chance']:.1f} | {100 * r['accuracy']:.1f} | "
                     f"{100 * r['ci_low']:.1f}–{100 * r['ci_high']:.1f} | {100 * m['accuracy']:.1f} | "
                     f"{100 * m['ci_low']:.1f}–{100 * m['ci_high']:.1f} |")
    lines.append(f"| **Average** | | | **{100 * result['random']['average']['value']:.1f}** | | "
                 f"**{100 * result['majority']['average']['value']:.1f}** | |")
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--objects", type=int, default=100)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--work", type=Path, default=Path("runs/bench/baselines"), help="relative to the repo root")
    args = ap.parse_args()
    work: Path = args.work
    commands: list[str] = []
    sim, bench = work / "dyntac_sim", work / "dyntac_sim_bench"
    sim_args = ["simulate", "--out", str(sim), "--objects", str(args.objects), "--repeats", str(args.repeats),
                "--sensors", "mini,digit"]
    run(*sim_args)
    bench_args = ["build-bench", "--source", "sim", "--data", str(sim), "--out", str(bench), "--heldout-sensor",
                  "digit"]
    run(*bench_args)
    commands += ["tacreasoner " + " ".join(sim_args), "tacreasoner " + " ".join(bench_args)]
    results = {"dyntac_test": baselines(bench, "test", "DynTAC-Sim-Bench test (novel objects)", commands),
               "dyntac_heldout": baselines(bench, "test_heldout_sensor",
                                           "DynTAC-Sim-Bench test, held-out sensor (DIGIT)", commands)}
    if (REPO / PHYSICLEAR / "labels.json").exists():
        pbench = work / "physiclear_bench"
        p_args = ["build-bench", "--source", "physiclear", "--data", str(PHYSICLEAR), "--out", str(pbench)]
        run(*p_args)
        commands.append("tacreasoner " + " ".join(p_args))
        results["physiclear_val"] = baselines(pbench, "val", "PhysiCLeAR val split (real GelSight Mini)", commands)

    info = stamp()
    md = header_md("Baselines: random and majority-class predictors", info)
    md += ("Majority = the most frequent gold answer of the train split per task (zero-shot TSA has no train "
           "items, so it falls back to random). Accuracy in %, Wilson 95% intervals over items, strict answer "
           "extraction. DynTAC-Sim-Bench is simulated: the project's stand-in, not the paper's DynTAC-Bench.\n\n")
    for result in results.values():
        md += f"## {result['label']}\n\n" + table(result) + "\n"
    md += "## Commands\n\n```\n" + "\n".join(commands) + "\n```\n"
    payload = {**info, "settings": {k: str(v) for k, v in vars(args).items()}, "commands": commands,
               "results": results}
    publish("baselines", payload, md)


if __name__ == "__main__":
    main()
