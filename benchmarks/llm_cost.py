"""What does the tactile path cost on a real pretrained LLM? Training steps of TacReasoner on SmolLM2-135M-Instruct
against the bare SmolLM2 with the same LoRA on the same tokens, on this machine's CPU (or a GPU with --device).

Variants, each one training step (forward, backward, AdamW) on one batch of token ids (samples with 1, 2, 3 videos
in turn; the bare LLM reads the placeholder ids as ordinary tokens), interleaved round robin so machine noise hits
them alike; the ratio of medians is the figure:

- bare SmolLM2 + LoRA (q/k/v/o): the reference;
- TacReasoner Stage II: the same LoRA + projector, the frozen tactile encoder in front (appearance tokens cached,
  as the trainer does by default, and not cached);
- TacReasoner Stage I: the LLM frozen, gradients through it into the temporal branch, fusion and projector.

Every variant runs the LM head on the answer positions only (``loss_only``, what the trainer does; the bare LLM
gets the same through ``logits_to_keep``-free slicing of its hidden states). Tokens/s counts every non-padding
token of the batch. Peak memory: each variant alone in a fresh process (max RSS on the CPU, max allocated on CUDA).

    python benchmarks/llm_cost.py --llm runs/smollm2 [--steps 8 --batch 8 --lora-r 128] [--device cuda]
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp
from tacreasoner.model.encoder_config import TactileEncoderConfig
from tacreasoner.model.modeling import TacReasonerForCausalLM
from tacreasoner.model.stages import LoraSettings, configure_stage

VARIANTS = ("bare SmolLM2 + LoRA", "TacReasoner Stage II (appearance cached)", "TacReasoner Stage II (no cache)",
            "TacReasoner Stage I")


def make_batch(batch: int, tpv: int, question: int, answer: int, seed: int, vocab: int,
               tactile_id: int) -> dict[str, torch.Tensor]:
    """Samples with 1, 2, 3 videos in turn: question, placeholder runs, answer; loss on the answer only."""
    g = torch.Generator().manual_seed(seed)
    rows, labels, n_videos = [], [], 0
    for i in range(batch):
        k = 1 + i % 3
        n_videos += k
        q = torch.randint(10, vocab - 10, (question,), generator=g)
        a = torch.randint(10, vocab - 10, (answer,), generator=g)
        ids = torch.cat([q, torch.full((k * tpv,), tactile_id), a])
        rows.append(ids)
        labels.append(torch.cat([torch.full((question + k * tpv,), -100), a]))
    width = max(len(r) for r in rows)
    input_ids = torch.zeros(batch, width, dtype=torch.long)
    label_ids = torch.full((batch, width), -100, dtype=torch.long)
    mask = torch.zeros(batch, width, dtype=torch.long)
    for i, (r, lab) in enumerate(zip(rows, labels, strict=True)):
        input_ids[i, : len(r)], label_ids[i, : len(r)], mask[i, : len(r)] = r, lab, 1
    return {"input_ids": input_ids, "attention_mask": mask, "labels": label_ids, "n_videos": n_videos}


def step_fn(module: torch.nn.Module, inputs: dict, lr: float = 1e-4) -> Callable[[], float]:
    """One training step (forward, backward, AdamW) on ``inputs``, timed: a function returning its seconds."""
    params = [p for p in module.parameters() if p.requires_grad]
    opt = torch.optim.AdamW(params, lr=lr)

    def step() -> float:
        t0 = time.perf_counter()
        loss = module(**inputs).loss
        loss.backward()
        opt.step()
        opt.zero_grad(set_to_none=True)
        return time.perf_counter() - t0

    return step


def time_steps(steps: dict[str, Callable[[], float]], n: int, warmup: int = 2) -> dict[str, list[float]]:
    """``n`` timed rounds of every step function, round robin, after ``warmup`` untimed ones each."""
    for fn in steps.values():
        for _ in range(warmup):
            fn()
    times: dict[str, list[float]] = {k: [] for k in steps}
    for _ in range(n):
        for name, fn in steps.items():
            times[name].append(fn())
    return times


class BareLoss(torch.nn.Module):
    """The bare LLM with the LM head on labelled positions only: the same work TacReasoner's ``loss_only`` does."""

    def __init__(self, peft_llm: torch.nn.Module) -> None:
        super().__init__()
        self.peft_llm = peft_llm

    def forward(self, input_ids: torch.Tensor, attention_mask: torch.Tensor, labels: torch.Tensor) -> object:
        lm = self.peft_llm.get_base_model()
        hidden = self.peft_llm.base_model.model.model(input_ids=input_ids, attention_mask=attention_mask,
                                                      use_cache=False).last_hidden_state
        targets = torch.nn.functional.pad(labels, (0, 1), value=-100)[:, 1:]
        keep = targets != -100
        logits = lm.get_output_embeddings()(hidden[keep]).float()
        loss = torch.nn.functional.cross_entropy(logits, targets[keep])
        return type("Out", (), {"loss": loss})()


def build_variants(args: argparse.Namespace, only: str | None = None) -> tuple[dict, dict]:
    """The step functions (and a description of the batch) for every variant, or only ``only``."""
    from peft import LoraConfig, get_peft_model

    from tacreasoner.model.build import build_model

    device = torch.device(args.device)
    encoder = TactileEncoderConfig(tokens_per_video=args.tokens_per_video)
    lora = LoraSettings(r=args.lora_r, alpha=2 * args.lora_r, dropout=0.05)

    def fresh() -> TacReasonerForCausalLM:
        torch.manual_seed(0)
        model, processor = build_model(args.llm, encoder=encoder, attn_implementation=args.attn)
        fresh.tactile_id, fresh.vocab = model.config.tactile_token_id, len(processor.tokenizer)
        return model.to(device).train()

    wanted = [only] if only else list(VARIANTS)
    steps, model = {}, fresh()  # also tells make_batch the vocabulary and the tactile id
    data = make_batch(args.batch, encoder.tokens_per_video, args.question_tokens, args.answer_tokens, seed=0,
                      vocab=fresh.vocab, tactile_id=fresh.tactile_id)
    n_videos = int(data.pop("n_videos"))
    data = {k: v.to(device) for k, v in data.items()}
    pixel_values = torch.randn(n_videos, encoder.num_frames, 3, *encoder.image_size, device=device)
    full = {**data, "pixel_values": pixel_values, "loss_only": True}
    autocast = torch.autocast(device.type, dtype=torch.bfloat16, enabled=args.bf16)

    def wrapped(fn: Callable[[], float]) -> Callable[[], float]:
        def run() -> float:
            with autocast:
                return fn()
        return run

    for name in wanted:
        if name == "bare SmolLM2 + LoRA":
            bare = get_peft_model((model if only else fresh()).language_model, LoraConfig(
                r=lora.r, lora_alpha=lora.alpha, lora_dropout=lora.dropout, target_modules=list(lora.target_modules)))
            steps[name] = wrapped(step_fn(BareLoss(bare), data))
        elif name.startswith("TacReasoner Stage II"):
            stage2 = configure_stage(model if "no cache" in name or only else fresh(), 2, lora)
            inputs = dict(full)
            if "cached" in name:
                with torch.no_grad():
                    inputs["appearance_tokens"] = stage2.base_model.model.tactile_encoder.appearance_tokens(
                        pixel_values)
            steps[name] = wrapped(step_fn(stage2, inputs))
        else:
            steps[name] = wrapped(step_fn(configure_stage(model if only else fresh(), 1), full))
    tokens = int(data["attention_mask"].sum())
    answer = int((data["labels"] != -100).sum())
    return steps, {"tokens": tokens, "answer_tokens": answer, "videos": n_videos}


def peak_memory_mb(args: argparse.Namespace, variant: str) -> float:
    """One variant alone in a fresh process: its peak memory (MB)."""
    cmd = [sys.executable, __file__, "--peak-of", variant, *sys.argv[1:]]
    done = subprocess.run(cmd, capture_output=True, text=True, check=True)
    return float(json.loads(done.stdout.strip().splitlines()[-1])["peak_mb"])


def _resident_peak_mb() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def measure_peak(args: argparse.Namespace) -> None:
    """Peak memory of training steps alone: the loading peak (two copies of the weights) is reset first."""
    steps, _ = build_variants(args, only=args.peak_of)
    step = next(iter(steps.values()))
    if args.device.startswith("cuda"):
        torch.cuda.reset_peak_memory_stats()
    else:
        Path("/proc/self/clear_refs").write_text("5")  # Linux: reset the resident-set high-water mark
    for _ in range(2):
        step()
    peak = torch.cuda.max_memory_allocated() / 2**20 if args.device.startswith("cuda") else _resident_peak_mb()
    print(json.dumps({"peak_mb": peak}))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--llm", required=True, help="SmolLM2 folder from `tacreasoner llm get smollm2`")
    ap.add_argument("--steps", type=int, default=8)
    ap.add_argument("--batch", type=int, default=8)
    ap.add_argument("--question-tokens", type=int, default=64)
    ap.add_argument("--answer-tokens", type=int, default=64)
    ap.add_argument("--tokens-per-video", type=int, default=5)
    ap.add_argument("--lora-r", type=int, default=128)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--attn", default="sdpa", help="attention implementation of the LLM")
    ap.add_argument("--bf16", action=argparse.BooleanOptionalAction, default=True, help="bf16 autocast")
    ap.add_argument("--name", default="llm_cost", help="results file name under benchmarks/results/")
    ap.add_argument("--peak-of", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    from transformers.utils import logging as hf_logging

    hf_logging.set_verbosity_error()
    if args.peak_of:
        measure_peak(args)
        return
    info = stamp()
    steps, batch = build_variants(args)
    times = time_steps(steps, args.steps)
    base = statistics.median(times[VARIANTS[0]])
    rows, results = [], {}
    for name, ts in times.items():
        med = statistics.median(ts)
        peak = peak_memory_mb(args, name)
        results[name] = {"median_s": med, "ratio_vs_bare": med / base, "tokens_per_s": batch["tokens"] / med,
                         "peak_mb": peak, "times_s": ts}
        rows.append([name, med * 1000, med / base, batch["tokens"] / med, peak])
    device = torch.cuda.get_device_name(0) if args.device.startswith("cuda") else f"CPU, {args.threads} threads"
    payload = {**info, "device": device, "settings": vars(args), "batch": batch, "train_step": results}
    md = header_md("Tactile path cost on SmolLM2-135M-Instruct (4-bit GGUF weights, dequantised)", info)
    md += (f"Device: {device}. Batch: {args.batch} samples with 1/2/3 videos in turn ({batch['videos']} videos, "
           f"{batch['tokens']} tokens, {batch['answer_tokens']} of them answer tokens; {args.question_tokens} "
           f"question + {args.answer_tokens} answer tokens each, {args.tokens_per_video} tactile tokens per video). "
           f"LoRA r={args.lora_r}, α={2 * args.lora_r} on q/k/v/o; AdamW; "
           f"bf16 autocast {'on' if args.bf16 else 'off'}; "
           f"attention {args.attn}. Median of {args.steps} interleaved steps after 2 warm-up steps each; peak memory "
           f"of each variant alone in a fresh process (resident high-water mark on the CPU, max allocated on a GPU; "
           f"loading excluded).\n\n")
    md += md_table(["variant", "step (ms)", "× bare LLM", "tokens/s", "peak MB"], rows)
    md += ("\nTarget (issue 27): the tactile path costs at most 1.3× the bare LLM. Stage II with cached appearance "
           "tokens is what the trainer runs (`data.cache_appearance: true`).\n")
    publish(args.name, payload, md)


if __name__ == "__main__":
    main()
