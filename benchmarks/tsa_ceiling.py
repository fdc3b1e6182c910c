"""How far can an LLM take zero-shot TSA when perception is perfect? The TSA items with every video replaced by words.

TSA asks which of two touched objects suits a scenario ("scraping frost off a car windscreen"). A model needs two
things: what each object feels like (perception) and which property the scenario needs (the LLM's commonsense).
This benchmark removes the first: each ``<tactile>`` placeholder of a TSA item becomes the object's gold levels in
the benchmark's own phrases ("an object with extremely hard hardness, slight friction, ..."), and the LLM, as
shipped (no tactile training, no LoRA), answers the text. Three conditions per item:

- ``none``: the placeholders become "an object" (no perception at all: chance by construction);
- ``needed``: only the attributes the scenario depends on are described (the easiest text);
- ``all``: all four attributes are described (the model must pick the relevant ones itself).

Each is answered three ways: greedy generation scored by the project's TSA scorer (strict reads a letter, lenient
also the option text); the log-probabilities of "A" and "B" as the reply's first token (no format to learn); and
those of " first" and " second" after "The" (how this LLM opens such answers: "The first object is better ...").
Accuracy with Wilson 95% intervals; chance is 50%. An LLM that cannot choose above chance from the gold words gives a
tactile model built on it nothing to reach TSA with zero-shot, unless its training also teaches the commonsense.

    python benchmarks/tsa_ceiling.py --llm runs/smollm2 --bench runs/quickstart/bench [--splits val,test]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp

CONDITIONS = ("none", "needed", "all")
PLACEHOLDER = "<tactile>"


def describe(levels: dict[str, int], vocabulary: str) -> str:
    """``an object (hardness: extremely hard; friction: slight friction)`` from gold levels (benchmark phrases)."""
    from tacreasoner.tasks.vocab import get_vocabulary

    vocab = get_vocabulary(vocabulary)
    return "an object (" + "; ".join(f"{a}: {vocab[a].phrase(r)}" for a, r in levels.items()) + ")"


def textual_question(item, condition: str, labels: dict[str, dict]) -> str:
    """The item's question with each placeholder replaced by the condition's description of that video (a QAItem
    holds exactly one placeholder per video)."""
    question = item.question
    for k, video in enumerate(item.videos):
        if condition == "none":
            words = "an object"
        elif condition == "needed":
            words = describe(item.meta["ranks"][k], item.vocabulary)
        else:
            words = describe(labels[video.clip_id][item.vocabulary], item.vocabulary)
        question = question.replace(PLACEHOLDER, words, 1)
    return question


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--llm", type=Path, default=Path("runs/smollm2"), help="a Hugging Face causal LM folder")
    ap.add_argument("--bench", type=Path, default=Path("runs/quickstart/bench"))
    ap.add_argument("--splits", default="val,test")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--max-new-tokens", type=int, default=48)
    ap.add_argument("--name", default="tsa_ceiling")
    args = ap.parse_args()

    import torch
    from transformers import AutoModelForCausalLM, AutoTokenizer

    from tacreasoner.intervals import wilson_interval
    from tacreasoner.jsonl import iter_jsonl
    from tacreasoner.tasks.bench import load_bench
    from tacreasoner.tasks.scoring import score_item
    from tacreasoner.train.data import bench_video_root

    torch.set_num_threads(args.threads)
    info = stamp()
    tokenizer = AutoTokenizer.from_pretrained(args.llm)
    model = AutoModelForCausalLM.from_pretrained(args.llm, dtype=torch.float32).eval()
    letter_ids = [tokenizer.encode(x, add_special_tokens=False) for x in ("A", "B")]
    ordinal_ids = [tokenizer.encode(x, add_special_tokens=False) for x in (" first", " second")]
    if any(len(ids) != 1 for ids in (*letter_ids, *ordinal_ids)):
        raise SystemExit(f"{args.llm}: 'A', 'B', ' first' and ' second' are not single tokens in its tokenizer")
    opening = tokenizer("The", return_tensors="pt", add_special_tokens=False).input_ids
    start = time.perf_counter()
    results: dict[str, dict] = {}
    examples: dict[str, list] = {}
    for split in [s.strip() for s in args.splits.split(",") if s.strip()]:
        bench_info, items = load_bench(args.bench, split)
        items = [it for it in items if it.task == "TSA"]
        if not items:
            raise SystemExit(f"{args.bench}/{split}.jsonl: no TSA items")
        manifest = bench_video_root(args.bench, bench_info) / "manifest.jsonl"
        labels = {row["clip_id"]: row["labels"] for _, row in iter_jsonl(manifest)}
        for condition in CONDITIONS:
            right = {"strict": 0, "lenient": 0, "logprob": 0, "ordinal": 0}
            for item in items:
                messages = [{"role": "user", "content": textual_question(item, condition, labels)}]
                prompt = tokenizer.apply_chat_template(messages, tokenize=False, add_generation_prompt=True)
                ids = tokenizer(prompt, return_tensors="pt", add_special_tokens=False).input_ids
                with torch.no_grad():
                    logits = model(ids).logits[0, -1]
                    after_the = model(torch.cat([ids, opening], dim=1)).logits[0, -1]
                    out = model.generate(ids, max_new_tokens=args.max_new_tokens, do_sample=False,
                                         pad_token_id=tokenizer.eos_token_id)
                reply = tokenizer.decode(out[0, ids.shape[1]:], skip_special_tokens=True).strip()
                pick = "AB"[int(logits[letter_ids[1][0]] > logits[letter_ids[0][0]])]
                right["logprob"] += pick == item.gold["letter"]
                ordinal = "AB"[int(after_the[ordinal_ids[1][0]] > after_the[ordinal_ids[0][0]])]
                right["ordinal"] += ordinal == item.gold["letter"]
                for mode in ("strict", "lenient"):
                    right[mode] += score_item(item, reply, mode).correct
                if len(examples.setdefault(f"{split}/{condition}", [])) < 3:
                    examples[f"{split}/{condition}"].append({"id": item.id, "question": messages[0]["content"],
                                                             "reply": reply, "gold": item.gold["letter"]})
            n = len(items)
            results[f"{split}/{condition}"] = {
                "split": split, "condition": condition, "n": n,
                **{mode: {"correct": k, "accuracy": k / n, "wilson": list(wilson_interval(k, n))}
                   for mode, k in right.items()}}
            print(f"{split} {condition}: " + ", ".join(f"{m} {k}/{n}" for m, k in right.items()), flush=True)
    seconds = time.perf_counter() - start

    rows = []
    for r in results.values():
        cells = []
        for mode in ("strict", "lenient", "logprob", "ordinal"):
            low, high = r[mode]["wilson"]
            cells.append(f"{100 * r[mode]['accuracy']:.1f} [{100 * low:.0f}–{100 * high:.0f}]"
                         + (" ✓" if low > 0.5 else ""))
        rows.append([r["split"], r["condition"], r["n"], *cells])
    md = header_md("Zero-shot TSA with perfect perception: the LLM alone, answering from the gold words", info)
    md += (f"LLM: `{args.llm}` as shipped (no tactile training, no adapter); {args.threads} thread(s); greedy, up to "
           f"{args.max_new_tokens} new tokens; {seconds:.0f} s in all. Items: DynTAC-Sim-Bench TSA (held-out "
           "objects), each `<tactile>` replaced by words (conditions in the script's docstring). Chance 50%; ✓: the "
           "Wilson 95% lower bound is above it. Strict reads a letter only, lenient also the option text; "
           "logprob A/B compares the next-token log-probabilities of `A` and `B`; first/second those of ` first` and "
           "` second` after `The`.\n\n")
    md += md_table(["split", "condition", "n", "strict % [95%]", "lenient % [95%]", "logprob A/B % [95%]",
                    "logprob first/second % [95%]"], rows)
    md += "\nExamples (first items of each condition):\n\n"
    for key, shown in examples.items():
        for ex in shown[:1]:
            md += f"- {key}: `{ex['question']!s}` → `{ex['reply']}` (gold {ex['gold']})\n"
    publish(args.name, {**info, "llm": str(args.llm), "bench": str(args.bench), "seconds": round(seconds, 1),
                        "results": results, "examples": examples}, md)
    print(json.dumps({k: [v[m]["accuracy"] for m in ("logprob", "ordinal")] for k, v in results.items()}))


if __name__ == "__main__":
    main()
