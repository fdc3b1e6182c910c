"""Is a change faster, and does it train the same? The quickstart's steps, this tree against a commit, alternated.

A code change that should only make training faster (same math) is checked here: short Stage I and Stage II runs
of the quickstart's recipe, alternately with this working tree and with ``--base`` (a git worktree of that commit,
imported through PYTHONPATH), ``--rounds`` times each, so both see the same machine load. Per run: the median
seconds of a step (the first 3 not counted) and the logged loss of every step; the two trees' losses are compared
step by step (bf16 autocast rounds differently when the same sums run in another order, so identical math need
not give identical bf16 losses; ``--fp32`` runs in float32 to check the math itself).

    python benchmarks/step_time_ab.py --run runs/quickstart --base HEAD~1 [--steps 30] [--rounds 3] [--fp32]

Results: benchmarks/results/step_time_ab[_fp32].{json,md}.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, quickstart_stage_config, stamp

SKIP = 3
"""Steps not counted in a run's median (warm-up)."""
ROOT = Path(__file__).resolve().parents[1]


def worker(run: Path, stage: int, steps: int, fp32: bool, out: Path) -> None:
    """One short training run of ``stage`` with whichever ``tacreasoner`` is importable; times and losses → ``out``."""
    from tacreasoner.train.trainer import train_stage

    with tempfile.TemporaryDirectory() as tmp:
        config = quickstart_stage_config(run, stage, steps, Path(tmp) / "run")
        config.runtime.threads = 2
        if fp32:
            config.runtime.mixed_precision = "no"
        times: list[float] = []
        losses: list[float] = []
        last = [0.0]

        def on_log(rec: dict) -> None:
            now = time.perf_counter()
            times.append(now - last[0])
            losses.append(rec["loss"])
            last[0] = time.perf_counter()

        last[0] = time.perf_counter()
        train_stage(config, stage, on_log=on_log)
    out.write_text(json.dumps({"times": times[1:], "losses": losses}))  # the first interval includes the set-up


def _run(tree: Path, run: Path, stage: int, steps: int, fp32: bool, out: Path) -> dict:
    env = {**os.environ, "PYTHONPATH": str(tree / "src")}
    cmd = [sys.executable, str(Path(__file__).resolve()), "--worker", "--run", str(run), "--stage", str(stage),
           "--steps", str(steps), "--out", str(out)] + (["--fp32"] if fp32 else [])
    done = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"training with {tree} failed:\n{done.stderr[-3000:]}")
    return json.loads(out.read_text())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--run", type=Path, default=Path("runs/quickstart"), help="A finished quickstart run folder.")
    ap.add_argument("--base", default="HEAD", help="The commit to compare this working tree with.")
    ap.add_argument("--steps", type=int, default=30, help="Steps per run.")
    ap.add_argument("--rounds", type=int, default=3, help="Runs per tree and stage, alternated.")
    ap.add_argument("--stages", default="1,2", help="Which stages, comma-separated.")
    ap.add_argument("--fp32", action="store_true", help="Train in float32 (to compare the math without bf16).")
    ap.add_argument("--name", help="Result name under benchmarks/results/ (default step_time_ab, or _fp32).")
    ap.add_argument("--notes", default="", help="A paragraph for the result file: what the change is.")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--stage", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--out", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        worker(args.run.resolve(), args.stage, args.steps, args.fp32, args.out)
        return
    if not (args.run / "train" / "seed0" / "stage1" / "model").is_dir():
        sys.exit(f"{args.run}: no train/seed0/stage1/model: run `tacreasoner quickstart` first")
    if args.steps <= SKIP + 2:
        sys.exit(f"--steps must be over {SKIP + 2}")
    info = stamp()
    base_rev = subprocess.run(["git", "rev-parse", "--short", args.base], cwd=ROOT, capture_output=True, text=True,
                              check=True).stdout.strip()
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                          check=True).stdout.strip()
    dirty = bool(subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT,
                                capture_output=True, text=True, check=True).stdout.strip())
    this = f"{head}{' + uncommitted changes' if dirty else ''}"
    results: dict = {"base": base_rev, "this": this, "steps": args.steps, "rounds": args.rounds, "fp32": args.fp32,
                     "stages": {}}
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        worktree = Path(tmp) / "base"
        subprocess.run(["git", "worktree", "add", "--detach", "-q", str(worktree), base_rev], cwd=ROOT, check=True)
        try:
            for stage in (int(s) for s in args.stages.split(",")):
                runs: dict[str, list[dict]] = {"base": [], "this": []}
                for r in range(args.rounds):
                    for name, tree in (("base", worktree), ("this", ROOT)):
                        got = _run(tree, args.run.resolve(), stage, args.steps, args.fp32, Path(tmp) / "out.json")
                        runs[name].append(got)
                        print(f"Stage {stage} round {r + 1} {name}: median "
                              f"{statistics.median(got['times'][SKIP:]):.3f} s/step", flush=True)
                medians = {n: [statistics.median(g["times"][SKIP:]) for g in v] for n, v in runs.items()}
                diffs = [abs(a - b) for a, b in zip(runs["base"][0]["losses"], runs["this"][0]["losses"], strict=True)]
                rel = [d / abs(a) for d, a in zip(diffs, runs["base"][0]["losses"], strict=True) if a]
                ratio = statistics.mean(medians["this"]) / statistics.mean(medians["base"])
                paired = [t / b for t, b in zip(medians["this"], medians["base"], strict=True)]
                results["stages"][str(stage)] = {"medians_s": medians, "ratio_of_means": ratio,
                                                 "paired_ratios": paired,
                                                 "losses": {n: v[0]["losses"] for n, v in runs.items()},
                                                 "max_abs_loss_diff": max(diffs), "max_rel_loss_diff": max(rel),
                                                 "first_diff_step": next((i + 1 for i, d in enumerate(diffs) if d),
                                                                         None)}
                rows.append([f"Stage {'I' if stage == 1 else 'II'}",
                             " / ".join(f"{m:.3f}" for m in medians["base"]),
                             " / ".join(f"{m:.3f}" for m in medians["this"]), f"{ratio:.3f}",
                             " / ".join(f"{p:.2f}" for p in paired), f"{max(diffs):.2g} ({100 * max(rel):.2g}%)",
                             results["stages"][str(stage)]["first_diff_step"] or "none"])
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(worktree)], cwd=ROOT, check=False)
    name = args.name or ("step_time_ab_fp32" if args.fp32 else "step_time_ab")
    md = header_md(f"Training step time: {this} against {base_rev}, alternated", info)
    md += (f"Run folder: `{args.run}` (the quickstart's data, LLM, encoder and Stage I model); the quickstart's recipe "
           f"({'float32' if args.fp32 else 'mixed precision as configured'}), {args.steps} steps a run, "
           f"{args.rounds} runs per tree and stage, the trees alternated (base first); a run's time is the median "
           f"step after the first {SKIP}. Ratio: mean of this tree's medians over the base's (below 1: faster); "
           "paired: per round. Loss: the largest difference between the two trees' logged losses, step by step "
           "(the first round of each), and the first step where they differ.\n\n")
    if args.notes:
        md += args.notes + "\n\n"
    md += md_table(["stage", f"{base_rev} s/step (per run)", "this s/step (per run)", "ratio", "paired",
                    "max loss diff", "first differing step"], rows)
    publish(name, {**info, **results}, md)


if __name__ == "__main__":
    main()
