"""Stage II training steps of a paper config's model at full size, random weights: tokens/s, MFU, peak memory.

Issue 38 asks what one Stage II step of the 7B model costs on a GPU before anyone trains it for real. No
checkpoint is needed: the LLM is built from its published shape (``memory_plan.resolve_llm``) with random
bf16 weights, wrapped with the config's tactile encoder, and trained exactly as the trainer trains it
(``configure_stage(2)`` with the config's LoRA, fp32 master weights, bf16 autocast, the labelled-positions-only loss,
activation checkpointing as configured, fused AdamW on the GPU). Each example is ``--seq-len`` tokens with one
video; ``--answer-fraction`` of the positions are labelled.

    python benchmarks/stage2_step.py --config configs/qwen2.5-7b.yaml --micro-batch 8 --steps 10   # on a GPU
    python benchmarks/stage2_step.py --layers 2 --seq-len 128 --micro-batch 2 --steps 2 --out /tmp/x  # CPU smoke

MFU counts model FLOPs the usual way (PaLM, appendix B): 6 × the LLM's non-embedding parameters per token, plus
12 × layers × hidden × sequence length for attention, over the GPU's dense bf16 peak (``--peak-tflops``; 989 for
an H100 SXM). A LoRA step does less than that (no weight gradients for the frozen base) but recomputes the forward
under activation checkpointing, so the figure compares with full fine-tuning MFUs, not with the work done.
Results: benchmarks/results/stage2_step_<model>.{json,md}.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp


def build(config_path: str, layers: int | None, device: str):
    """The Stage II model of ``config_path`` at its LLM's published shape, random weights, on ``device``."""
    import torch

    from tacreasoner.model.configuration import TacReasonerConfig
    from tacreasoner.model.encoder_config import TactileEncoderConfig
    from tacreasoner.model.modeling import TacReasonerForCausalLM
    from tacreasoner.model.stages import configure_stage
    from tacreasoner.train.config import load_train_config
    from tacreasoner.train.memory_plan import resolve_llm
    from tacreasoner.train.trainer import enable_activation_checkpointing, master_weights_in_fp32

    config = load_train_config(config_path)
    name, text = resolve_llm(config.model.llm)
    if layers is not None:
        fields = {k: v for k, v in text.to_dict().items() if k not in ("layer_types", "max_window_layers")}
        text = type(text)(**{**fields, "num_hidden_layers": layers})
        name = f"{name} ({layers} layers)"
    vocab = int(text.vocab_size)
    new_ids = list(range(vocab - 5, vocab))  # the 5 tokens build_model adds: rows Stage II trains too
    encoder = TactileEncoderConfig.from_dict(config.model.encoder)
    model_config = TacReasonerConfig(text_config=text.to_dict(), encoder=encoder.to_dict(),
                                     tactile_token_id=new_ids[0], new_token_ids=new_ids)
    previous = torch.get_default_dtype()
    torch.set_default_dtype(torch.bfloat16)  # built in bf16 where it lives: 7B in fp32 would need 30 GB first
    try:
        with torch.device(device):
            model = TacReasonerForCausalLM(model_config)
    finally:
        torch.set_default_dtype(previous)
    if config.model.gradient_checkpointing:
        enable_activation_checkpointing(model.language_model)
    trained = configure_stage(model, 2, config.lora)
    master_weights_in_fp32(trained, "bf16")
    return name, config, model, trained


def batch(model, micro_batch: int, seq_len: int, answer_fraction: float, device: str) -> dict:
    """Random tokens, one video per example (its placeholder run first), the last positions labelled."""
    import torch

    enc = model.encoder_config
    vocab = model.config.text_config.vocab_size
    generator = torch.Generator().manual_seed(0)
    ids = torch.randint(0, vocab - 5, (micro_batch, seq_len), generator=generator)
    ids[:, 1:1 + enc.tokens_per_video] = model.config.tactile_token_id
    labels = torch.full_like(ids, -100)
    answer = max(1, int(seq_len * answer_fraction))
    labels[:, -answer:] = ids[:, -answer:]
    height, width = enc.image_size if isinstance(enc.image_size, tuple | list) else (enc.image_size,) * 2
    pixels = torch.rand(micro_batch, enc.num_frames, 3, height, width, generator=generator)
    return {"input_ids": ids.to(device), "attention_mask": torch.ones_like(ids).to(device), "labels": labels.to(device),
            "pixel_values": pixels.to(device)}


def model_flops_per_token(text, seq_len: int) -> float:
    """6 N (non-embedding) + 12 L H S: the PaLM MFU numerator per token."""
    hidden, layers = int(text.hidden_size), int(text.num_hidden_layers)
    heads = int(text.num_attention_heads)
    kv = int(getattr(text, "num_key_value_heads", None) or heads)
    head_dim = hidden // heads
    per_layer = hidden * (heads * head_dim) + 2 * hidden * (kv * head_dim) + (heads * head_dim) * hidden \
        + 3 * hidden * int(text.intermediate_size)
    return 6 * layers * per_layer + 12 * layers * hidden * seq_len


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--config", default="configs/qwen2.5-7b.yaml")
    parser.add_argument("--micro-batch", type=int, default=8)
    parser.add_argument("--seq-len", type=int, default=1024)
    parser.add_argument("--answer-fraction", type=float, default=0.3)
    parser.add_argument("--steps", type=int, default=10)
    parser.add_argument("--warmup", type=int, default=3)
    parser.add_argument("--layers", type=int, default=None, help="fewer decoder layers (a CPU smoke test)")
    parser.add_argument("--peak-tflops", type=float, default=989.0, help="the GPU's dense bf16 peak")
    parser.add_argument("--out", default=None, help="results directory (default benchmarks/results)")
    args = parser.parse_args()

    import torch

    cuda = torch.cuda.is_available()
    device = "cuda" if cuda else "cpu"
    info = stamp()
    info["gpu"] = torch.cuda.get_device_name() if cuda else None
    started = time.perf_counter()
    name, config, model, trained = build(args.config, args.layers, device)
    build_s = time.perf_counter() - started
    params = [p for p in trained.parameters() if p.requires_grad]
    optimizer = torch.optim.AdamW(params, lr=config.stage2.lr, fused=cuda)
    inputs = batch(model, args.micro_batch, args.seq_len, args.answer_fraction, device)
    labelled = int((inputs["labels"][:, 1:] != -100).sum())
    trained.train()
    if cuda:
        torch.cuda.reset_peak_memory_stats()
    times = []
    for step in range(args.warmup + args.steps):
        if cuda:
            torch.cuda.synchronize()
        t0 = time.perf_counter()
        with torch.autocast(device, dtype=torch.bfloat16):
            loss = trained(**inputs, num_items_in_batch=labelled, loss_only=True).loss
        loss.backward()
        torch.nn.utils.clip_grad_norm_(params, config.stage2.max_grad_norm)
        optimizer.step()
        optimizer.zero_grad(set_to_none=True)
        if cuda:
            torch.cuda.synchronize()
        if step >= args.warmup:
            times.append(time.perf_counter() - t0)
    step_s = sorted(times)[len(times) // 2]
    tokens_per_s = args.micro_batch * args.seq_len / step_s
    text = model.config.text_config
    mfu = model_flops_per_token(text, args.seq_len) * tokens_per_s / (args.peak_tflops * 1e12)
    peak_gb = torch.cuda.max_memory_allocated() / 1e9 if cuda else None
    result = {**info, "model": name, "config": args.config, "micro_batch": args.micro_batch, "seq_len": args.seq_len,
              "answer_fraction": args.answer_fraction, "gradient_checkpointing": config.model.gradient_checkpointing,
              "lora": {"r": config.lora.r, "alpha": config.lora.alpha}, "trainable_parameters": sum(
                  p.numel() for p in params), "parameters": sum(p.numel() for p in model.parameters()),
              "build_seconds": round(build_s, 1), "step_seconds_median": round(step_s, 3),
              "step_seconds": [round(t, 3) for t in times], "tokens_per_s": round(tokens_per_s, 1),
              "mfu": round(mfu, 4), "peak_tflops": args.peak_tflops, "peak_memory_gb": peak_gb,
              "final_loss": float(loss.detach())}
    rows = [[name, info["gpu"] or "CPU", args.micro_batch, args.seq_len, f"{step_s:.3f}", f"{tokens_per_s:,.0f}",
             f"{mfu:.1%}", f"{peak_gb:.1f}" if peak_gb is not None else "—"]]
    md = header_md(f"Stage II step at full size, random weights: {name}", info)
    md += md_table(["model", "device", "micro-batch", "tokens/example", "s/step (median)", "tokens/s", "MFU",
                    "peak memory, GB"], rows)
    md += (f"\n{len(times)} timed steps after {args.warmup} warm-up; LoRA r {config.lora.r}, "
           f"{result['trainable_parameters'] / 1e6:.1f} M trainable of {result['parameters'] / 1e9:.2f} B; "
           f"activation checkpointing {'on' if config.model.gradient_checkpointing else 'off'}; "
           f"{args.answer_fraction:.0%} of positions labelled. MFU: 6 N + 12 L H S FLOPs per token over "
           f"{args.peak_tflops:g} TFLOP/s (module docstring).\n")
    slug = name.lower().replace(" ", "_").replace("(", "").replace(")", "").replace(".", "")
    publish(f"stage2_step_{slug}", result, md, Path(args.out) if args.out else None)


if __name__ == "__main__":
    main()
