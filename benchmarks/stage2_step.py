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
``--measure-peak`` also times a large bf16 matmul on the same device, so the MFU is given against what the chip
reaches as well as its data-sheet peak; ``--profile`` adds one profiled step's top operators (where the time goes).
Results: benchmarks/results/stage2_step_<model>_mb<micro-batch>.{json,md}.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, matmul_seconds, md_table, publish, stamp


def build(config_path: str, layers: int | None, device: str, dtype: str = "bfloat16", vocab_size: int | None = None):
    """The Stage II model of ``config_path`` at its LLM's published shape, random weights, on ``device``, its frozen
    weights in ``dtype``."""
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
        shrunk = {"num_hidden_layers": layers, **({"vocab_size": vocab_size} if vocab_size else {})}
        text = type(text)(**{**fields, **shrunk})
        name = f"{name} ({layers} layers)"
    vocab = int(text.vocab_size)
    new_ids = list(range(vocab - 5, vocab))  # the 5 tokens build_model adds: rows Stage II trains too
    encoder = TactileEncoderConfig.from_dict(config.model.encoder)
    model_config = TacReasonerConfig(text_config=text.to_dict(), encoder=encoder.to_dict(),
                                     tactile_token_id=new_ids[0], new_token_ids=new_ids)
    previous = torch.get_default_dtype()
    torch.set_default_dtype(getattr(torch, dtype))  # bf16 unless asked: 7B in fp32 would need 30 GB first
    try:
        with torch.device(device):
            model = TacReasonerForCausalLM(model_config)
    finally:
        torch.set_default_dtype(previous)
    if dtype == "float32":
        model.float()  # the text config's own torch_dtype (bf16) sets the LLM's, whatever the default dtype
    if config.model.gradient_checkpointing:
        enable_activation_checkpointing(model.language_model)
    trained = configure_stage(model, 2, config.lora)
    master_weights_in_fp32(trained, "bf16" if dtype == "bfloat16" else "no")
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


def planned_memory_gb(config_path: str, micro_batch: int, seq_len: int, answer_fraction: float,
                      layers: int | None) -> float | None:
    """What ``tacreasoner memory-plan`` predicts for this step on one GPU (None for a cut-down model)."""
    from tacreasoner.train.config import load_train_config
    from tacreasoner.train.memory_plan import GB, plan_for_config

    if layers is not None:
        return None
    base = load_train_config(config_path)
    if base.stage2.global_batch % micro_batch:
        return None
    config = load_train_config(config_path, {"stage2.grad_accum": base.stage2.global_batch // micro_batch,
                                             "data.max_length": seq_len})
    (plan,) = plan_for_config(config, stage=2, world_sizes=(1,), gpu_gb=1000.0, answer_fraction=answer_fraction)
    assert plan.batch_size == micro_batch, (plan.batch_size, micro_batch)
    return plan.total / GB


def measured_peak_tflops(device: str, size: int, repeats: int = 10, dtype: str = "bfloat16") -> float:
    """Matmul TFLOP/s that this device reaches in ``dtype`` (size³ products, mean of ``repeats`` after 3 warm-ups)."""
    times = matmul_seconds(size, dtype, repeats, warmup=3, device=device)
    return 2 * size ** 3 * len(times) / sum(times) / 1e12


def profile_step(step, device: str, top: int = 15) -> tuple[list[dict], float]:
    """One step under torch.profiler: the operators taking the most device (on a CPU, self CPU) time, each with its
    share of the device's busy time, and that busy time in ms. On a GPU the busy time sums the kernels, each once:
    an operator's self device time is its kernels' time, so adding kernel rows and operator rows would count it
    twice."""
    from torch.profiler import ProfilerActivity, profile

    activities = [ProfilerActivity.CPU] + ([ProfilerActivity.CUDA] if device == "cuda" else [])
    with profile(activities=activities) as prof:
        step()
    events = list(prof.key_averages())
    if device == "cuda":
        key = "self_device_time_total"
        kernels = [e for e in events if str(getattr(e, "device_type", "")).endswith("CUDA")]
        ops = [e for e in events if e not in kernels]
        busy = sum(getattr(e, key) for e in kernels)
    else:
        key, ops = "self_cpu_time_total", events
        busy = sum(getattr(e, key) for e in events)
    rows = sorted(ops, key=lambda e: getattr(e, key), reverse=True)[:top]
    return ([{"op": e.key, "calls": e.count, "ms": round(getattr(e, key) / 1e3, 2),
              "share": round(getattr(e, key) / (busy or 1.0), 4)} for e in rows], busy / 1e3)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--config", default="configs/qwen2.5-7b.yaml")
    parser.add_argument("--micro-batch", type=int, default=8)
    parser.add_argument("--seq-len", type=int, default=1024)
    parser.add_argument("--answer-fraction", type=float, default=0.3)
    parser.add_argument("--steps", type=int, default=10)
    parser.add_argument("--warmup", type=int, default=3)
    parser.add_argument("--layers", type=int, default=None, help="fewer decoder layers (a CPU smoke test)")
    parser.add_argument("--vocab-size", type=int, default=None,
                        help="with --layers, a smaller vocabulary too (a CPU smoke test: 7B's 152k rows, in and "
                             "out, are 4 GB in fp32)")
    parser.add_argument("--peak-tflops", type=float, default=989.0, help="the GPU's dense bf16 peak")
    parser.add_argument("--measure-peak", action="store_true", help="also time a large matmul (in --dtype) here")
    parser.add_argument("--dtype", choices=("bfloat16", "float32"), default="bfloat16",
                        help="the step's compute and frozen weights; float32 for a CPU smoke test, where a CPU "
                             "without native bf16 emulates it ~100x slower (a one-layer step took over 10 minutes)")
    parser.add_argument("--profile", action="store_true", help="also profile one step: where the time goes")
    parser.add_argument("--out", default=None, help="results directory (default benchmarks/results)")
    args = parser.parse_args()
    if args.vocab_size is not None and args.layers is None:
        parser.error("--vocab-size is for a cut-down model: give --layers too (a full-size step keeps its vocabulary)")

    import torch

    cuda = torch.cuda.is_available()
    device = "cuda" if cuda else "cpu"
    info = stamp()
    info["gpu"] = torch.cuda.get_device_name() if cuda else None
    started = time.perf_counter()
    name, config, model, trained = build(args.config, args.layers, device, args.dtype, args.vocab_size)
    build_s = time.perf_counter() - started
    params = [p for p in trained.parameters() if p.requires_grad]
    optimizer = torch.optim.AdamW(params, lr=config.stage2.lr, fused=cuda)
    inputs = batch(model, args.micro_batch, args.seq_len, args.answer_fraction, device)
    labelled = int((inputs["labels"][:, 1:] != -100).sum())
    trained.train()
    if cuda:
        torch.cuda.reset_peak_memory_stats()

    def one_step() -> torch.Tensor:
        with torch.autocast(device, dtype=torch.bfloat16, enabled=args.dtype == "bfloat16"):
            loss = trained(**inputs, num_items_in_batch=labelled, loss_only=True).loss
        loss.backward()
        torch.nn.utils.clip_grad_norm_(params, config.stage2.max_grad_norm)
        optimizer.step()
        optimizer.zero_grad(set_to_none=True)
        if cuda:
            torch.cuda.synchronize()
        return loss

    times = []
    for step in range(args.warmup + args.steps):
        if cuda:
            torch.cuda.synchronize()
        t0 = time.perf_counter()
        loss = one_step()
        if step >= args.warmup:
            times.append(time.perf_counter() - t0)
    step_s = sorted(times)[len(times) // 2]
    peak_gb = torch.cuda.max_memory_allocated() / 1e9 if cuda else None
    reserved_gb = torch.cuda.max_memory_reserved() / 1e9 if cuda else None
    profile, busy_ms = profile_step(one_step, device) if args.profile else (None, None)
    peak_size = 8192 if cuda else 1024  # the large square product of the measured peak
    measured = measured_peak_tflops(device, peak_size, dtype=args.dtype) if args.measure_peak else None
    planned_gb = planned_memory_gb(args.config, args.micro_batch, args.seq_len, args.answer_fraction, args.layers)
    tokens_per_s = args.micro_batch * args.seq_len / step_s
    text = model.config.text_config
    achieved_tflops = model_flops_per_token(text, args.seq_len) * tokens_per_s / 1e12
    mfu = achieved_tflops / args.peak_tflops
    result = {**info, "model": name, "config": args.config, "micro_batch": args.micro_batch, "seq_len": args.seq_len,
              "dtype": args.dtype,
              "answer_fraction": args.answer_fraction, "gradient_checkpointing": config.model.gradient_checkpointing,
              "lora": {"r": config.lora.r, "alpha": config.lora.alpha}, "trainable_parameters": sum(
                  p.numel() for p in params), "parameters": sum(p.numel() for p in model.parameters()),
              "build_seconds": round(build_s, 1), "step_seconds_median": round(step_s, 3),
              "step_seconds": [round(t, 3) for t in times], "tokens_per_s": round(tokens_per_s, 1),
              # 4 significant figures, not decimals: a cut-down step on a CPU without bf16 achieves ~0.0004 TFLOP/s
              "achieved_tflops": float(f"{achieved_tflops:.4g}"), "mfu": round(mfu, 4), "peak_tflops": args.peak_tflops,
              "measured_peak_tflops": float(f"{measured:.4g}") if measured else None,
              "mfu_of_measured_peak": round(achieved_tflops / measured, 4) if measured else None,
              "peak_memory_gb": peak_gb, "peak_reserved_gb": reserved_gb, "memory_plan_gb": planned_gb,
              "final_loss": float(loss.detach()),
              "profile_top": profile, "profile_busy_ms": round(busy_ms, 1) if busy_ms else None}
    rows = [[name, info["gpu"] or "CPU", args.micro_batch, args.seq_len, f"{step_s:.3f}", f"{tokens_per_s:,.0f}",
             f"{achieved_tflops:.1f}", f"{mfu:.1%}", f"{achieved_tflops / measured:.1%}" if measured else "—",
             f"{peak_gb:.1f}" if peak_gb is not None else "—", f"{planned_gb:.1f}" if planned_gb else "—"]]
    md = header_md(f"Stage II step at full size, random weights: {name}", info)
    md += md_table(["model", "device", "micro-batch", "tokens/example", "s/step (median)", "tokens/s",
                    "model TFLOP/s", f"MFU (of {args.peak_tflops:g})",
                    f"MFU (of measured {measured:.3g})" if measured else "MFU (of measured)", "peak memory, GB",
                    "memory-plan, GB"], rows)
    md += (f"\n{len(times)} timed steps after {args.warmup} warm-up; LoRA r {config.lora.r}, "
           f"{result['trainable_parameters'] / 1e6:.1f} M trainable of {result['parameters'] / 1e9:.2f} B; "
           f"activation checkpointing {'on' if config.model.gradient_checkpointing else 'off'}; "
           f"{args.answer_fraction:.0%} of positions labelled. MFU: 6 N + 12 L H S FLOPs per token over "
           f"{args.peak_tflops:g} TFLOP/s (module docstring).\n")
    if measured:
        md += (f"\nMeasured peak: a {peak_size}³ {args.dtype} matmul on this device ran at {measured:.1f} TFLOP/s "
               f"(mean of 10).\n")
    if reserved_gb is not None:
        md += (f"\nPeak memory: {peak_gb:.1f} GB allocated, {reserved_gb:.1f} GB reserved by PyTorch's allocator; "
               f"`tacreasoner memory-plan` predicts {planned_gb:.1f} GB for this micro-batch on one GPU (its "
               f"terms: frozen weights, trainable weights, gradients, AdamW, activations; no CUDA context).\n"
               if planned_gb else "")
    if profile:
        md += (f"\nOne step profiled (torch.profiler): the device was busy {busy_ms:.0f} ms; the operators with the "
               f"most self device time, each with its share of that busy time:\n\n")
        md += md_table(["operator", "calls", "ms", "share"],
                       [[p["op"], p["calls"], f"{p['ms']:.1f}", f"{p['share']:.1%}"] for p in profile])
    slug = name.lower().replace(" ", "_").replace("(", "").replace(")", "").replace(".", "")
    slug += f"_mb{args.micro_batch}"
    publish(f"stage2_step_{slug}", result, md, Path(args.out) if args.out else None)


if __name__ == "__main__":
    main()
