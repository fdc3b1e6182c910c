"""Two variants of one model on the same items, seed by seed: per-task accuracy over seeds and an exact McNemar
test per seed pair (the same Stage I per seed, so the pair differs only in what the variants change).

Each variant is a list of ``tacreasoner evaluate`` output folders (one per seed, in seed order); their
``scored/<split>.jsonl`` records are read.

    python benchmarks/paired_seeds.py --split val --name head_folds \\
        --a "cross-fitted heads (data.head_folds 5)" /tmp/x0 /tmp/x1 /tmp/x2 \\
        --b "in-sample heads (data.head_folds 1)" /tmp/i0 /tmp/i1 /tmp/i2 --notes "..."
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp
from tacreasoner.evaluate.report import compare_runs, load_scored, summarize


def _runs(folders: list[str], split: str) -> dict[str, list[dict]]:
    out = {}
    for seed, folder in enumerate(folders):
        path = Path(folder) / "scored" / f"{split}.jsonl"
        if not path.is_file():
            raise SystemExit(f"{path}: no scored records (run `tacreasoner evaluate --split {split}` first)")
        out[f"seed{seed}"] = load_scored(path)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for flag in ("--a", "--b"):
        ap.add_argument(flag, nargs="+", required=True, metavar=("LABEL", "FOLDER"),
                        help="label, then one folder per seed")
    ap.add_argument("--split", default="val")
    ap.add_argument("--name", required=True, help="result file stem under benchmarks/results")
    ap.add_argument("--title", default="Two variants, paired by seed")
    ap.add_argument("--notes", default="", help="what was trained where, and how")
    args = ap.parse_args()
    (label_a, *folders_a), (label_b, *folders_b) = args.a, args.b
    if len(folders_a) != len(folders_b) or not folders_a:
        raise SystemExit(f"--a has {len(folders_a)} folders and --b {len(folders_b)}: give one per seed to each")
    runs_a, runs_b = _runs(folders_a, args.split), _runs(folders_b, args.split)
    rep_a, rep_b = summarize(runs_a), summarize(runs_b)
    info = stamp()
    md = header_md(args.title, info) + (args.notes + "\n\n" if args.notes else "")
    md += (f"Split: **{args.split}**; {len(folders_a)} seeds; strict extraction; accuracy in %, mean ± std over "
           "seeds.\n\n")
    tasks_b = {r.task: r for r in rep_b.tasks}
    rows = [[r.task, r.n, f"{100 * r.accuracy:.1f} ± {100 * (r.std or 0):.1f}",
             f"{100 * tasks_b[r.task].accuracy:.1f} ± {100 * (tasks_b[r.task].std or 0):.1f}"] for r in rep_a.tasks]
    rows.append(["**Average**", "", f"**{100 * rep_a.average['value']:.1f}** ± {100 * (rep_a.average['std'] or 0):.1f}",
                 f"**{100 * rep_b.average['value']:.1f}** ± {100 * (rep_b.average['std'] or 0):.1f}"])
    md += md_table(["task", "n", label_a, label_b], rows)
    md += "\nPer seed (exact McNemar over all items; ↓ items A answers right and B wrong, ↑ the reverse):\n\n"
    pairs, seeds = [], {}
    for seed in runs_a:
        comp = compare_runs(runs_a[seed], runs_b[seed], label_a, label_b)
        a_avg = summarize({seed: runs_a[seed]}).average["value"]
        b_avg = summarize({seed: runs_b[seed]}).average["value"]
        seeds[seed] = {"a": a_avg, "b": b_avg, "p": comp.overall.p_value, "b10": comp.overall.b10,
                       "b01": comp.overall.b01}
        pairs.append([seed, f"{100 * a_avg:.1f}", f"{100 * b_avg:.1f}",
                      f"{comp.overall.p_value:.2g} ({comp.overall.b10}↓ {comp.overall.b01}↑)"])
    md += md_table(["seed", f"A: {label_a}", f"B: {label_b}", "p"], pairs)
    publish(args.name, {**info, "split": args.split, "a": {"label": label_a, "folders": folders_a,
                                                          "report": rep_a.to_dict()},
                        "b": {"label": label_b, "folders": folders_b, "report": rep_b.to_dict()},
                        "per_seed": seeds, "notes": args.notes}, md)


if __name__ == "__main__":
    main()
