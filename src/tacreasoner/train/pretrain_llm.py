"""Text-only pre-training of the tiny LLM on the commonsense corpus, and a knowledge check of the result.

Read top to bottom: build the corpus → train (or, on resume, reload) the BPE tokenizer → tokenise
documents (plain LM loss on every token) and dialogues (loss on the assistant turn only, as in Stage II
SFT: the model must learn to answer, not to ask; the question still shapes the answer through
attention) → pack whole examples into rows with per-example positions (transformers turns reset
``position_ids`` into a block-diagonal causal mask, so packed examples never see each other and every
dialogue starts at position 0 as at inference) → AdamW + warmup/cosine → atomic checkpoints under
``out_dir/checkpoints/`` → the final model and tokenizer in ``out_dir`` itself, loadable with
``AutoModelForCausalLM.from_pretrained(out_dir)`` / ``AutoTokenizer.from_pretrained(out_dir)``.

Files in ``out_dir``: ``tokenizer/`` (written first, reused on resume), ``checkpoints/step-*``,
``train_log.jsonl`` (one line per logged step), ``pretrain.json`` (settings, corpus statistics, timing),
then ``config.json``, ``generation_config.json``, ``model.safetensors`` and the tokenizer files.
"""

from __future__ import annotations

import json
import math
import random
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import torch

from tacreasoner.knowledge.corpus import EVAL_KINDS, Corpus, EvalQuestion, build_corpus, chatml
from tacreasoner.model.tokenizer import END_OF_TEXT, IM_END, train_tokenizer, wording_texts
from tacreasoner.progress import ProgressBar
from tacreasoner.train.state import (
    cosine_with_warmup,
    latest_checkpoint,
    load_checkpoint,
    save_checkpoint,
    seed_everything,
    write_json,
)
from tacreasoner.train.threads import free_threads

__all__ = ["PretrainSettings", "evaluate_knowledge", "knowledge_check", "pretrain_llm", "tokenizer_training_texts"]

IGNORE = -100
TOKENIZER_DIR = "tokenizer"
CHECKPOINT_DIR = "checkpoints"
SETTINGS_FILE = "pretrain.json"
LOG_FILE = "train_log.jsonl"


@dataclass(frozen=True)
class PretrainSettings:
    """Everything that determines a run; a resumed run must match the one it continues."""

    steps: int = 320
    batch_size: int = 16
    seq_len: int = 256
    lr: float = 3e-3
    seed: int = 0
    vocab_size: int = 4096
    warmup_steps: int = 20
    weight_decay: float = 0.1
    holdout_fraction: float = 0.2
    checkpoint_every: int = 50
    bf16: bool = False
    model: dict[str, Any] = field(default_factory=dict)
    """Overrides of ``tiny_qwen2_config`` (e.g. ``{"num_hidden_layers": 2}``)."""
    corpus: dict[str, Any] = field(default_factory=dict)
    """Keyword arguments of ``build_corpus`` besides seed and holdout (e.g. ``{"n_compare": 1000}``)."""
    rehearsal: dict[str, Any] = field(default_factory=dict)
    """TouchCoT's multi-video items as text (``tacreasoner.train.rehearsal``): ``{"touchcot": training file,
    "bench": its benchmark directory, "passes": wordings per item (default 2)}``; empty = none."""

    def check(self) -> None:
        for name in ("steps", "batch_size", "seq_len", "vocab_size", "checkpoint_every"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be at least 1, got {getattr(self, name)}")
        if not (self.lr > 0 and math.isfinite(self.lr)):
            raise ValueError(f"lr must be a positive number, got {self.lr}")
        if self.warmup_steps < 0 or self.weight_decay < 0:
            raise ValueError("warmup_steps and weight_decay must be >= 0")
        if self.seq_len < 64:
            raise ValueError(f"seq_len must be at least 64 (one dialogue must fit), got {self.seq_len}")
        if self.rehearsal:
            if unknown := sorted(set(self.rehearsal) - {"touchcot", "bench", "passes"}):
                raise ValueError(f"rehearsal: unknown keys {unknown}; known: bench, passes, touchcot")
            passes = self.rehearsal.get("passes", 2)
            if not isinstance(passes, int) or isinstance(passes, bool) or passes < 1:
                raise ValueError(f"rehearsal.passes must be a whole number ≥ 1, got {passes!r}")
            for key in ("touchcot", "bench"):
                if not self.rehearsal.get(key) or not Path(self.rehearsal[key]).exists():
                    raise ValueError(f"rehearsal.{key}: {self.rehearsal.get(key)!r} does not exist (a TouchCoT "
                                     f"training file and the benchmark directory it was built from are needed)")


def bf16_supported(cpuinfo: str | None = None) -> bool:
    """Native bf16 matmuls on this CPU (autocast then roughly doubles training speed; otherwise it slows it).

    oneDNN reports bf16 "supported" on any AVX-512 CPU, where it is emulated: on an AVX-512 Xeon without AVX512_BF16
    a bf16 matmul ran at 24 GFLOP/s against 83 in float32 (2026-11-26), and "auto" mixed precision made Stage I
    several times slower. So the CPU's own flags decide where Linux lists them (``avx512_bf16``/``amx_bf16`` on x86,
    ``bf16`` on ARM); elsewhere oneDNN's answer stands."""
    if cpuinfo is None:
        try:
            cpuinfo = Path("/proc/cpuinfo").read_text(encoding="utf-8", errors="replace")
        except OSError:
            cpuinfo = ""
    flags = {flag for line in cpuinfo.splitlines() if line.lower().startswith(("flags", "features"))
             for flag in line.split(":", 1)[-1].split()}
    if flags:
        return bool(flags & {"avx512_bf16", "amx_bf16", "bf16"})
    try:
        return bool(torch.ops.mkldnn._is_mkldnn_bf16_supported())
    except (AttributeError, RuntimeError):
        return False


# ------------------------------------------------------------------------------------------ data


@dataclass
class _Example:
    ids: list[int]
    labels: list[int]


def _tokenise(corpus: Corpus, tokenizer: Any, seq_len: int) -> tuple[list[_Example], int]:
    """Documents (loss on all tokens, closed by ``<|endoftext|>``) and dialogues (loss on the answer).

    Returns the examples and how many had to be truncated to ``seq_len``.
    """
    eot = tokenizer.convert_tokens_to_ids(END_OF_TEXT)
    encode = lambda texts: tokenizer(texts, add_special_tokens=False)["input_ids"]  # noqa: E731
    examples = [_Example([*ids, eot], [*ids, eot]) for ids in encode(corpus.documents)]
    prompts = encode([chatml(d[:-1], add_generation_prompt=True) for d in corpus.dialogues])
    answers = encode([d[-1]["content"] + IM_END for d in corpus.dialogues])
    newline = encode(["\n"])[0]
    for p, a in zip(prompts, answers, strict=True):
        examples.append(_Example([*p, *a, *newline], [IGNORE] * len(p) + a + [IGNORE] * len(newline)))
    truncated = 0
    for e in examples:
        if len(e.ids) > seq_len:
            e.ids, e.labels, truncated = e.ids[:seq_len], e.labels[:seq_len], truncated + 1
    return examples, truncated


_Row = tuple[list[int], list[int], list[int], int]


def _pack(examples: Sequence[_Example], seq_len: int, pad_id: int) -> list[_Row]:
    """Whole examples greedily packed into rows of ``seq_len``.

    A row is (ids, labels, position ids restarting at every example, number of non-padding tokens).
    """
    rows: list[_Row] = []
    ids: list[int] = []
    labels: list[int] = []
    pos: list[int] = []

    def close() -> None:
        pad = seq_len - len(ids)
        rows.append((ids + [pad_id] * pad, labels + [IGNORE] * pad, pos + list(range(pad)), len(ids)))

    for e in examples:
        if len(ids) + len(e.ids) > seq_len:
            close()
            ids, labels, pos = [], [], []
        ids, labels, pos = ids + e.ids, labels + e.labels, pos + list(range(len(e.ids)))
    if ids:
        close()
    return rows


def _batches(examples: Sequence[_Example], settings: PretrainSettings, pad_id: int,
             start_step: int) -> Iterator[tuple[torch.Tensor, torch.Tensor, torch.Tensor, int]]:
    """Batches in a fixed order for the seed: epoch ``e`` shuffles with ``(seed, e)``; resume skips ahead."""
    skip = start_step * settings.batch_size
    epoch = 0
    pending: list[_Row] = []
    while True:
        order = list(examples)
        random.Random(settings.seed * 1_000_003 + epoch).shuffle(order)
        rows = _pack(order, settings.seq_len, pad_id)
        epoch += 1
        if skip >= len(rows):
            skip -= len(rows)
            continue
        pending += rows[skip:]
        skip = 0
        while len(pending) >= settings.batch_size:
            chunk, pending = pending[: settings.batch_size], pending[settings.batch_size:]
            yield (torch.tensor([r[0] for r in chunk]), torch.tensor([r[1] for r in chunk]),
                   torch.tensor([r[2] for r in chunk]), sum(r[3] for r in chunk))


def packed_forward(model: Any, ids: torch.Tensor, positions: torch.Tensor, labels: torch.Tensor | None = None) -> Any:
    """Forward over packed rows: attention stays inside each example (positions restart at 0 per example).

    ``use_cache=False`` matters: with a cache, transformers does not derive the block-diagonal mask from
    the position ids, and examples would attend to their neighbours at meaningless relative positions.
    """
    return model(input_ids=ids, position_ids=positions, labels=labels, use_cache=False)


# ------------------------------------------------------------------------------------------ run files


def _check_settings(out: Path, settings: PretrainSettings, resume: bool) -> None:
    path = out / SETTINGS_FILE
    has_run = (out / CHECKPOINT_DIR).is_dir() and latest_checkpoint(out / CHECKPOINT_DIR) is not None
    if not resume:
        if has_run:
            raise ValueError(f"{out}: already holds a pre-training run (checkpoints in {out / CHECKPOINT_DIR}); "
                             f"resume it or choose a new output directory")
        return
    if not path.is_file():
        return
    before = json.loads(path.read_text(encoding="utf-8")).get("settings", {})
    now = json.loads(json.dumps(asdict(settings)))
    # bf16 only changes speed (and rounding): a run may resume on a machine without it.
    differ = sorted(k for k in now if k in before and before[k] != now[k] and k != "bf16")
    if differ:
        details = ", ".join(f"{k}: {before[k]!r} → {now[k]!r}" for k in differ)
        raise ValueError(f"{path}: cannot resume with different settings ({details}); use the original ones or a "
                         f"new output directory")


def write_untrained_tokens(out: Path, examples: Sequence[_Example], vocab_size: int) -> Path:
    """Record the vocabulary entries that never occur in the corpus (see ``UNTRAINED_TOKENS_FILE``)."""
    from tacreasoner.model.build import UNTRAINED_TOKENS_FILE

    seen = {t for e in examples for t in e.ids}
    ids = [i for i in range(vocab_size) if i not in seen]
    path = out / UNTRAINED_TOKENS_FILE
    write_json(path, {"ids": ids, "why": "tokens of the BPE vocabulary (learnt from the corpus and the package's "
                                         "wording files) that never occur in the pre-training corpus: their "
                                         "embedding rows are untrained, so the tactile stages train them"})
    return path


def _unique_weights(model: torch.nn.Module) -> dict[str, torch.Tensor]:
    """The state dict without tied duplicates (safetensors refuses tensors that share memory)."""
    seen: set[int] = set()
    out = {}
    for name, tensor in model.state_dict().items():
        if tensor.data_ptr() in seen:
            continue
        seen.add(tensor.data_ptr())
        out[name] = tensor
    return out


def tokenizer_training_texts(corpus: Corpus | None = None) -> list[str]:
    """The texts the tiny LLM's BPE merges are learnt from: the commonsense corpus + the package's wording files.

    ``corpus`` defaults to ``build_corpus(seed=0)``. Dialogues enter as rendered chat text, so ChatML
    markup and the reasoning layout tokenise as they will in training. Here rather than in
    ``model.tokenizer`` because the corpus (``knowledge``) belongs to this pre-training, not to the model.
    """
    corpus = build_corpus(seed=0) if corpus is None else corpus
    return [*corpus.documents, *(chatml(d) for d in corpus.dialogues), *wording_texts()]


def _load_tokenizer_or_train(out: Path, corpus: Corpus, vocab_size: int, resume: bool) -> Any:
    from transformers import AutoTokenizer

    tok_dir = out / TOKENIZER_DIR
    if resume and (tok_dir / "tokenizer_config.json").is_file():
        return AutoTokenizer.from_pretrained(tok_dir)
    tokenizer = train_tokenizer(tokenizer_training_texts(corpus), vocab_size=vocab_size)
    tokenizer.save_pretrained(tok_dir)
    return AutoTokenizer.from_pretrained(tok_dir)  # exactly what a resumed run will use


# ------------------------------------------------------------------------------------------ training


def pretrain_llm(out_dir: str | Path, *, steps: int = PretrainSettings.steps,
                 batch_size: int = PretrainSettings.batch_size, seq_len: int = PretrainSettings.seq_len,
                 lr: float = PretrainSettings.lr, seed: int = 0, resume: bool = False,
                 vocab_size: int = PretrainSettings.vocab_size, progress: bool = True,
                 checkpoint_every: int = PretrainSettings.checkpoint_every,
                 warmup_steps: int = PretrainSettings.warmup_steps,
                 holdout_fraction: float = PretrainSettings.holdout_fraction, bf16: bool | None = None,
                 model_overrides: dict[str, Any] | None = None, corpus_options: dict[str, Any] | None = None,
                 rehearsal: dict[str, Any] | None = None,
                 log_every: int = 10,
                 threads: int | None = None, stop_after: int | None = None,
                 on_log: Callable[[dict[str, Any]], None] | None = None) -> Path:
    """Train the tokenizer and a tiny Qwen2 from scratch on the commonsense corpus; returns ``out_dir``.

    ``resume=True`` continues from the newest checkpoint (same settings required) and reuses the saved
    tokenizer. ``bf16=None`` uses bf16 autocast when the CPU has native bf16; ``threads=None`` picks
    :func:`~tacreasoner.train.threads.free_threads` (the global torch setting is restored afterwards).
    ``stop_after`` ends the run early after that many steps *without* the final save (for tests of
    interrupted runs). ``rehearsal`` adds TouchCoT's multi-video items as text (:class:`PretrainSettings`).
    """
    settings = PretrainSettings(steps=steps, batch_size=batch_size, seq_len=seq_len, lr=lr, seed=seed,
                                vocab_size=vocab_size, warmup_steps=warmup_steps, holdout_fraction=holdout_fraction,
                                checkpoint_every=checkpoint_every, bf16=bf16_supported() if bf16 is None else bf16,
                                model=dict(model_overrides or {}), corpus=dict(corpus_options or {}),
                                rehearsal={k: v if k == "passes" else str(v) for k, v in (rehearsal or {}).items()})
    settings.check()
    if threads is not None and threads < 1:
        raise ValueError(f"threads must be at least 1, got {threads}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    _check_settings(out, settings, resume)
    before = torch.get_num_threads()
    torch.set_num_threads(free_threads() if threads is None else threads)
    try:
        return _train(out, settings, resume=resume, progress=progress, log_every=log_every, stop_after=stop_after,
                      on_log=on_log)
    finally:
        torch.set_num_threads(before)


def _train(out: Path, settings: PretrainSettings, *, resume: bool, progress: bool, log_every: int,
           stop_after: int | None, on_log: Callable[[dict[str, Any]], None] | None) -> Path:
    from transformers import Qwen2ForCausalLM

    from tacreasoner.model.tiny import tiny_qwen2_config

    seed, steps, lr = settings.seed, settings.steps, settings.lr
    started = time.perf_counter()

    corpus = build_corpus(seed=seed, holdout_fraction=settings.holdout_fraction, **settings.corpus)
    rehearsal = None
    if settings.rehearsal:
        from tacreasoner.train.rehearsal import rehearsal_dialogues

        rehearsal = rehearsal_dialogues(settings.rehearsal["touchcot"], settings.rehearsal["bench"],
                                        passes=settings.rehearsal.get("passes", 2), seed=seed)
        corpus = replace(corpus, dialogues=[*corpus.dialogues, *rehearsal.dialogues])
    tokenizer = _load_tokenizer_or_train(out, corpus, settings.vocab_size, resume)
    examples, truncated = _tokenise(corpus, tokenizer, settings.seq_len)
    pad_id, eos_id = tokenizer.pad_token_id, tokenizer.eos_token_id
    n_tokens = sum(len(e.ids) for e in examples)
    write_json(out / SETTINGS_FILE, {"settings": asdict(settings), "corpus": corpus.stats(),
                                       "rehearsal": rehearsal.stats() if rehearsal else None,
                                       "corpus_tokens": n_tokens, "truncated_examples": truncated,
                                       "vocab_size": len(tokenizer)})

    seed_everything(seed)
    config = tiny_qwen2_config(len(tokenizer), eos_token_id=eos_id, pad_token_id=pad_id,
                               bos_token_id=tokenizer.convert_tokens_to_ids(END_OF_TEXT), **settings.model)
    model = Qwen2ForCausalLM(config)
    decay = [p for n, p in model.named_parameters() if p.ndim >= 2]
    no_decay = [p for n, p in model.named_parameters() if p.ndim < 2]
    optimizer = torch.optim.AdamW([{"params": decay, "weight_decay": settings.weight_decay},
                                   {"params": no_decay, "weight_decay": 0.0}], lr=lr, betas=(0.9, 0.95))
    scheduler = cosine_with_warmup(optimizer, min(settings.warmup_steps, steps // 5), steps)
    ckpt_dir = out / CHECKPOINT_DIR
    step, tokens_seen, elapsed_before = 0, 0, 0.0
    last_loss: float | None = None
    last = latest_checkpoint(ckpt_dir) if resume else None
    if last is not None:
        weights, state = load_checkpoint(last, optimizer, scheduler)
        missing, unexpected = model.load_state_dict(weights, strict=False)
        if unexpected or [k for k in missing if not k.startswith("lm_head")]:
            raise ValueError(f"checkpoint {last}: does not fit the model (missing {missing}, unexpected {unexpected})")
        step = state.step
        tokens_seen = int(state.extra.get("tokens_seen", 0))
        elapsed_before = float(state.extra.get("train_seconds", 0.0))
        last_loss = state.extra.get("loss")

    model.train()
    bar = ProgressBar(progress)
    bar.stage("pre-training LLM", steps, step, unit="steps")
    batches = _batches(examples, settings, pad_id, step)
    log_path = out / LOG_FILE
    window_tokens, window_start = 0, time.perf_counter()
    train_start = time.perf_counter()
    try:
        while step < steps:
            if stop_after is not None and step >= stop_after:
                return out
            ids, labels, positions, real = next(batches)
            with torch.autocast("cpu", dtype=torch.bfloat16, enabled=settings.bf16):
                loss = packed_forward(model, ids, positions, labels).loss
            loss.backward()
            torch.nn.utils.clip_grad_norm_(model.parameters(), 1.0)
            optimizer.step()
            scheduler.step()
            optimizer.zero_grad(set_to_none=True)
            step += 1
            tokens_seen += real
            window_tokens += real
            rate = window_tokens / max(1e-9, time.perf_counter() - window_start)
            last_loss = loss.item()
            bar.update(step, f"loss {last_loss:.3f}  {rate:,.0f} tokens/s")
            if step % log_every == 0 or step == steps:
                record = {"step": step, "loss": round(last_loss, 4), "lr": scheduler.get_last_lr()[0],
                          "tokens": tokens_seen, "tokens_per_s": round(rate, 1),
                          "elapsed_s": round(elapsed_before + time.perf_counter() - train_start, 1)}
                with log_path.open("a", encoding="utf-8") as f:
                    f.write(json.dumps(record) + "\n")
                if on_log is not None:
                    on_log(record)
                window_tokens, window_start = 0, time.perf_counter()
            if step % settings.checkpoint_every == 0 or step == steps:
                save_checkpoint(ckpt_dir, step, _unique_weights(model), optimizer, scheduler,
                                extra={"tokens_seen": tokens_seen, "loss": last_loss,
                                       "train_seconds": elapsed_before + time.perf_counter() - train_start})
    finally:
        bar.close()

    model.eval()
    model.generation_config.eos_token_id = eos_id
    model.generation_config.pad_token_id = pad_id
    model.generation_config.bos_token_id = None
    model.save_pretrained(out)
    tokenizer.save_pretrained(out)
    write_untrained_tokens(out, examples, len(tokenizer))
    info = json.loads((out / SETTINGS_FILE).read_text(encoding="utf-8"))
    info.update({"steps_done": step, "tokens_seen": tokens_seen,
                 "final_loss": None if last_loss is None else round(last_loss, 4),
                 "train_seconds": round(elapsed_before + time.perf_counter() - train_start, 1),
                 "total_seconds_this_call": round(time.perf_counter() - started, 1),
                 "parameters": sum(p.numel() for p in model.parameters()), "threads": torch.get_num_threads()})
    write_json(out / SETTINGS_FILE, info)
    return out


# ------------------------------------------------------------------------------------------ evaluation


def _as_question(q: EvalQuestion | dict[str, Any]) -> EvalQuestion:
    if isinstance(q, EvalQuestion):
        return q
    try:
        return EvalQuestion(str(q["id"]), str(q["kind"]), str(q["question"]), str(q["answer"]),
                            tuple(q["options"]), dict(q.get("meta", {})))
    except (KeyError, TypeError) as e:
        raise ValueError(f"knowledge question {q!r}: needs id, kind, question, answer and options ({e})") from None


def _generate(model: Any, tokenizer: Any, prompts: list[str], max_new_tokens: int) -> list[str]:
    tokenizer.padding_side = "left"
    batch = tokenizer(prompts, return_tensors="pt", padding=True, add_special_tokens=False)
    with torch.inference_mode():
        out = model.generate(**batch, do_sample=False, max_new_tokens=max_new_tokens,
                             eos_token_id=tokenizer.eos_token_id, pad_token_id=tokenizer.pad_token_id)
    return tokenizer.batch_decode(out[:, batch["input_ids"].shape[1]:], skip_special_tokens=True)


def evaluate_knowledge(model_dir: str | Path, questions: Sequence[EvalQuestion | dict[str, Any]], *,
                       batch_size: int = 64, max_new_tokens: int = 160, threads: int | None = None) -> dict[str, Any]:
    """Greedy answers to text-only questions, scored per kind with Wilson 95% intervals against chance.

    The answer is read with the benchmark's strict extractor (``<think>…</think><answer>…</answer>``,
    a format failure counts as wrong; ``parse_failures`` says how often); ``lenient_accuracy`` uses the
    lenient extractor for reference. ``threads=None`` uses :func:`~tacreasoner.train.threads.free_threads`.
    """
    from transformers import AutoModelForCausalLM, AutoTokenizer

    from tacreasoner.intervals import wilson_interval
    from tacreasoner.tasks.extract import extract_answer

    items = [_as_question(q) for q in questions]
    if not items:
        raise ValueError("evaluate_knowledge: no questions")
    path = Path(model_dir)
    if not (path / "config.json").is_file():
        raise FileNotFoundError(f"{path}: no model here (config.json missing; run `tacreasoner pretrain-llm`)")
    tokenizer = AutoTokenizer.from_pretrained(path)
    model = AutoModelForCausalLM.from_pretrained(path)
    model.eval()
    prompts = [tokenizer.apply_chat_template(q.messages(), tokenize=False, add_generation_prompt=True) for q in items]
    order = sorted(range(len(items)), key=lambda i: len(prompts[i]))  # similar lengths batch with little padding
    texts: dict[int, str] = {}
    start = time.perf_counter()
    before = torch.get_num_threads()
    torch.set_num_threads(free_threads() if threads is None else threads)
    try:
        for i in range(0, len(order), batch_size):
            chunk = order[i: i + batch_size]
            texts.update(zip(chunk, _generate(model, tokenizer, [prompts[j] for j in chunk], max_new_tokens),
                             strict=True))
    finally:
        torch.set_num_threads(before)
    predictions = []
    for i, q in enumerate(items):
        strict, lenient = extract_answer(texts[i], "strict"), extract_answer(texts[i], "lenient")
        predictions.append({"id": q.id, "kind": q.kind, "prediction": texts[i], "answer": q.answer,
                            "extracted": strict, "correct": q.is_correct(strict),
                            "lenient_correct": q.is_correct(lenient), "parsed": strict is not None,
                            "chance": q.chance})
    present = {p["kind"] for p in predictions}
    kinds = [k for k in (*EVAL_KINDS, *(f"seen_{k}" for k in EVAL_KINDS)) if k in present]
    kinds += sorted(present - set(kinds))

    def summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
        n, k = len(rows), sum(r["correct"] for r in rows)
        lo, hi = wilson_interval(k, n)
        chance = sum(r["chance"] for r in rows) / n
        return {"n": n, "correct": k, "accuracy": k / n, "ci95": [lo, hi], "chance": chance,
                "above_chance": lo > chance, "parse_failures": sum(not r["parsed"] for r in rows) / n,
                "lenient_accuracy": sum(r["lenient_correct"] for r in rows) / n}

    return {"model_dir": str(path), "kinds": {k: summary([p for p in predictions if p["kind"] == k]) for k in kinds},
            "overall": summary(predictions), "seconds": round(time.perf_counter() - start, 1),
            "predictions": predictions}


KNOWLEDGE_EVAL_FILE = "knowledge_eval.json"
KNOWLEDGE_PREDICTIONS_FILE = "knowledge_predictions.jsonl"


def knowledge_check(out_dir: str | Path, *, include_seen: bool = False, batch_size: int = 64,
                    threads: int | None = None) -> dict[str, Any]:
    """Evaluate a ``pretrain_llm`` output on its own held-out questions; writes the report next to the model.

    The corpus is rebuilt from the run's ``pretrain.json`` (seed, holdout, corpus options), so the
    questions are exactly the ones held out of that run's training text. With ``include_seen`` the
    same question kinds on trained pairs/scenarios are scored too (kinds prefixed ``seen_``): the
    memorisation reference for the held-out numbers. Writes ``knowledge_eval.json`` (summary) and
    ``knowledge_predictions.jsonl`` (one line per question).
    """
    out = Path(out_dir)
    info_path = out / SETTINGS_FILE
    if not info_path.is_file():
        raise FileNotFoundError(f"{info_path}: not a pre-training output (run `tacreasoner pretrain-llm`)")
    settings = json.loads(info_path.read_text(encoding="utf-8"))["settings"]
    corpus = build_corpus(seed=settings["seed"], holdout_fraction=settings["holdout_fraction"],
                          **settings.get("corpus", {}))
    questions = list(corpus.eval_questions)
    if include_seen:
        questions += [EvalQuestion(q.id, f"seen_{q.kind}", q.question, q.answer, q.options, q.meta)
                      for q in corpus.seen_questions]
    result = evaluate_knowledge(out, questions, batch_size=batch_size, threads=threads)
    predictions = result.pop("predictions")
    with (out / KNOWLEDGE_PREDICTIONS_FILE).open("w", encoding="utf-8") as f:
        for p in predictions:
            f.write(json.dumps(p) + "\n")
    result["heldout_pairs"] = len(corpus.heldout_pairs)
    result["heldout_scenarios"] = list(corpus.heldout_scenarios)
    write_json(out / KNOWLEDGE_EVAL_FILE, result)
    return result
