"""How far can an LLM take zero-shot TSA when perception is perfect? The TSA items with every video replaced by words.

TSA asks which of two touched objects suits a scenario ("scraping frost off a car windscreen"). A model needs two
things: what each object feels like (perception) and which property the scenario needs (the LLM's commonsense).
This check removes the first: each ``<tactile>`` placeholder of a TSA item becomes the object's gold levels in the
benchmark's own phrases ("an object (hardness: extremely hard; friction: slight friction)"), and the LLM, as shipped
(no tactile training, no LoRA), answers the text. Three conditions per item (``CONDITIONS``):

- ``none``: the placeholders become "an object" (no perception at all: chance by construction);
- ``needed``: only the attributes the scenario depends on are described (the easiest text);
- ``all``: all four attributes are described (the model must pick the relevant ones itself).

Each is answered four ways (``WAYS``): greedy generation scored by the project's TSA scorer, ``strict`` (reads a
letter) and ``lenient`` (also the option text); ``logprob``: the log-probabilities of "A" and "B" as the reply's first
token (no format to learn); ``ordinal``: those of " first" and " second" after "The" (how such LLMs open these
answers: "The first object is better ..."). Accuracy with Wilson 95% intervals; chance is 50%. An LLM that cannot
choose above chance from the gold words gives a tactile model built on it nothing to reach TSA with zero-shot, unless
its training also teaches the commonsense. ``benchmarks/tsa_ceiling.py`` publishes a run as a result file.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tacreasoner.tasks.schema import QAItem

__all__ = ["CONDITIONS", "PLACEHOLDER", "TITLE", "WAYS", "TsaCeiling", "describe", "run_tsa_ceiling",
           "textual_question", "tsa_items"]

CONDITIONS = ("none", "needed", "all")
WAYS = ("strict", "lenient", "logprob", "ordinal")
PLACEHOLDER = "<tactile>"
TITLE = "Zero-shot TSA with perfect perception: the LLM alone, answering from the gold words"
"""The title of a published run (``benchmarks/tsa_ceiling.py``)."""


def describe(levels: Mapping[str, int], vocabulary: str) -> str:
    """``an object (hardness: extremely hard; friction: slight friction)`` from gold levels (benchmark phrases)."""
    from tacreasoner.tasks.vocab import get_vocabulary

    vocab = get_vocabulary(vocabulary)
    return "an object (" + "; ".join(f"{a}: {vocab[a].phrase(r)}" for a, r in levels.items()) + ")"


def textual_question(item: QAItem, condition: str, labels: Mapping[str, Mapping[str, Any]]) -> str:
    """The item's question with each placeholder replaced by the condition's description of that video (a QAItem
    holds exactly one placeholder per video). ``labels``: clip id → its manifest labels (per vocabulary)."""
    if condition not in CONDITIONS:
        raise ValueError(f"condition must be one of {', '.join(CONDITIONS)}; got {condition!r}")
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


def tsa_items(bench: Path, split: str) -> tuple[list[QAItem], dict[str, dict]]:
    """The split's TSA items and the labels of the benchmark's clips (clip id → labels, from its manifest)."""
    from tacreasoner.jsonl import iter_jsonl
    from tacreasoner.tasks.bench import load_bench
    from tacreasoner.train.data import bench_video_root

    info, items = load_bench(bench, split)
    items = [it for it in items if it.task == "TSA"]
    if not items:
        raise ValueError(f"{bench}/{split}.jsonl: no TSA items")
    manifest = bench_video_root(bench, info) / "manifest.jsonl"
    return items, {row["clip_id"]: row["labels"] for _, row in iter_jsonl(manifest)}


@dataclass
class TsaCeiling:
    """Per ``split/condition``: n and, per way of answering, correct, accuracy and Wilson interval; a few examples."""

    llm: Path
    bench: Path
    threads: int | None
    max_new_tokens: int
    seconds: float
    results: dict[str, dict[str, Any]] = field(default_factory=dict)
    examples: dict[str, list[dict[str, str]]] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"llm": str(self.llm), "bench": str(self.bench), "seconds": round(self.seconds, 1),
                "results": self.results, "examples": self.examples}

    def markdown(self) -> str:
        """What was run, the table (✓: Wilson lower bound above chance) and one example per condition; no title."""
        rows = []
        for r in self.results.values():
            cells = []
            for way in WAYS:
                low, high = r[way]["wilson"]
                cells.append(f"{100 * r[way]['accuracy']:.1f} [{100 * low:.0f}–{100 * high:.0f}]"
                             + (" ✓" if low > 0.5 else ""))
            rows.append([r["split"], r["condition"], str(r["n"]), *cells])
        head = ["split", "condition", "n", "strict % [95%]", "lenient % [95%]", "logprob A/B % [95%]",
                "logprob first/second % [95%]"]
        threads = f"{self.threads} thread(s)" if self.threads else "torch's default threads"
        md = (f"LLM: `{self.llm}` as shipped (no tactile training, no adapter); {threads}; greedy, up to "
              f"{self.max_new_tokens} new tokens; {self.seconds:.0f} s in all. Items: DynTAC-Sim-Bench TSA (held-out "
              "objects), each `<tactile>` replaced by words (conditions: `tacreasoner.evaluate.tsa_ceiling`). Chance "
              "50%; ✓: the Wilson 95% lower bound is above it. Strict reads a letter only, lenient also the option "
              "text; logprob A/B compares the next-token log-probabilities of `A` and `B`; first/second those of "
              "` first` and ` second` after `The`.\n\n")
        md += "| " + " | ".join(head) + " |\n|" + "---|" * len(head) + "\n"
        md += "".join("| " + " | ".join(row) + " |\n" for row in rows)
        md += "\nExamples (first items of each condition):\n\n"
        for key, shown in self.examples.items():
            for ex in shown[:1]:
                md += f"- {key}: `{ex['question']!s}` → `{ex['reply']}` (gold {ex['gold']})\n"
        return md


def run_tsa_ceiling(llm: Path, bench: Path, splits: tuple[str, ...] = ("val", "test"), *, max_new_tokens: int = 48,
                    threads: int | None = None, say: Callable[[str], None] = print) -> TsaCeiling:
    """Answer every TSA item of ``splits`` under each condition with the LLM at ``llm`` (a Hugging Face causal LM
    folder, float32 on the CPU). ``threads`` sets torch's thread count for the process when given."""
    import torch
    from transformers import AutoModelForCausalLM, AutoTokenizer

    from tacreasoner.intervals import wilson_interval
    from tacreasoner.tasks.scoring import score_item

    if threads:
        torch.set_num_threads(threads)
    tokenizer = AutoTokenizer.from_pretrained(llm)
    model = AutoModelForCausalLM.from_pretrained(llm, dtype=torch.float32).eval()
    letter_ids = [tokenizer.encode(x, add_special_tokens=False) for x in ("A", "B")]
    ordinal_ids = [tokenizer.encode(x, add_special_tokens=False) for x in (" first", " second")]
    if any(len(ids) != 1 for ids in (*letter_ids, *ordinal_ids)):
        raise ValueError(f"{llm}: 'A', 'B', ' first' and ' second' are not single tokens in its tokenizer")
    opening = tokenizer("The", return_tensors="pt", add_special_tokens=False).input_ids
    start = time.perf_counter()
    ceiling = TsaCeiling(llm=llm, bench=bench, threads=threads, max_new_tokens=max_new_tokens, seconds=0.0)
    for split in splits:
        items, labels = tsa_items(bench, split)
        for condition in CONDITIONS:
            right = dict.fromkeys(WAYS, 0)
            shown = ceiling.examples.setdefault(f"{split}/{condition}", [])
            for item in items:
                messages = [{"role": "user", "content": textual_question(item, condition, labels)}]
                prompt = tokenizer.apply_chat_template(messages, tokenize=False, add_generation_prompt=True)
                ids = tokenizer(prompt, return_tensors="pt", add_special_tokens=False).input_ids
                with torch.no_grad():
                    logits = model(ids).logits[0, -1]
                    after_the = model(torch.cat([ids, opening], dim=1)).logits[0, -1]
                    out = model.generate(ids, max_new_tokens=max_new_tokens, do_sample=False,
                                         pad_token_id=tokenizer.eos_token_id)
                reply = tokenizer.decode(out[0, ids.shape[1]:], skip_special_tokens=True).strip()
                pick = "AB"[int(logits[letter_ids[1][0]] > logits[letter_ids[0][0]])]
                right["logprob"] += pick == item.gold["letter"]
                ordinal = "AB"[int(after_the[ordinal_ids[1][0]] > after_the[ordinal_ids[0][0]])]
                right["ordinal"] += ordinal == item.gold["letter"]
                for mode in ("strict", "lenient"):
                    right[mode] += score_item(item, reply, mode).correct
                if len(shown) < 3:
                    shown.append({"id": item.id, "question": messages[0]["content"], "reply": reply,
                                  "gold": item.gold["letter"]})
            n = len(items)
            ceiling.results[f"{split}/{condition}"] = {
                "split": split, "condition": condition, "n": n,
                **{way: {"correct": k, "accuracy": k / n, "wilson": list(wilson_interval(k, n))}
                   for way, k in right.items()}}
            say(f"{split} {condition}: " + ", ".join(f"{w} {k}/{n}" for w, k in right.items()))
    ceiling.seconds = time.perf_counter() - start
    return ceiling
