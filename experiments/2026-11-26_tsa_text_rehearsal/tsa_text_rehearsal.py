"""Can SmolLM2-135M *learn* TSA's commonsense from text? LoRA on the commonsense corpus, then TSA with gold words.

``tsa_ceiling.py`` found that SmolLM2-135M-Instruct as shipped cannot choose between two objects for a scenario
even when told their gold levels (64% at best, through log-probabilities only; 0% strict). Zero-shot TSA through a
tactile model is then out of reach unless training also teaches the commonsense. This benchmark asks whether text
can teach it: a LoRA adapter (the Stage II shape: r16 on q/k/v/o) is trained on the project's commonsense corpus
(``tacreasoner.knowledge``: object facts, what each scenario needs, comparisons and scenario choices between *named*
objects, with short reasoning; a fifth of the scenarios are held out: the corpus states their needs but no choice
involving them), and the result answers

- the corpus's held-out scenario questions (named objects, held-out scenarios): did it learn to compose?
- the DynTAC-Sim-Bench TSA items with each video replaced by the object's gold levels in words (``tsa_ceiling``'s
  ``needed`` and ``all`` conditions): does it carry over to TSA's own wording, which it never saw?

Each TSA item is answered twice, in its order and with the two descriptions swapped (the gold letter swaps too):
a model reading the words flips its letter; one answering from the wording does not (``tsa_swap.py``). No tactile
data and no TSA item is trained on; only the val split is used by default (choices are made on val).

    python benchmarks/tsa_text_rehearsal.py --llm runs/smollm2 --bench runs/quickstart/bench --steps 150
"""

from __future__ import annotations

import argparse
import json
import random
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp
from tsa_ceiling import textual_question
from tsa_swap import swapped

MIX = {"scenario": 0.6, "need": 0.15, "compare": 0.25, "documents": 0.0}
"""Share of each corpus family in a batch: scenario choices carry the skill asked for; ``documents`` (plain text,
loss on every token) are the only place the held-out scenarios' needs are stated (``--documents``)."""


def family(dialogue: list[dict[str, str]]) -> str:
    """Which corpus family a dialogue belongs to, read from its reasoning (scenario choices score both objects)."""
    reply = dialogue[-1]["content"]
    if " suits it " in reply:
        return "scenario"
    if "an object should be" in reply:
        return "need"
    return "compare"


def encode(tokenizer, messages: list[dict[str, str]] | str, max_length: int) -> tuple[list[int], list[int]]:
    """Token ids of a whole dialogue and its labels (−100 outside the assistant's reply: loss on the answer only);
    a document (plain text) is learnt whole."""
    if isinstance(messages, str):
        ids = tokenizer(messages + tokenizer.eos_token, add_special_tokens=False).input_ids[:max_length]
        return ids, list(ids)
    prompt = tokenizer.apply_chat_template(messages[:-1], tokenize=False, add_generation_prompt=True)
    full = tokenizer.apply_chat_template(messages, tokenize=False)
    p_ids = tokenizer(prompt, add_special_tokens=False).input_ids
    ids = tokenizer(full, add_special_tokens=False).input_ids[:max_length]
    return ids, [-100] * min(len(p_ids), len(ids)) + ids[len(p_ids):]


def generate(model, tokenizer, prompts: list[list[dict[str, str]]], max_new_tokens: int, batch: int) -> list[str]:
    """Greedy replies, batched with left padding."""
    import torch

    tokenizer.padding_side = "left"
    replies: list[str] = []
    for start in range(0, len(prompts), batch):
        texts = [tokenizer.apply_chat_template(m, tokenize=False, add_generation_prompt=True)
                 for m in prompts[start:start + batch]]
        enc = tokenizer(texts, return_tensors="pt", padding=True, add_special_tokens=False)
        with torch.no_grad(), torch.autocast("cpu", dtype=torch.bfloat16):
            out = model.generate(**enc, max_new_tokens=max_new_tokens, do_sample=False,
                                 pad_token_id=tokenizer.pad_token_id or tokenizer.eos_token_id)
        replies += tokenizer.batch_decode(out[:, enc.input_ids.shape[1]:], skip_special_tokens=True)
    return [r.strip() for r in replies]


def lenient(item, reply: str) -> tuple[bool, str | None]:
    """Whether the reply is right under lenient scoring, and the letter it chose (None when unread)."""
    from tacreasoner.tasks.scoring import score_item

    score = score_item(item, reply, "lenient")
    if score.parse_failed or score.parsed is None:
        return score.correct, None
    gold = item.gold["letter"]
    return score.correct, gold if score.correct else {"A": "B", "B": "A"}[gold]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--llm", type=Path, default=Path("runs/smollm2"))
    ap.add_argument("--bench", type=Path, default=Path("runs/quickstart/bench"))
    ap.add_argument("--split", default="val")
    ap.add_argument("--steps", type=int, default=150)
    ap.add_argument("--batch-size", type=int, default=8)
    ap.add_argument("--lr", type=float, default=3e-4)
    ap.add_argument("--rank", type=int, default=16)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--max-length", type=int, default=256)
    ap.add_argument("--max-new-tokens", type=int, default=160)
    ap.add_argument("--conditions", default="needed,all")
    ap.add_argument("--documents", type=float, default=0.0,
                    help="share of each batch drawn from the corpus documents (the rest keeps MIX's proportions)")
    ap.add_argument("--name", default="tsa_text_rehearsal")
    args = ap.parse_args()

    import torch
    from peft import LoraConfig, get_peft_model
    from transformers import AutoModelForCausalLM, AutoTokenizer

    from tacreasoner.intervals import wilson_interval
    from tacreasoner.jsonl import iter_jsonl
    from tacreasoner.knowledge.corpus import build_corpus
    from tacreasoner.tasks.bench import load_bench
    from tacreasoner.tasks.extract import extract_answer
    from tacreasoner.tasks.scoring import score_item
    from tacreasoner.train.data import bench_video_root

    torch.manual_seed(args.seed)
    torch.set_num_threads(args.threads)
    info = stamp()
    tokenizer = AutoTokenizer.from_pretrained(args.llm)
    model = AutoModelForCausalLM.from_pretrained(args.llm, dtype=torch.float32)
    model = get_peft_model(model, LoraConfig(r=args.rank, lora_alpha=2 * args.rank, lora_dropout=0.05,
                                             target_modules=["q_proj", "k_proj", "v_proj", "o_proj"],
                                             task_type="CAUSAL_LM"))

    corpus = build_corpus(args.seed)
    pools: dict[str, list] = {k: [] for k in MIX}
    for d in corpus.dialogues:
        pools[family(d)].append(d)
    pools["documents"] = corpus.documents
    mix = {k: (args.documents if k == "documents" else v * (1 - args.documents)) for k, v in MIX.items()}
    rng = random.Random(args.seed)
    optimizer = torch.optim.AdamW([p for p in model.parameters() if p.requires_grad], lr=args.lr, weight_decay=0.0)
    warmup = max(1, args.steps // 20)
    scheduler = torch.optim.lr_scheduler.LambdaLR(
        optimizer, lambda s: min(1.0, (s + 1) / warmup) * max(0.0, (args.steps - s) / max(1, args.steps - warmup)))
    pad = tokenizer.pad_token_id if tokenizer.pad_token_id is not None else tokenizer.eos_token_id
    start = time.perf_counter()
    losses: list[float] = []
    model.train()
    for step in range(args.steps):
        rows = [encode(tokenizer, rng.choice(pools[rng.choices(list(mix), weights=list(mix.values()))[0]]),
                       args.max_length) for _ in range(args.batch_size)]
        width = max(len(ids) for ids, _ in rows)
        ids = torch.tensor([r + [pad] * (width - len(r)) for r, _ in rows])
        labels = torch.tensor([lab + [-100] * (width - len(lab)) for _, lab in rows])
        mask = torch.tensor([[1] * len(r) + [0] * (width - len(r)) for r, _ in rows])
        with torch.autocast("cpu", dtype=torch.bfloat16):
            loss = model(input_ids=ids, attention_mask=mask, labels=labels).loss
        loss.backward()
        optimizer.step()
        scheduler.step()
        optimizer.zero_grad(set_to_none=True)
        losses.append(float(loss))
        if step % 10 == 0 or step == args.steps - 1:
            print(f"step {step}: loss {loss.item():.3f} ({time.perf_counter() - start:.0f} s)", flush=True)
    train_seconds = time.perf_counter() - start
    model.eval()

    results: dict[str, dict] = {}
    examples: dict[str, str] = {}
    held = [q for q in corpus.eval_questions if q.kind == "scenario"]
    replies = generate(model, tokenizer, [q.messages() for q in held], args.max_new_tokens, 16)
    right = sum(q.is_correct(extract_answer(r, "strict")) for q, r in zip(held, replies, strict=True))
    results["corpus_heldout_scenarios"] = {"n": len(held), "correct": right, "accuracy": right / len(held),
                                           "wilson": list(wilson_interval(right, len(held)))}
    examples["corpus_heldout_scenarios"] = f"{held[0].question} → {replies[0]}"
    print(f"corpus held-out scenarios: {right}/{len(held)}", flush=True)

    bench_info, items = load_bench(args.bench, args.split)
    items = [it for it in items if it.task == "TSA"]
    manifest = bench_video_root(args.bench, bench_info) / "manifest.jsonl"
    labels_of = {row["clip_id"]: row["labels"] for _, row in iter_jsonl(manifest)}
    held_ids = set(corpus.heldout_scenarios)
    for condition in [c.strip() for c in args.conditions.split(",") if c.strip()]:
        orders = {"as asked": items, "swapped": [swapped(it) for it in items]}
        outcome: dict[str, list] = {}
        for order, its in orders.items():
            prompts = [[{"role": "user", "content": textual_question(it, condition, labels_of)}] for it in its]
            got = generate(model, tokenizer, prompts, args.max_new_tokens, 16)
            outcome[order] = [(score_item(it, r, "strict").correct, *lenient(it, r), r) for it, r in
                              zip(its, got, strict=True)]
            examples[f"{condition}/{order}"] = f"{prompts[0][0]['content']} → {got[0]} (gold {its[0].gold['letter']})"
        n = len(items)
        row: dict[str, object] = {"n": n}
        for k, mode in enumerate(("strict", "lenient")):
            c = sum(o[k] for o in outcome["as asked"])
            both = sum(a[k] and b[k] for a, b in zip(outcome["as asked"], outcome["swapped"], strict=True))
            heldout = [a[k] for it, a in zip(items, outcome["as asked"], strict=True)
                       if it.gold["scenario"] in held_ids]
            row[mode] = {"correct": c, "accuracy": c / n, "wilson": list(wilson_interval(c, n)),
                         "right_both_orders": both / n,
                         "heldout_scenarios": {"n": len(heldout), "accuracy": sum(heldout) / max(1, len(heldout))}}
        # A letter that follows the objects changes when the videos swap (an unread reply follows nothing).
        flips = [a[2] is not None and b[2] is not None and a[2] != b[2]
                 for a, b in zip(outcome["as asked"], outcome["swapped"], strict=True)]
        row["follows_objects"] = sum(flips) / n
        results[f"tsa/{condition}"] = row
        print(f"TSA {args.split} {condition}: {json.dumps(row)}", flush=True)
    seconds = time.perf_counter() - start

    md = header_md("Teaching SmolLM2-135M TSA's commonsense as text: LoRA on the corpus, TSA with gold words", info)
    md += (f"LLM `{args.llm}` (Q4_1 GGUF dequantised) + LoRA r{args.rank} on q/k/v/o, {args.steps} steps of "
           f"{args.batch_size} corpus dialogues (mix {mix}; corpus seed {args.seed}, held-out scenarios "
           f"{', '.join(corpus.heldout_scenarios)}), lr {args.lr}, bf16 autocast, {args.threads} thread(s): "
           f"{train_seconds:.0f} s of training, {seconds:.0f} s in all; loss {losses[0]:.2f} → "
           f"{sum(losses[-10:]) / min(10, len(losses)):.2f} (mean of the last 10 steps). Greedy, up to "
           f"{args.max_new_tokens} new tokens. Split `{args.split}`. No tactile data, no TSA item trained on.\n\n")
    h = results["corpus_heldout_scenarios"]
    md += (f"Corpus held-out scenario questions (named objects): **{100 * h['accuracy']:.1f}%** "
           f"[{100 * h['wilson'][0]:.0f}–{100 * h['wilson'][1]:.0f}] of {h['n']} (chance 50%).\n\n")
    rows = []
    for key, r in results.items():
        if not key.startswith("tsa/"):
            continue
        cells = []
        for mode in ("strict", "lenient"):
            m = r[mode]
            cells.append(f"{100 * m['accuracy']:.1f} [{100 * m['wilson'][0]:.0f}–{100 * m['wilson'][1]:.0f}]"
                         + (" ✓" if m["wilson"][0] > 0.5 else ""))
        rows.append([key.split("/", 1)[1], r["n"], *cells, f"{100 * r['lenient']['right_both_orders']:.1f}",
                     f"{100 * r['follows_objects']:.1f}",
                     f"{100 * r['lenient']['heldout_scenarios']['accuracy']:.1f} "
                     f"(n {r['lenient']['heldout_scenarios']['n']})"])
    md += md_table(["TSA with words", "n", "strict % [95%]", "lenient % [95%]", "right in both orders %",
                    "letter follows the objects %", "lenient, held-out scenarios %"], rows)
    md += "\nExamples:\n\n" + "".join(f"- {k}: `{v}`\n" for k, v in examples.items())
    publish(args.name, {**info, "llm": str(args.llm), "bench": str(args.bench), "split": args.split,
                        "steps": args.steps, "batch_size": args.batch_size, "lr": args.lr, "rank": args.rank,
                        "seed": args.seed, "mix": mix, "train_seconds": round(train_seconds, 1),
                        "seconds": round(seconds, 1), "losses": [round(x, 4) for x in losses],
                        "heldout_scenarios": list(corpus.heldout_scenarios), "results": results,
                        "examples": examples}, md)


if __name__ == "__main__":
    main()
