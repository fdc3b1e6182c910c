"""Summarise the SmolLM2 recipe chosen on val (``benchmarks/gpu_smollm2.sh ... part 2 sweep``) into one results file.

Reads ``<run>/eval/<name>/<split>/scored/<split>.jsonl`` and ``<run>/results/sweep_choice.json`` and writes:

- the Stage II candidates on **val** (all from seed 0's Stage I) and which one ``choose_on_val.py`` picked;
- the chosen recipe over three seeds on val and on test (test answered once, after the choice; seed 0's val is the
  run it was chosen on, so optimistic);
- TouchCoT against plain answers on the same three Stage I models (the paper's "w/o TouchCoT" ablation, paired
  exact McNemar per seed), and the Stage I models without Stage II (seeds 1, 2);
- TSA (never trained on) under strict and lenient extraction, with the Wilson lower bound against chance.

    python benchmarks/smollm2_recipe_summary.py --run /work/gpu_sweep/run --machine "..." --command "..."
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp
from smollm2_summary import _lenient_tsa, _records
from tacreasoner.evaluate.report import compare_runs, summarize
from tacreasoner.intervals import wilson_interval

CANDIDATES = {
    "plain_s500": "plain answers, 500 steps",
    "plain_r16": "plain answers, LoRA r16 (α 32)",
    "plain_lr1e-4": "plain answers, lr 1e-4",
    "plain": "plain answers (r128, lr 2e-4, 1000 steps)",
    "plain_lr5e-4": "plain answers, lr 5e-4",
    "cot": "TouchCoT, the paper's settings (r128, lr 2e-4, 1000 steps)",
    "cot_lr5e-4": "TouchCoT, lr 5e-4",
}


def _seeds(name: str) -> list[str]:
    return [name, f"{name}.seed1", f"{name}.seed2"]


def _tsa(run: Path, name: str, split: str, bench: Path) -> dict:
    correct, n = _lenient_tsa(run, name, split, bench)
    strict = next(r for r in summarize({name: _records(run, name, split)}).tasks if r.task == "TSA")
    s_correct = round(strict.accuracy * strict.n)
    return {"n": n, "strict_correct": s_correct, "lenient_correct": correct,
            "strict_wilson": wilson_interval(s_correct, n), "lenient_wilson": wilson_interval(correct, n)}


def _pct(x: float) -> str:
    return f"{100 * x:.1f}"


def _finite(x: float | None) -> float | None:
    return None if x is None or x != x else x


def _halluc(rate: float | None) -> str:
    """Plain answers give no reasoning to check: no rate, not 0%."""
    return "– (no reasoning)" if rate is None or rate != rate else _pct(rate)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, required=True, help="folder holding eval/ and results/sweep_choice.json")
    ap.add_argument("--bench", type=Path, default=Path("runs/quickstart/bench"))
    ap.add_argument("--name", default="smollm2_recipe")
    ap.add_argument("--machine", default="")
    ap.add_argument("--command", default="")
    args = ap.parse_args()
    run, bench = args.run, args.bench
    choice = json.loads((run / "results" / "sweep_choice.json").read_text())
    winner = choice["winner"]
    info = stamp()
    md = header_md("SmolLM2-135M-Instruct: the recipe chosen on val", info)
    md += (f"- Trained and evaluated on: {args.machine}\n- By: `{args.command}`\n- Data: DynTAC-Sim-Bench "
           "(simulated, not the paper's DynTAC-Bench), held-out objects, strict extraction unless said; the LLM's "
           "weights came through 4-bit (Q4_1) GGUF quantisation.\n\n")
    payload: dict = {**info, "trained_on": args.machine, "run_command": args.command, "choice": choice}

    # 1. the choice, on val only
    md += ("## 1. Choosing Stage II on val\n\nEvery candidate continues seed 0's Stage I (1000 steps) for 1000 "
           "Stage II steps unless said, and answers **val** only. `benchmarks/choose_on_val.py` takes the highest "
           "val average; a candidate within 1 point of it counts as tied and the cheapest of the tied ones wins "
           "(the order below). Test was not read until the choice was made.\n\n")
    rows, cands = [], {}
    for name, label in CANDIDATES.items():
        rep = summarize({name: _records(run, name, "val")})
        tsa = _tsa(run, name, "val", bench)
        cands[name] = {"label": label, "val_average": rep.average["value"], "val_items": rep.overall["accuracy"],
                       "hallucination_rate": _finite(rep.overall.get("hallucination_rate")), "tsa": tsa}
        rows.append([("**" + label + "** (chosen)") if name == winner else label, _pct(rep.average["value"]),
                     _pct(rep.overall["accuracy"]), _halluc(rep.overall.get("hallucination_rate")),
                     f"{tsa['strict_correct']}/{tsa['n']}", f"{tsa['lenient_correct']}/{tsa['n']}"])
    md += md_table(["Stage II candidate", "val Average", "val items", "Halluc. %", "TSA strict", "TSA lenient"], rows)
    payload["candidates"] = cands

    # 2. the chosen recipe, three seeds
    chosen = {s: _records(run, s, "val") for s in _seeds(winner)}
    payload["chosen"] = {}
    md += (f"\n## 2. The chosen recipe ({CANDIDATES[winner]}), three seeds\n\nSeeds 1 and 2 have their own "
           "Stage I. Seed 0's val is the run the recipe was chosen on (optimistic); seeds 1 and 2 are fresh on val. "
           "Test was answered once, after the choice.\n\n")
    for split in ("val", "test"):
        report = summarize({s: _records(run, s, split) for s in _seeds(winner)})
        payload["chosen"][split] = report.to_dict()
        md += f"### {split}\n\n" + report.to_markdown().split("\n", 2)[2].lstrip() + "\n"
    del chosen

    # 3. TouchCoT vs plain answers, and no Stage II, on the same Stage I models
    md += ("\n## 3. The paper's ablations on three seeds: TouchCoT vs plain answers, Stage II or not\n\n"
           "The same Stage I model per seed; p: exact McNemar over all 780 items (↓ items TouchCoT answers right and "
           "the other wrong, ↑ the reverse). The paper: TouchCoT helps, both stages are needed.\n\n")
    rows, ablation = [], {}
    for split in ("val", "test"):
        for seed, (cot, plain) in enumerate(zip(_seeds("cot"), _seeds("plain"), strict=True)):
            a, b = _records(run, cot, split), _records(run, plain, split)
            comp = compare_runs(a, b, cot, plain)
            ra, rb = summarize({cot: a}), summarize({plain: b})
            ablation[f"{split}/seed{seed}/no_cot"] = {"touchcot": ra.average["value"], "plain": rb.average["value"],
                                                      "p": comp.overall.p_value}
            rows.append([split, seed, "plain answers (w/o TouchCoT)", _pct(ra.average["value"]),
                         _pct(rb.average["value"]), f"{comp.overall.p_value:.2g} ({comp.overall.b10}↓ "
                                                    f"{comp.overall.b01}↑)"])
        for seed in (1, 2):
            name = f"no_stage2.seed{seed}"
            if not (run / "eval" / name / split).is_dir():
                continue
            a, b = _records(run, f"cot.seed{seed}", split), _records(run, name, split)
            comp = compare_runs(a, b, f"cot.seed{seed}", name)
            ra, rb = summarize({"a": a}), summarize({"b": b})
            ablation[f"{split}/seed{seed}/no_stage2"] = {"touchcot": ra.average["value"],
                                                         "stage1_only": rb.average["value"],
                                                         "p": comp.overall.p_value}
            rows.append([split, seed, "w/o Stage II (Stage I model)", _pct(ra.average["value"]),
                         _pct(rb.average["value"]), f"{comp.overall.p_value:.2g} ({comp.overall.b10}↓ "
                                                    f"{comp.overall.b01}↑)"])
    md += md_table(["split", "seed", "ablation", "TouchCoT Average", "ablation Average", "p vs TouchCoT"], rows)
    payload["ablations"] = ablation

    # 4. TSA zero-shot
    md += ("\n## 4. TSA (zero-shot: never trained on), test\n\nChance 50% (two options). Above chance means the "
           "Wilson 95% lower bound is over 50%. Strict reads a letter only; lenient also an option's text.\n\n")
    rows, tsa_payload = [], {}
    for name in [*_seeds(winner), *_seeds("plain"), *_seeds("cot")]:
        t = _tsa(run, name, "test", bench)
        tsa_payload[name] = t
        rows.append([name, f"{_pct(t['strict_correct'] / t['n'])} [{_pct(t['strict_wilson'][0])}–"
                           f"{_pct(t['strict_wilson'][1])}]",
                     f"{_pct(t['lenient_correct'] / t['n'])} [{_pct(t['lenient_wilson'][0])}–"
                     f"{_pct(t['lenient_wilson'][1])}]",
                     "yes" if max(t["strict_wilson"][0], t["lenient_wilson"][0]) > 0.5 else "no"])
    md += md_table(["model", "strict % [Wilson 95%]", "lenient % [Wilson 95%]", "above chance"], rows)
    payload["tsa_test"] = tsa_payload

    # 5. the short recipe sized for 2 CPU cores
    if (run / "eval" / "cpu60" / "val").is_dir():
        rep = summarize({"cpu60": _records(run, "cpu60", "val")})
        payload["cpu60_val"] = rep.average["value"]
        md += (f"\n## 5. A short recipe sized for 2 CPU cores\n\nStage I 300 steps, Stage II 600 steps on plain "
               f"answers (r128, lr 2e-4), seed 0, on the GPU: val Average **{_pct(rep.average['value'])}%** (the "
               f"1000 + 1000-step plain recipe: {_pct(cands['plain']['val_average'])}%). Its time on 2 CPU cores: "
               "smollm2_cpu_recipe.md.\n")
    publish(args.name, payload, md)


if __name__ == "__main__":
    main()
