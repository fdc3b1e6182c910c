"""Summarise a SmolLM2 run (benchmarks/gpu_smollm2.sh, or the same layout on a CPU) into one results file.

Reads ``<run>/eval/<name>/<split>/scored/<split>.jsonl`` (the per-item records ``tacreasoner evaluate`` keeps) for
the recipe's seeds and the ablations, and writes, per split (val, then test):

- the recipe over its seeds: per-task accuracy, mean ± std over seeds, Wilson 95% interval, hallucination rate;
- the paper's Table 3/4 ablations, one seed each, against the recipe's seed 0 on the same items (exact McNemar);
- TSA (zero-shot) under strict and lenient extraction, since an untrained format is what it tests.

    python benchmarks/smollm2_summary.py --run /tmp/gpu --bench runs/quickstart/bench --name gpu_smollm2 \
        --machine "one NVIDIA H100 (lent), 16 cores" --command "bash benchmarks/gpu_smollm2.sh ..."
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp
from tacreasoner.evaluate.report import Report, compare_runs, evaluate, load_scored, summarize
from tacreasoner.intervals import wilson_interval
from tacreasoner.tasks.bench import load_bench

ABLATIONS = {
    "no_dyn": "w/o temporal branch (appearance only)",
    "no_cot": "w/o TouchCoT (Stage II on plain answers)",
    "no_stage1": "w/o Stage I",
    "no_stage2": "w/o Stage II (Stage I model)",
}


def _records(run: Path, name: str, split: str) -> list[dict]:
    return load_scored(run / "eval" / name / split / "scored" / f"{split}.jsonl")


def _lenient_tsa(run: Path, name: str, split: str, bench: Path) -> tuple[int, int]:
    """(correct, n) of TSA under lenient extraction, rescored from the kept predictions."""
    _, items = load_bench(bench, split)
    tsa = [item for item in items if item.task == "TSA"]
    with tempfile.TemporaryDirectory() as tmp:
        preds = run / "eval" / name / split / "predictions" / f"{split}.jsonl"
        report = evaluate(tsa, [preds], "lenient", Path(tmp))
    row = next(r for r in report.tasks if r.task == "TSA")
    return round(row.accuracy * row.n), row.n


def _tsa_cell(correct: int, n: int) -> str:
    lo, hi = wilson_interval(correct, n)
    return f"{100 * correct / n:.1f} [{100 * lo:.0f}–{100 * hi:.0f}]"


def split_section(run: Path, split: str, seeds: list[str], bench: Path) -> tuple[str, dict]:
    seed_runs = {s: _records(run, s, split) for s in seeds}
    recipe: Report = summarize(seed_runs)
    md = f"## {split}\n\n### The recipe, {len(seeds)} seeds ({', '.join(seeds)})\n\n"
    md += recipe.to_markdown().split("\n", 2)[2].lstrip()  # without its own title
    base = seed_runs[seeds[0]]
    rows, ablations = [], {}
    for name, label in ABLATIONS.items():
        path = run / "eval" / name / split / "scored" / f"{split}.jsonl"
        if not path.is_file():
            continue
        records = load_scored(path)
        rep = summarize({name: records})
        comp = compare_runs(base, records, seeds[0], name)
        tasks = {r.task: r.accuracy for r in rep.tasks}
        ablations[name] = {"label": label, "average": rep.average["value"], "overall": rep.overall["accuracy"],
                           "hallucination_rate": rep.overall.get("hallucination_rate"), "tasks": tasks,
                           "mcnemar_vs_seed0": {"p": comp.overall.p_value, "b10": comp.overall.b10,
                                                "b01": comp.overall.b01}}
        rows.append([label, 100 * rep.average["value"], 100 * rep.overall["accuracy"],
                     f"{comp.overall.p_value:.2g} ({comp.overall.b10}↓ {comp.overall.b01}↑)",
                     *[100 * tasks.get(t.task, float("nan")) for t in recipe.tasks]])
    seed0 = summarize({seeds[0]: base})
    rows.insert(0, [f"full ({seeds[0]})", 100 * seed0.average["value"], 100 * seed0.overall["accuracy"], "–",
                    *[100 * r.accuracy for r in seed0.tasks]])
    md += (f"\n### Ablations (the paper's Tables 3/4), one seed each, against {seeds[0]} on the same items\n\n"
           "p: exact McNemar test on all items (↓ items the full model answers right and the ablation wrong, "
           "↑ the reverse).\n\n")
    md += md_table(["model", "Average", "items", "p vs full", *[r.task for r in recipe.tasks]], rows)
    tsa = {}
    for name in [*seeds, *ablations]:
        correct, n = _lenient_tsa(run, name, split, bench)
        strict = next((r for r in summarize({name: _records(run, name, split)}).tasks if r.task == "TSA"), None)
        tsa[name] = {"lenient_correct": correct, "n": n, "strict_accuracy": strict.accuracy if strict else None}
    md += ("\n### TSA (zero-shot: never trained on), strict and lenient extraction\n\n"
           "Strict reads only a letter (\"A\", \"(A)\"); lenient also an option's text (\"the first object\"). "
           "Chance 50%.\n\n")
    md += md_table(["model", "strict %", "lenient % [Wilson 95%]"],
                   [[k, 100 * (v["strict_accuracy"] or 0), _tsa_cell(v["lenient_correct"], v["n"])]
                    for k, v in tsa.items()])
    ids = [r["id"] for r in base]
    correct = {}  # per model, one character per item in ``item_ids`` order: paired tests against later models
    for name in [*seeds, *ablations]:
        by_id = {r["id"]: r["correct"] for r in _records(run, name, split)}
        correct[name] = "".join("1" if by_id[i] else "0" for i in ids)
    return md + "\n", {"recipe": recipe.to_dict(), "ablations": ablations, "tsa": tsa, "item_ids": ids,
                        "correct": correct}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, required=True, help="folder holding eval/<name>/<split>/")
    ap.add_argument("--bench", type=Path, default=Path("runs/quickstart/bench"))
    ap.add_argument("--seeds", default="seed0,seed1,seed2")
    ap.add_argument("--name", default="smollm2")
    ap.add_argument("--title", default="SmolLM2-135M-Instruct (4-bit GGUF weights) with the paper's core encoder")
    ap.add_argument("--machine", default="", help="where the models were trained and evaluated")
    ap.add_argument("--command", default="", help="the command that trained and evaluated them")
    ap.add_argument("--notes", default="", help="a paragraph placed under the header")
    args = ap.parse_args()
    info = stamp()
    seeds = args.seeds.split(",")
    md = header_md(args.title, info)
    md += (f"- Trained and evaluated on: {args.machine}\n- By: `{args.command}`\n"
           "- Recipe: `configs/smollm2-135m-touchcot.yaml` "
           f"(Stage I 1000 + Stage II 1000 steps, LoRA r 128 / α 256, lr 2e-4, fp32), DynTAC-Sim-Bench (simulated, "
           f"not the paper's DynTAC-Bench), held-out objects; strict extraction unless said.\n\n")
    md += (args.notes + "\n\n") if args.notes else ""
    payload = {**info, "trained_on": args.machine, "run_command": args.command, "seeds": seeds, "splits": {}}
    for split in ("val", "test"):
        section, data = split_section(args.run, split, seeds, args.bench)
        md += section
        payload["splits"][split] = data
    publish(args.name, payload, md)


if __name__ == "__main__":
    main()
