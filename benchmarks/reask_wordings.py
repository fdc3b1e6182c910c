"""Which of the benchmark's own wordings a person's question is best asked again in: every val comparison and
real-or-fake item asked in each trained template of its kind, and the majority over them, on the same items.

`auto` asks a person's comparison (SFD, SOI) or real-or-fake question (RFOR) again in a benchmark wording, one pass
(`evaluate.stepwise.reasked_question`). Which wording is a choice, made here on val in the benchmark's own wordings
(no held-out wording set is read): each item's slots rendered in every template of its kind (SFD "which" items in
the three "which" templates, and so on), answered by each model, scored strictly. Also the majority of the three
parsed answers (ties: the plainest template's answer). Items differ between templates in the benchmark itself, so
only this same-items comparison says which wording the model answers best.

**Rule, fixed before the run**: per kind (SFD which, SFD yes/no, SOI, RFOR), the strategy (one template, or the
majority) with the highest mean accuracy over seeds; the majority wins ties (it does not rest on one wording).

    python benchmarks/reask_wordings.py --bench runs/qs_stepwise/bench --out runs/reask_tpl \\
        --models runs/qs_stepwise/model runs/qs_stepwise/train/seed{1,2}/stage2/model
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import subprocess
import sys
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, portable, publish, stamp
from tacreasoner.tasks.bench import BENCH_INFO, load_bench
from tacreasoner.tasks.formats import write_jsonl
from tacreasoner.tasks.schema import QAItem
from tacreasoner.tasks.templating import load_templates

KINDS = {"SFD which": "sfd_which", "SFD yesno": "sfd_yesno", "SOI": "soi", "RFOR": "rfor"}
MAJORITY = "majority"


def kind_of(item: QAItem) -> str | None:
    if item.task == "SFD":
        return "SFD yesno" if item.answer in ("yes", "no") else "SFD which"
    return item.task if item.task in ("SOI", "RFOR") else None


def asked_in_every_template(items: list[QAItem]) -> list[QAItem]:
    """Each comparison and real-or-fake item once per template of its kind (id ``<id>@<template>``)."""
    templates = load_templates()
    out = []
    for item in items:
        kind = kind_of(item)
        if kind is None:
            continue
        for template in templates[KINDS[kind]]:
            out.append(dataclasses.replace(item, id=f"{item.id}@{template.id}",
                                           question=template.render(**item.meta["slots"]),
                                           meta={**item.meta, "template": template.id}))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bench", type=Path, required=True)
    ap.add_argument("--models", type=Path, nargs="+", required=True, help="one trained model per seed")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--dtype", default="float32")
    args = ap.parse_args()
    info = stamp()
    bench = args.out / "bench"
    if not (bench / "val.jsonl").is_file():
        _, items = load_bench(args.bench, "val")
        asked = asked_in_every_template(items)
        bench.mkdir(parents=True, exist_ok=True)
        write_jsonl(asked, bench / "val.jsonl")
        meta = json.loads((args.bench / BENCH_INFO).read_text())
        meta.update(name=f"{meta.get('name')}, comparisons in every template",
                    counts={"val": dict(Counter(i.task for i in asked))})
        (bench / BENCH_INFO).write_text(json.dumps(meta, indent=2))
    plainest = {"SFD which": "sfd_which_plain", "SFD yesno": "sfd_yesno_plain", "SOI": "soi_plain",
                "RFOR": "rfor_plain"}
    results: dict[str, dict[str, dict[str, float]]] = {}
    n_items: dict[str, int] = {}
    for seed, model in enumerate(args.models):
        out = args.out / f"seed{seed}"
        if not (out / "report.json").is_file():
            cmd = [sys.executable, "-m", "tacreasoner", "evaluate", "--model", str(model), "--bench", str(bench),
                   "--split", "val", "--out", str(out), "--dtype", args.dtype]
            print("$", " ".join(cmd), flush=True)
            subprocess.run(cmd, check=True)
        records = [json.loads(line) for line in (out / "scored" / "val.jsonl").read_text().splitlines() if line]
        gold = {i.id: i for i in load_bench(bench, "val")[1]}
        by_item: dict[str, dict[str, dict]] = defaultdict(dict)
        for r in records:
            base, template = r["id"].split("@")
            by_item[base][template] = r
        right: dict[str, dict[str, list[bool]]] = defaultdict(lambda: defaultdict(list))
        for answers in by_item.values():
            kind = kind_of(gold[next(iter(answers.values()))["id"]])
            for template, r in answers.items():
                right[kind][template].append(bool(r["correct"]))
            parsed = [json.dumps(r["parsed"]) for r in answers.values() if not r["parse_failed"]]
            counts = Counter(parsed)
            top = max(counts.values()) if counts else 0
            tied = [p for p, c in counts.items() if c == top]
            first = answers.get(plainest[kind])
            choice = (json.dumps(first["parsed"]) if first and json.dumps(first["parsed"]) in tied else
                      (sorted(tied)[0] if tied else None))
            majority = next((r["correct"] for r in answers.values() if json.dumps(r["parsed"]) == choice), False)
            right[kind][MAJORITY].append(bool(majority))
        results[f"seed{seed}"] = {k: {t: 100 * float(np.mean(v)) for t, v in ts.items()} for k, ts in right.items()}
        n_items.update({k: len(ts[MAJORITY]) for k, ts in right.items()})
        print(f"seed {seed}:", json.dumps(results[f"seed{seed}"]), flush=True)

    chosen: dict[str, str] = {}
    rows = []
    for kind in KINDS:
        strategies = [*(t.id for t in load_templates()[KINDS[kind]]), MAJORITY]
        means = {s: float(np.mean([results[seed][kind][s] for seed in results])) for s in strategies}
        best = max(means.values())
        chosen[kind] = MAJORITY if means[MAJORITY] == best else max(means, key=lambda s: means[s])
        for s in strategies:
            values = [results[seed][kind][s] for seed in results]
            rows.append([kind, s, str(n_items[kind]), *[f"{v:.1f}" for v in values],
                         (f"**{means[s]:.1f}**" if s == chosen[kind] else f"{means[s]:.1f}") +
                         (f" ± {np.std(values, ddof=1):.1f}" if len(values) > 1 else "")])
    data = {**info, "bench": portable(str(args.bench)), "models": [portable(str(m)) for m in args.models],
            "split": "val", "dtype": args.dtype, "results": results, "chosen": chosen}
    md = header_md("Asking again in the benchmark's own wordings: which one (val, same items)", info)
    md += ("Every val SFD, SOI and RFOR item asked in each trained template of its kind (the same items in each), "
           f"answered by the quickstart's models ({', '.join(f'`{portable(str(m))}`' for m in args.models)}), "
           f"weights {args.dtype}, strict extraction; `majority`: the most common of the three parsed answers (a tie "
           "goes to the plainest template's). No held-out wording is read. Rule fixed before the run: per kind the "
           "strategy with the highest mean over seeds, the majority winning ties; chosen in bold.\n\n")
    md += md_table(["kind", "asked in", "items", *results, "mean ± sd"], rows)
    md += "\nChosen: " + "; ".join(f"{k} → `{v}`" for k, v in chosen.items()) + "\n"
    publish("reask_wordings_val", data, md)


if __name__ == "__main__":
    main()
