"""Does the tiny LLM learn world knowledge it can compose? `tacreasoner pretrain-llm` with defaults, then
held-out questions.

Runs the real command (default settings: tokenizer + tiny Qwen2 from scratch on the commonsense
corpus), times it, and scores greedy answers to text-only questions whose object pairs / scenarios the
corpus never compares or asks about (it only states each object's and scenario's own facts):
"is X harder/softer/rougher/… than Y?", "which is …, X or Y?", and "which suits scenario S, X or Y?".
Accuracy per kind with Wilson 95% intervals against chance (0.5), plus the same kinds on trained
pairs/scenarios as a memorisation reference.

    python benchmarks/llm_knowledge.py [--out runs/bench/llm_knowledge] [--seed 0]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from collections import defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp
from tacreasoner.intervals import wilson_interval
from tacreasoner.train.pretrain_llm import KNOWLEDGE_PREDICTIONS_FILE, knowledge_check

KIND_TITLES = {
    "compare_yesno": "is X <comparative> than Y? (yes/no)",
    "compare_which": "which is <comparative>, X or Y?",
    "scenario": "which suits scenario S better, X or Y?",
}


def _by_attribute(out: Path) -> list[list]:
    """Held-out comparison accuracy per attribute (from the per-question predictions and the corpus)."""
    from tacreasoner.knowledge import build_corpus

    settings = json.loads((out / "pretrain.json").read_text())["settings"]
    corpus = build_corpus(seed=settings["seed"], holdout_fraction=settings["holdout_fraction"], **settings["corpus"])
    attribute = {q.id: q.meta.get("attribute") for q in corpus.eval_questions}
    groups: dict[str, list[bool]] = defaultdict(list)
    for line in (out / KNOWLEDGE_PREDICTIONS_FILE).read_text().splitlines():
        p = json.loads(line)
        if p["kind"].startswith("compare") and p["id"] in attribute:
            groups[attribute[p["id"]]].append(p["correct"])
    rows = []
    for a in sorted(groups):
        k, n = sum(groups[a]), len(groups[a])
        lo, hi = wilson_interval(k, n)
        rows.append([a, n, k / n, f"[{lo:.2f}, {hi:.2f}]"])
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="runs/bench/llm_knowledge")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    out = Path(args.out)
    shutil.rmtree(out, ignore_errors=True)
    load_before = os.getloadavg()[0]
    cli = [sys.executable, "-m", "tacreasoner", "pretrain-llm", "--out", str(out), "--seed", str(args.seed),
           "--no-eval"]
    t0 = time.perf_counter()
    subprocess.run(cli, check=True, env={**os.environ, "TQDM_DISABLE": "1"})
    wall = time.perf_counter() - t0
    load_after = os.getloadavg()[0]
    info = json.loads((out / "pretrain.json").read_text())
    from transformers.utils import logging as hf_logging

    hf_logging.disable_progress_bar()
    t1 = time.perf_counter()
    result = knowledge_check(out, include_seen=True)
    eval_seconds = time.perf_counter() - t1

    stamp_info = stamp()
    payload = {**stamp_info, "settings": vars(args), "pretrain_command": "tacreasoner " + " ".join(cli[3:]),
               "pretrain_wall_s": round(wall, 1), "load_average_before_after": [load_before, load_after],
               "pretrain": info, "knowledge": result, "eval_seconds": round(eval_seconds, 1)}
    rows = []
    for kind, s in result["kinds"].items():
        base = kind.removeprefix("seen_")
        which = "seen (trained pairs)" if kind.startswith("seen_") else "held out"
        rows.append([KIND_TITLES.get(base, base), which, s["n"], s["accuracy"], f"[{s['ci95'][0]:.2f}, "
                     f"{s['ci95'][1]:.2f}]", s["chance"], "yes" if s["above_chance"] else "no", s["parse_failures"]])
    md = header_md("Tiny LLM world knowledge: held-out comparisons and scenario choices", stamp_info)
    s = info["settings"]
    md += (f"`tacreasoner pretrain-llm` with default settings: byte-level BPE (vocabulary {info['vocab_size']}) and a "
           f"tiny Qwen2 ({info['parameters'] / 1e6:.1f} M parameters) trained from scratch for {s['steps']} steps of "
           f"{s['batch_size']}×{s['seq_len']} tokens ({info['tokens_seen'] / 1e6:.2f} M tokens, {info['threads']} "
           f"thread(s), bf16 autocast {'on' if s['bf16'] else 'off'}) on the commonsense corpus "
           f"({info['corpus']['documents']} documents, {info['corpus']['dialogues']} dialogues, "
           f"{info['corpus_tokens'] / 1e3:.0f} k tokens). **Command wall time {wall:.0f} s** (training loop "
           f"{info['train_seconds']:.0f} s); 1-minute load average {load_before:.1f} before, {load_after:.1f} after "
           "(the machine is shared: other jobs slow it down).\n\n"
           f"Held out: {result['heldout_pairs']} object pairs (never compared anywhere in the corpus) and scenarios "
           f"{', '.join(result['heldout_scenarios'])} (only their needs are stated). Greedy decoding, strict "
           "`<think>…</think><answer>…</answer>` extraction (a format failure counts as wrong).\n\n")
    md += md_table(["question", "items", "n", "accuracy", "95% CI", "chance", "CI above chance", "parse failures"],
                   rows)
    md += "\nHeld-out comparisons by attribute:\n\n"
    md += md_table(["attribute", "n", "accuracy", "95% CI"], _by_attribute(out))
    md += (f"\nEvaluation ({len(rows)} kinds, greedy, up to 160 new tokens) took {eval_seconds:.0f} s. Text only: no "
           "tactile data is involved in this benchmark.\n")
    publish("llm_knowledge", payload, md)


if __name__ == "__main__":
    main()
