"""DynTAC-Sim val asked in the benchmark's wordings and in held-out wordings no training used, on the same items,
seed by seed (issue 37, point 7: does the model answer the question a user asks, or only the templates it saw?).

Each ``--seed S=TEMPLATE:HELDOUT`` names two scored files of one model (``tacreasoner evaluate`` writes
``<out>/scored/val.jsonl``): val in the benchmark's wordings, and val of ``tacreasoner paraphrase-bench`` (the
same items, ids suffixed ``-heldout``; tasks without a held-out wording are left out there, so the template side is
cut to the same items). Writes ``benchmarks/results/<name>.{md,json}``: per task accuracy in both wordings, the
share of replies in the asked form (strict extraction found a value of the asked kind: 100 − parse failures), the
share of checkable reasoning that contradicts itself or the question, and per seed an exact McNemar test.

    python benchmarks/dyntac_wordings.py --seed 0=runs/eval_val/scored/val.jsonl:runs/eval_heldout/scored/val.jsonl
"""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, pct, pm, publish, stamp
from tacreasoner.evaluate.report import Report, compare_runs, load_scored, summarize

SUFFIX = re.compile(r"-heldout\d*$")
"""What ``paraphrase-bench`` appends to an item's id (``-heldout``, ``-heldout2``, …)."""


def paired_records(template: Path, heldout: Path) -> tuple[list[dict], list[dict]]:
    """The template records of the items the held-out file asks, and the held-out records under the same ids."""
    held = [{**r, "id": SUFFIX.sub("", r["id"])} for r in load_scored(heldout)]
    asked = {r["id"] for r in held}
    base = [r for r in load_scored(template) if r["id"] in asked]
    if len(base) != len(held):
        missing = sorted(asked - {r["id"] for r in base})
        raise SystemExit(f"{template}: lacks {len(missing)} of the held-out items, e.g. {missing[:3]} "
                         f"(both files must score the same benchmark's split)")
    return base, held



def checked(rep: Report, task: str | None = None) -> str:
    """Contradicting replies among those with reasoning to check, or why none could be checked."""
    if task is None:
        n, k = rep.overall["n_checkable"], rep.overall["n_hallucinated"]
    else:
        row = next(r for r in rep.tasks if r.task == task)
        n, k = row.n_checkable, row.n_hallucinated
    return "no reasoning" if n == 0 else f"{100 * k / n:.1f} of {n}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", action="append", required=True, metavar="S=TEMPLATE:HELDOUT",
                    help="one model's scored val files in the benchmark's and in held-out wordings")
    ap.add_argument("--name", default="dyntac_wordings_val", help="result file stem under benchmarks/results")
    ap.add_argument("--machine", default="", help="where the models were trained and answered")
    ap.add_argument("--notes", default="", help="what was run and how")
    ap.add_argument("--wording", default="heldout", help="the held-out set asked (tasks/paraphrases/<it>.yaml)")
    args = ap.parse_args()
    pairs = {}
    for spec in args.seed:
        seed, _, files = spec.partition("=")
        template, _, heldout = files.partition(":")
        if not (seed.isdigit() and template and heldout):
            raise SystemExit(f"--seed {spec!r}: expected S=TEMPLATE_SCORED.jsonl:HELDOUT_SCORED.jsonl")
        pairs[int(seed)] = paired_records(Path(template), Path(heldout))
    base = summarize({f"seed{s}": b for s, (b, _) in pairs.items()})
    held = summarize({f"seed{s}": h for s, (_, h) in pairs.items()})
    tests = []
    for s, (b, h) in pairs.items():
        comp = compare_runs(b, h, "benchmark wordings", "held-out wordings")
        tests.append({"seed": s, "p": comp.overall.p_value, "template_only_right": comp.overall.b10,
                      "heldout_only_right": comp.overall.b01,
                      "per_task_p": {t: r.p_value for t, r in comp.per_task.items()}})
    rows = []
    for b_row, h_row in zip(base.tasks, held.tasks, strict=True):
        rows.append([b_row.task, b_row.n, pm(b_row.mean, b_row.std), pm(h_row.mean, h_row.std),
                     pct(1 - b_row.parse_failure_rate), pct(1 - h_row.parse_failure_rate), checked(held, h_row.task),
                     pct(b_row.chance)])
    rows.append(["**Average**", "", f"**{pm(base.average['value'], base.average['std'])}**",
                 f"**{pm(held.average['value'], held.average['std'])}**", "", "", checked(held), ""])
    info = stamp()
    md = header_md("DynTAC-Sim val in the benchmark's wordings and in held-out wordings, same items", info)
    md += (f"- Trained and answered on: {args.machine}\n" if args.machine else "") + (
        f"- Notes: {args.notes}\n" if args.notes else "") + f"- Seeds: {', '.join(map(str, pairs))}; split: val\n\n"
    md += (f"Held-out wordings: `tasks/paraphrases/{args.wording}.yaml`, never used in training (`tacreasoner "
           "paraphrase-bench`); tasks without one are left out, and the benchmark-wording column is cut to the same "
           "items. Asked form: strict extraction found a value of the asked kind in `<answer>…</answer>`. "
           "Contradicts: replies whose reasoning names another object or concludes another value than their answer, "
           "among the replies with reasoning to check.\n\n")
    md += md_table(["task", "n", "benchmark wordings (%)", "held-out wordings (%)", "asked form, benchmark (%)",
                    "asked form, held-out (%)", "contradicts, held-out (%)", "chance"], rows)
    md += "\nPaired per seed (exact McNemar, all items): " + "; ".join(
        f"seed {t['seed']} p = {t['p']:.2g} ({t['template_only_right']} right only in the benchmark's wordings, "
        f"{t['heldout_only_right']} only in held-out)" for t in tests) + ".\n"
    payload = {**info, "machine_trained": args.machine, "notes": args.notes, "split": "val", "wording": args.wording,
               "benchmark_wordings": base.to_dict(), "heldout_wordings": held.to_dict(), "paired": tests}
    publish(args.name, payload, md)


if __name__ == "__main__":
    main()
