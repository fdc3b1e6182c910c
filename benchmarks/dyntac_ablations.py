"""The paper's ablations (Tables 3/4) on DynTAC-Sim val, seed by seed against the recommended recipe, from the
folders that benchmarks/dyntac_gpu.sh leaves (``eval/<variant>.seed<S>/<split>/scored/*.jsonl``).

Writes ``benchmarks/results/<name>.{md,json}``: the recipe over its seeds on val (and on test, scored once, when
its test folders exist), then one row per ablation: Average mean ± std over seeds, its difference to the recipe,
and per seed an exact McNemar test on the same val items (the ablation and the recipe share the seed); per task;
and the answer form (replies in the asked form, replies the reply budget cut where the predictions record it, and
accuracy on the items answered in form beside the recipe's on the same items).

    python benchmarks/dyntac_ablations.py --run /tmp/dyntac_gpu --name dyntac_ablations_val \\
        --machine "one lent H100" --notes "..."

``--variant NAME=LABEL`` (repeatable) compares other scored variants against the recipe instead, e.g. shorter
training budgets (benchmarks/results/quickstart_budget_val.md).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, pct, pm, publish, stamp
from tacreasoner.evaluate.predict import cut_replies
from tacreasoner.evaluate.report import compare_runs, load_scored, summarize

RECIPE = "rec"
ABLATIONS = {
    "no_dyn": "w/o temporal branch (appearance only)",
    "no_qcond": "w/o question conditioning",
    "cot": "Stage II on TouchCoT instead of plain answers",
    "no_stage1": "w/o Stage I (Stage II from the untrained projector)",
    "no_stage2": "w/o Stage II (the recipe's Stage I model)",
}


def seeds_of(run: Path, variant: str, split: str) -> dict[int, list[dict]]:
    """Seed → score records of every scored ``variant.seedS`` folder of ``split``."""
    out = {}
    for folder in sorted(run.glob(f"eval/{variant}.seed*/{split}/scored")):
        files = sorted(folder.glob("*.jsonl"))
        if len(files) != 1:
            raise SystemExit(f"{folder}: expected one scored file, found {len(files)}")
        out[int(folder.parent.parent.name.rsplit("seed", 1)[1])] = load_scored(files[0])
    return dict(sorted(out.items()))



def recipe_table(runs: dict[int, list[dict]]) -> tuple[str, dict]:
    rep = summarize({f"seed{s}": recs for s, recs in runs.items()})
    rows = [[r.task, r.n, pm(r.mean, r.std), f"{pct(r.ci_low)}–{pct(r.ci_high)}",
             pct(r.parse_failure_rate), pct(r.chance)] for r in rep.tasks]
    rows.append(["**Average**", "", f"**{pm(rep.average['value'], rep.average['std'])}**", "", "",
                 ""])
    per_seed = ", ".join(f"seed{s} {pct(a)}" for s, a in zip(runs, rep.average["per_run"], strict=True))
    md = md_table(["task", "n", "mean ± std over seeds", "95% CI (pooled)", "parse fail", "chance"], rows)
    return md + f"\nAverage per seed: {per_seed}.\n", rep.to_dict()


def without(runs: dict[int, list[dict]], task: str | None) -> dict[int, list[dict]]:
    return {s: [r for r in recs if r["task"] != task] for s, recs in runs.items()} if task else runs


def ablation_rows(recipe: dict[int, list[dict]], variants: dict[str, str], scored: dict[str, dict[int, list[dict]]],
                  leave_out: str | None = None) -> tuple[list[list], dict]:
    """One row per variant against the recipe (``scored``: its val records by seed); ``leave_out`` drops one task
    from both sides first."""
    rows, payload = [], {}
    recipe = without(recipe, leave_out)
    base = summarize({f"seed{s}": recs for s, recs in recipe.items()})
    for variant, label in variants.items():
        runs = without(scored[variant], leave_out)
        if not runs:
            rows.append([label, "not run", "", "", ""])
            continue
        rep = summarize({f"seed{s}": recs for s, recs in runs.items()})
        tests, diffs = [], []
        for s, recs in runs.items():
            comp = compare_runs(recipe[s], recs, "recipe", variant)
            b_avg = summarize({"b": recs}).average["value"]
            a_avg = summarize({"a": recipe[s]}).average["value"]
            diffs.append(b_avg - a_avg)
            tests.append({"seed": s, "recipe": a_avg, "ablation": b_avg, "p": comp.overall.p_value,
                          "recipe_only_right": comp.overall.b10, "ablation_only_right": comp.overall.b01})
        lower = sum(t["p"] < 0.05 and t["ablation"] < t["recipe"] for t in tests)
        higher = sum(t["p"] < 0.05 and t["ablation"] > t["recipe"] for t in tests)
        verdict = (f"lower in {lower}/{len(tests)} seeds" if lower and not higher else
                   f"higher in {higher}/{len(tests)} seeds" if higher and not lower else
                   "mixed" if lower and higher else "no seed differs (p ≥ 0.05)")
        rows.append([label, f"{pm(rep.average['value'], rep.average['std'])} ({len(runs)})",
                     " / ".join(f"{100 * d:+.1f}" for d in diffs),
                     "; ".join(f"s{t['seed']} {t['p']:.2g} ({t['recipe_only_right']}↓ {t['ablation_only_right']}↑)"
                               for t in tests), verdict])
        payload[variant] = {"label": label, "report": rep.to_dict(), "per_seed": tests, "verdict": verdict}
    rows.insert(0, ["the recipe (quickstart-smollm2-cpu, with the read-out heads)",
                    f"{pm(base.average['value'], base.average['std'])} ({len(recipe)})", "–", "–",
                    "–"])
    return rows, payload


def per_task_table(recipe: dict[int, list[dict]], scored: dict[str, dict[int, list[dict]]]) -> str:
    """Per task, each scored variant's mean over its seeds beside the recipe's: which tasks an ablation moves."""
    reps = {"recipe": summarize({f"seed{s}": recs for s, recs in recipe.items()})}
    reps |= {v: summarize({f"seed{s}": recs for s, recs in runs.items()}) for v, runs in scored.items() if runs}
    means = {name: {t.task: t.mean for t in rep.tasks} for name, rep in reps.items()}
    others = [v for v in reps if v != "recipe"]
    rows = [[task, pct(base)] + [f"{pct(m)} ({100 * (m - base):+.1f})"
                                 for m in (means[v].get(task, float("nan")) for v in others)]
            for task, base in means["recipe"].items()]
    return md_table(["task", "recipe", *others], rows)


def cut_share(run: Path, variant: str, seed: int, split: str = "val") -> float | None:
    """The share of a scored run's replies that the reply budget stopped before the model ended them; None where its
    predictions do not record it (answered before evaluation recorded cuts)."""
    files = sorted((run / "eval" / f"{variant}.seed{seed}" / split / "predictions").glob("*.jsonl"))
    if len(files) != 1:
        return None
    lines = files[0].read_text(encoding="utf-8").splitlines()
    if not lines or not any('"cut":' in line for line in lines):
        return None
    return sum(cut_replies(files[0]).values()) / len(lines)


def form_table(recipe: dict[int, list[dict]], scored: dict[str, dict[int, list[dict]]],
               run: Path | None = None) -> tuple[str, dict]:
    """Per variant, the share of replies in the asked form, the share the reply budget cut (where recorded) and, on
    the items it answered in form, its accuracy beside the recipe's on the same items: does a variant lose on what it
    reads, or only on how it answers?"""
    rows, payload = [], {}
    for variant, runs in scored.items():
        if not runs:
            continue
        per_seed = []
        for s, recs in runs.items():
            base = {r["id"]: r["correct"] for r in recipe[s]}
            read = [r for r in recs if not r["parse_failed"] and r["id"] in base]
            per_seed.append({"seed": s, "in_form": len(read) / len(recs), "items": len(read),
                             "cut": None if run is None else cut_share(run, variant, s),
                             "variant": sum(r["correct"] for r in read) / max(len(read), 1),
                             "recipe": sum(base[r["id"]] for r in read) / max(len(read), 1)})
        payload[variant] = per_seed
        rows.append([variant, " / ".join(pct(p["in_form"]) for p in per_seed),
                     " / ".join("not recorded" if p["cut"] is None else pct(p["cut"]) for p in per_seed),
                     " / ".join(f"{pct(p['variant'])} vs {pct(p['recipe'])} (n {p['items']})" for p in per_seed)])
    return md_table(["variant", "replies in the asked form, per seed", "replies cut by the reply budget, per seed",
                     "accuracy on those items: variant vs recipe, per seed"], rows), payload


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, required=True, help="the unpacked dyntac_gpu.tgz (holds eval/)")
    ap.add_argument("--name", default="dyntac_ablations_val", help="result file stem under benchmarks/results")
    ap.add_argument("--machine", default="", help="where the models were trained and answered")
    ap.add_argument("--notes", default="", help="what was run, how, and what to read into it")
    ap.add_argument("--notes-file", type=Path, help="the notes from a file (long notes: the command line stays short)")
    ap.add_argument("--variant", action="append", default=[], metavar="NAME=LABEL",
                    help="compare these scored variants (eval/NAME.seedS/val) instead of the paper's ablations")
    ap.add_argument("--title", default="The paper's ablations on DynTAC-Sim val, paired by seed, on the recommended "
                                        "recipe", help="the result file's heading")
    ap.add_argument("--out-dir", type=Path, help="write the result files here instead of benchmarks/results")
    args = ap.parse_args()
    variants = dict(v.split("=", 1) for v in args.variant) if args.variant else ABLATIONS
    if args.notes_file is not None:
        args.notes = args.notes_file.read_text(encoding="utf-8").strip()
    recipe = seeds_of(args.run, RECIPE, "val")
    if not recipe:
        raise SystemExit(f"{args.run}/eval: no scored val folder of the recipe ({RECIPE}.seedS/val/scored)")
    info = stamp()
    md = header_md(args.title, info)
    md += (f"- Trained and answered on: {args.machine}\n\n" if args.machine else "") + (
        args.notes + "\n\n" if args.notes else "")
    md += ("DynTAC-Sim-Bench is simulated: the project's stand-in for the paper's DynTAC-Bench. Strict extraction "
           "(a reply not in the asked `<answer>…</answer>` form counts as wrong). Every choice below is read on "
           "**val**; the recipe's test row is its one scoring on test and chose nothing.\n\n")
    md += f"## The recipe on val, {len(recipe)} seeds\n\n"
    table, rec_payload = recipe_table(recipe)
    md += table
    payload: dict = {**info, "machine_trained": args.machine, "notes": args.notes, "recipe_val": rec_payload}
    test = seeds_of(args.run, RECIPE, "test")
    if test:
        table, payload["recipe_test"] = recipe_table(test)
        md += f"\n## The recipe on test (scored once, {len(test)} seeds)\n\n" + table
    # each variant's val records read once, for the tables below
    scored = {v: {s: recs for s, recs in seeds_of(args.run, v, "val").items() if s in recipe} for v in variants}
    rows, payload["ablations"] = ablation_rows(recipe, variants, scored)
    md += ("\n## " + ("Ablations on val (the paper's Tables 3/4)" if variants is ABLATIONS else "Variants on val")
           + "\n\nAverage: mean ± std over seeds (seeds). Δ: the "
           "ablation's Average minus the recipe's, per seed. p: exact McNemar over all val items per seed (↓ items "
           "only the recipe answers right, ↑ only the ablation). Verdict: seeds whose difference is significant "
           "(p < 0.05), by direction.\n\n")
    md += md_table(["model", "Average (val)", "Δ per seed (points)", "p per seed", "verdict"], rows)
    if "TSA" in {r["task"] for recs in recipe.values() for r in recs}:
        rows, payload["ablations_without_TSA"] = ablation_rows(recipe, variants, scored, leave_out="TSA")
        md += ("\n### The same without TSA\n\nTSA (scenario choice) is zero-shot, never trained on: its score is "
               "mostly whether a reply gives the option's letter (strict extraction), which swings by seed (the "
               "recipe's TSA row above: its std over seeds). A sensitivity check, not the paper's metric: the "
               "Average over the other ten tasks, the same tests on their items.\n\n")
        md += md_table(["model", "Average w/o TSA (val)", "Δ per seed (points)", "p per seed", "verdict"], rows)
    md += ("\n## Per task on val\n\nMean over seeds (the variant minus the recipe, points); a task's n is in the "
           "recipe's table above, so one item of 75 is 1.3 points of one seed.\n\n")
    md += per_task_table(recipe, scored)
    table, payload["answer_form"] = form_table(recipe, scored, args.run)
    md += ("\n## Answer form on val\n\nA reply outside the asked form scores wrong under strict extraction; so "
           "does one the reply budget (`--max-new-tokens`) stopped before the model ended it. Where a variant "
           "answers in form, does it read the touch as well as the recipe does on the same items?\n\n"
           + table)
    publish(args.name, payload, md, args.out_dir)


if __name__ == "__main__":
    main()
