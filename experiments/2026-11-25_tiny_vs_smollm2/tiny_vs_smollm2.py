"""The tiny default against SmolLM2's paper core on the same DynTAC-Sim-Bench items, val and test, seed by seed.

The tiny default's seeds are those of a ``tacreasoner quickstart --seeds 3`` run (its test answers are already
there; val is answered here, once, with the same models and video cache). SmolLM2's per-item correctness comes
from ``benchmarks/results/gpu_smollm2.json`` (written by smollm2_summary.py). Per split: Average and item accuracy
(mean ± std over seeds) per model, and the exact McNemar test of tiny seed k against SmolLM2 seed k on the same
items.

    python benchmarks/tiny_vs_smollm2.py [--run runs/quickstart] [--smollm2 benchmarks/results/gpu_smollm2.json]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import RESULTS, header_md, md_table, publish, stamp
from tacreasoner.evaluate.report import load_scored, summarize
from tacreasoner.evaluate.stats import mcnemar_exact
from tacreasoner.train.quickstart import QuickstartPaths, evaluate_seeds

SPLITS = ("val", "test")


def tiny_records(paths: QuickstartPaths, seeds: list[int]) -> dict[str, dict[str, list[dict]]]:
    """split → seed name → scored records, answering a split first where its records are missing."""
    out: dict[str, dict[str, list[dict]]] = {}
    for split in SPLITS:
        scored = {s: paths.evaluation / split / "scored" / f"seed{s}.jsonl" for s in seeds}
        if not all(p.is_file() for p in scored.values()):
            models = {s: paths.train(s) / "stage2" / "model" for s in seeds}
            evaluate_seeds(models, paths.bench, paths.evaluation, (split,), video_cache=paths.video_cache)
        out[split] = {f"seed{s}": load_scored(p) for s, p in scored.items()}
    return out


def _pm(values: list[float]) -> str:
    return f"{100 * statistics.mean(values):.1f} ± {100 * statistics.stdev(values):.1f}" if len(values) > 1 \
        else f"{100 * values[0]:.1f}"


def _halluc(overall: dict) -> str:
    """The report's pooled hallucination rate: flagged among checkable replies (docs/benchmark.md)."""
    n = overall.get("n_checkable") or 0
    return f"{100 * overall['hallucination_rate']:.1f} ({n})" if n else "–"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, default=Path("runs/quickstart"))
    ap.add_argument("--smollm2", type=Path, default=RESULTS / "gpu_smollm2.json")
    ap.add_argument("--seeds", default="0,1,2")
    args = ap.parse_args()
    info = stamp()
    seeds = [int(s) for s in args.seeds.split(",")]
    smol = json.loads(args.smollm2.read_text(encoding="utf-8"))
    tiny = tiny_records(QuickstartPaths(args.run), seeds)
    md = header_md("Tiny default vs SmolLM2's paper core, same items (DynTAC-Sim-Bench, strict)", info)
    md += ("Tiny default: the quickstart's recipe (tiny LLM pre-trained here, comparator, name matcher and clip reader "
           f"heads), trained on this machine's 2 CPU cores, seeds {args.seeds}. SmolLM2: "
           "`configs/smollm2-135m-touchcot.yaml` (SmolLM2-135M-Instruct, 4-bit GGUF weights, paper core, no heads), "
           "trained "
           f"on a lent H100 ({args.smollm2.name}). p: exact McNemar test of tiny seed k against SmolLM2 seed k on "
           "all items of the split (↑ items only the tiny model answers right, ↓ only SmolLM2).\n\n")
    payload = {**info, "seeds": seeds, "splits": {}}
    for split in SPLITS:
        split_smol = smol["splits"][split]
        ids = split_smol["item_ids"]
        tiny_rep = summarize(tiny[split])
        smol_avg = split_smol["recipe"]["average"]["per_run"]
        smol_items = split_smol["recipe"]["overall"]["per_run"]
        smol_overall = split_smol["recipe"]["overall"]
        rows = [["tiny default (heads)", len(seeds), _pm(tiny_rep.average["per_run"]),
                 _pm(tiny_rep.overall["per_run"]), _halluc(tiny_rep.overall)],
                ["SmolLM2 core", len(smol_avg), _pm(smol_avg), _pm(smol_items), _halluc(smol_overall)]]
        tests = {}
        for s in seeds:
            by_id = {r["id"]: bool(r["correct"]) for r in tiny[split][f"seed{s}"]}
            if set(by_id) != set(ids):
                raise ValueError(f"{split}: the tiny seed {s} answered other items than SmolLM2 ({len(by_id)} vs "
                                 f"{len(ids)}); was the benchmark rebuilt?")
            smol_correct = [c == "1" for c in split_smol["correct"][f"seed{s}"]]
            result = mcnemar_exact([by_id[i] for i in ids], smol_correct)
            tests[f"seed{s}"] = {"p": result.p_value, "tiny_only": result.b10, "smollm2_only": result.b01}
        md += f"## {split}\n\n" + md_table(["model", "seeds", "Average %", "items %", "halluc. % (checked)"], rows)
        md += "\n" + md_table(["pair", "p", "↑ tiny only", "↓ SmolLM2 only"],
                              [[f"seed {k[4:]}", f"{v['p']:.2g}", v["tiny_only"], v["smollm2_only"]]
                               for k, v in tests.items()])
        md += "\nPer task, tiny default (mean over seeds):\n\n" + md_table(
            ["task", "accuracy %", "mean ± std"], [[r.task, 100 * r.accuracy, _pm(r.per_run)] for r in tiny_rep.tasks])
        md += "\n"
        payload["splits"][split] = {"tiny": tiny_rep.to_dict(), "mcnemar_tiny_vs_smollm2": tests}
    publish("tiny_vs_smollm2", payload, md)


if __name__ == "__main__":
    main()
