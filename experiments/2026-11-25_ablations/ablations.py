"""The paper's Tables 3 and 4 on DynTAC-Sim-Bench with the tiny config: each ablation is one config change.

Usage (after `tacreasoner quickstart`, whose run directory holds the benchmark, TouchCoT, the pre-trained
tiny LLM and encoder, and the full model of seed 0):

    python benchmarks/ablations.py [--run runs/quickstart] [--variants full,no_dyn,...] [--seed 0]

Variants (Table 3: DynEncoder × CoT-SFT; Table 4: training stages; plus the encoder's own switches):

    full           the quickstart model (Stage I + Stage II on TouchCoT, dynamic encoder on)
    no_dyn         appearance branch only (no temporal branch, no fusion): VTV-LLM-like encoder
    no_cot         Stage II on plain QA (<answer>gold</answer>) instead of TouchCoT
    no_dyn_no_cot  both of the above
    no_stage1      Stage II straight on the pre-trained LLM + encoder
    no_stage2      Stage I only (the model has never seen a benchmark-style question)
    no_qcond       temporal pooling not conditioned on the question
    cls_only       1 tactile token per video (the paper's CLS-only mode) instead of 5
    no_cross       no cross-video layer and comparator: each video of a comparison encoded alone (the default
                   before the ninth session)
    no_names       the cross-video layer without its name matcher (OSC prompts get the comparator's pick)
    no_reader      no clip reader: single clips' tokens carry no fitted level vectors (the default before the
                   twelfth session)
    plain_hardness_only  diagnostic (not in the paper, not run by default): Stage II on plain TFA-hardness only
    plain_tfa_only       diagnostic (not run by default): both stages on the four TFA attributes only, Stage II
                         on plain answers, 1200 steps (~300 per attribute)

Each variant is trained and evaluated on the held-out test objects; the table gives per-task accuracy with
Wilson 95% intervals and the exact McNemar p-value of each variant against `full` on the same items.
no_cot, no_stage2 and no_reader change Stage II only, so they start from the full model's Stage I (copied).
Everything is resumable (finished variants are reused). Results: benchmarks/results/ablations.{json,md}.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, publish, stamp

VARIANTS: dict[str, dict] = {
    "full": {},
    "no_dyn": {"model": {"encoder": {"use_temporal": False}}},
    "no_cot": {"data": {"stage2_data": "plain"}},
    "no_dyn_no_cot": {"model": {"encoder": {"use_temporal": False}}, "data": {"stage2_data": "plain"}},
    "no_stage1": {"stage1": {"skip": True}},
    "no_stage2": {"stage2": {"skip": True}},
    "no_qcond": {"model": {"encoder": {"question_conditioning": False}}},
    "cls_only": {"model": {"encoder": {"tokens_per_video": 1}}},
    "no_cross": {"model": {"encoder": {"cross_video": 0}}},
    "no_names": {"model": {"encoder": {"cross_video_names": False}}},
    "no_reader": {"model": {"encoder": {"clip_reader": False}}},
    # diagnostic, not in the paper: is the LLM side able to learn one attribute when it sees only that task?
    "plain_hardness_only": {"data": {"stage2_data": "plain", "tasks": ["TFA-hardness"]}},
    # diagnostic: do the four attribute questions interfere with each other, or do the other tasks?
    "plain_tfa_only": {"data": {"stage2_data": "plain", "tasks": ["TFA-hardness", "TFA-protrusion", "TFA-elasticity",
                                                                  "TFA-friction"]},
                       "stage2": {"steps": 1200}},
}
SHARED_STAGE1 = ("no_cot", "no_stage2", "no_reader")
"""Variants that change Stage II only: they start from the full model's Stage I (copied, not retrained with the
same seed and settings), which saves two Stage I runs and keeps Stage I's randomness out of their comparison."""
DESCRIPTIONS = {
    "full": "Stage I + Stage II (TouchCoT), dynamic encoder",
    "no_dyn": "no temporal branch (appearance only)",
    "no_cot": "Stage II on plain QA, no reasoning",
    "no_dyn_no_cot": "no temporal branch + plain QA",
    "no_stage1": "without Stage I (alignment)",
    "no_stage2": "without Stage II (SFT)",
    "no_qcond": "temporal pooling ignores the question",
    "cls_only": "1 token per video (CLS only)",
    "no_cross": "no cross-video comparator",
    "no_names": "no name matcher (OSC)",
    "no_reader": "no clip reader (single-clip level vectors)",
    "plain_hardness_only": "diagnostic: Stage II on plain TFA-hardness answers only",
    "plain_tfa_only": "diagnostic: Stage II on plain answers of the four TFA attributes, 1200 steps",
}


def _config(paths, name: str, seed: int):
    from tacreasoner.train.quickstart import quickstart_config

    overrides = json.loads(json.dumps(VARIANTS[name]))
    if "model" in overrides:  # model.encoder is a nested mapping: merge, do not replace the model section
        model = {"llm": str(paths.llm), "appearance": str(paths.encoder)}
        model.update({k: v for k, v in overrides["model"].items()})
        overrides["model"] = model
    out = paths.train(seed) if name == "full" else paths.root / "ablations" / name / f"seed{seed}"
    return quickstart_config(paths, seed, overrides, output_dir=out)


def _share_stage1(paths, config, name: str, seed: int) -> None:
    source, target = paths.train(seed) / "stage1", config.stage_dir(1)
    if name in SHARED_STAGE1 and not target.exists() and (source / "run.json").is_file():
        shutil.copytree(source, target, ignore=shutil.ignore_patterns("checkpoints"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--run", type=Path, default=Path("runs/quickstart"))
    parser.add_argument("--variants", default=",".join(v for v in VARIANTS if not v.startswith("plain_")))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--name", default="ablations", help="Result file stem under benchmarks/results/.")
    args = parser.parse_args()

    from tacreasoner.evaluate.predict import load_trained, predict_items
    from tacreasoner.evaluate.report import compare_runs, evaluate
    from tacreasoner.tasks.bench import load_bench
    from tacreasoner.train.data import bench_video_root
    from tacreasoner.train.quickstart import QuickstartPaths, train_seed

    names = [v.strip() for v in args.variants.split(",") if v.strip()]
    unknown = [n for n in names if n not in VARIANTS]
    if unknown:
        parser.error(f"unknown variants {unknown}; known: {', '.join(VARIANTS)}")
    if "full" not in names:
        names.insert(0, "full")
    paths = QuickstartPaths(args.run)
    info, items = load_bench(paths.bench, "test")
    root = bench_video_root(paths.bench, info)
    reports, records, seconds = {}, {}, {}
    for name in names:
        config = _config(paths, name, args.seed)
        start = time.perf_counter()
        _share_stage1(paths, config, name, args.seed)
        trained = train_seed(config)
        preds = Path(config.output_dir) / "eval" / "test_predictions.jsonl"
        if name == "full" and (paths.evaluation / "test" / "predictions" / f"seed{args.seed}.jsonl").is_file():
            preds = paths.evaluation / "test" / "predictions" / f"seed{args.seed}.jsonl"
        model, processor = load_trained(trained["model"])
        predict_items(model, processor, items, root, preds, batch_size=48, video_cache=paths.video_cache)
        report = evaluate(items, [preds], "strict", Path(config.output_dir) / "eval")
        reports[name] = report
        records[name] = [json.loads(line) for line in
                         (Path(config.output_dir) / "eval" / "scored" / f"{preds.stem}.jsonl").read_text().splitlines()]
        seconds[name] = {"train": trained["seconds"], "total_this_call": round(time.perf_counter() - start, 1)}
        print(f"{name}: Average {100 * report.average['value']:.1f}%", flush=True)

    tasks = [t.task for t in reports["full"].tasks]
    comparisons = {n: compare_runs(records["full"], records[n], "full", n) for n in names if n != "full"}
    info_stamp = stamp()
    md = header_md("Ablations (the paper's Tables 3 and 4) on DynTAC-Sim-Bench, tiny config", info_stamp)
    md += ("DynTAC-Sim-Bench is simulated (the project's stand-in, not the paper's DynTAC-Bench). One training seed "
           f"({args.seed}) per variant; test split: {len(items)} items over held-out objects; strict extraction. "
           "Cells: accuracy % [Wilson 95% CI]; p = exact McNemar test against `full` on the same items "
           "(bold when p < 0.05). Settings: the quickstart's tiny config (configs/tiny-cpu.yaml), each variant one "
           "change; " + ", ".join(SHARED_STAGE1) + " start from the full model's Stage I (they change Stage II "
           "only).\n\n")
    head = ["Variant", *tasks, "Average", "Overall p"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name in names:
        rep = reports[name]
        by_task = {t.task: t for t in rep.tasks}
        cells = [f"**{name}**: {DESCRIPTIONS[name]}"]
        for task in tasks:
            t = by_task[task]
            cell = f"{100 * t.accuracy:.1f} [{100 * t.ci_low:.0f}–{100 * t.ci_high:.0f}]"
            if name != "full":
                p = comparisons[name].per_task[task].p_value
                cell += f" p={p:.2g}" if p >= 0.05 else f" **p={p:.2g}**"
            cells.append(cell)
        cells.append(f"{100 * rep.average['value']:.1f}")
        cells.append("–" if name == "full" else f"{comparisons[name].overall.p_value:.2g}")
        lines.append("| " + " | ".join(cells) + " |")
    md += "\n".join(lines) + "\n\nParse-failure rates (% of items whose reply is not in the strict format):\n\n"
    md += "| Variant | " + " | ".join(tasks) + " |\n|" + "---|" * (len(tasks) + 1) + "\n"
    for name in names:
        by_task = {t.task: t for t in reports[name].tasks}
        md += f"| {name} | " + " | ".join(f"{100 * by_task[t].parse_failure_rate:.0f}" for t in tasks) + " |\n"
    md += f"\nWall seconds per variant (training; this call): {json.dumps(seconds)}\n"
    payload = {**info_stamp, "seed": args.seed, "n_items": len(items), "descriptions": DESCRIPTIONS,
               "variants": {n: VARIANTS[n] for n in names},
               "reports": {n: reports[n].to_dict() for n in names},
               "mcnemar_vs_full": {n: c.to_dict() for n, c in comparisons.items()}, "seconds": seconds}
    publish(args.name, payload, md)


if __name__ == "__main__":
    main()
