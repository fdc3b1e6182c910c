"""How close the quickstart's training, evaluation and serving run to this CPU's matmul peak: achieved FLOP/s.

The quickstart is said to be compute-bound; this measures it. One run, side by side on one machine:

1. **The peak**: a large square matmul (``--matmul-n``) timed in float32 and in bfloat16 with torch's threads, the
   best of ``--reps`` (2·n³ FLOPs each): what this CPU reaches on the one kernel the model is mostly made of.
2. **Training steps**: ``--steps`` Stage I and Stage II steps of the quickstart's recipe on a finished run folder
   (its data, LLM, encoder and Stage I model; ``_common.quickstart_stage_config``), as the trainer runs them (its
   own autocast, packing and LoRA). One step after the warm-up is run under ``torch.utils.flop_counter`` to count
   the FLOPs a step really does (forward and backward, encoder and LM head included, matmuls and convolutions;
   the counted step is not timed); FLOPs per token × the other steps' tokens per second = achieved FLOP/s.
   Tokens are the unpacked rows' (the trainer's ``tokens_per_s``): packing's saving shows as a higher figure.
3. **Evaluation's generation**: ``--items`` val items answered as ``tacreasoner evaluate`` answers them
   (``predict_items``, the quickstart's batch and reply budget, float32), timed; their FLOPs counted in a second,
   untimed pass.
4. **Serving, where a request's time goes**: one two-video request through the engine: preparing it (decoding the
   clips, tokenising), the tactile encoder, the LLM's prefill, and each generated token; then 8 such requests one
   after another against one batched call (batching's gain).

    python benchmarks/train_flops.py [--run runs/quickstart] [--steps 30] [--items 96]

Results: benchmarks/results/train_flops.{json,md}. Do not run it beside other jobs: every figure is a rate.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, matmul_seconds, md_table, publish, quickstart_stage_config, stamp

WARMUP = 3


def matmul_peak(dtype_name: str, n: int, reps: int) -> dict[str, float]:
    """Best GFLOP/s of an n×n×n matmul in ``dtype_name`` (the first call, a warm-up, not counted)."""
    best = min(matmul_seconds(n, dtype_name, reps, warmup=1))
    return {"n": n, "best_s": best, "gflops": 2 * n**3 / best / 1e9}


class StepMeter:
    """The trainer's ``on_log`` (one record per step): times the steps after the warm-up, counts the FLOPs of step
    ``count_at`` and profiles the ``PROFILED`` steps from ``profile_at`` (neither is timed: both slow a step)."""

    def __init__(self, count_at: int, profile_at: int | None = None) -> None:
        self.count_at, self.profile_at = count_at, profile_at
        self.step = 0
        self.rates: list[float] = []
        self.seconds: list[float] = []
        self.counter: Any = None
        self.counted: tuple[float, float] | None = None
        self.profiler: Any = None
        self.profile: list[dict[str, Any]] | None = None
        self.skip_next = False
        self.last_elapsed = 0.0

    def __call__(self, record: dict[str, Any]) -> None:
        import torch
        from torch.utils.flop_counter import FlopCounterMode

        seconds = record["elapsed_s"] - self.last_elapsed
        self.last_elapsed = record["elapsed_s"]
        tokens = record.get("tokens_per_s", 0.0) * seconds
        if self.counter is not None:  # the step that just ended was counted
            self.counter.__exit__(None, None, None)
            self.counted = (float(self.counter.get_total_flops()), tokens)
            self.counter = None
        elif self.profiler is not None:  # ... or profiled
            if self.step == self.profile_at + PROFILED:
                self.profiler.stop()
                self.profile = op_times(self.profiler)
                self.profiler = None
                self.skip_next = True  # the summing-up above lands in the next step's elapsed time
        elif self.skip_next:
            self.skip_next = False
        elif self.step >= WARMUP:
            self.rates.append(record["tokens_per_s"])
            self.seconds.append(seconds)
        self.step += 1
        if self.step == self.count_at:
            self.counter = FlopCounterMode(display=False)
            self.counter.__enter__()
        elif self.step == self.profile_at:
            self.profiler = torch.profiler.profile(activities=[torch.profiler.ProfilerActivity.CPU])
            self.profiler.start()


PROFILED = 3
"""Stage II steps profiled (torch.profiler, CPU)."""
OP_GROUPS = (
    ("matmul (linear layers, LoRA, LM head)", ("aten::mm", "aten::addmm", "aten::bmm", "aten::matmul", "aten::linear",
                                              "aten::_mkldnn", "mkldnn")),
    ("attention kernel", ("scaled_dot_product", "flash_attention", "_efficient_attention")),
    ("convolution", ("conv",)),
    ("optimizer", ("_foreach", "adam", "aten::lerp", "aten::addcdiv", "aten::addcmul", "aten::sqrt")),
    ("casts and copies (autocast, contiguous)", ("aten::copy_", "aten::to", "aten::_to_copy", "aten::clone",
                                                 "aten::contiguous")),
    ("softmax, norms, activations", ("softmax", "norm", "silu", "gelu", "aten::rsqrt", "aten::pow", "aten::mean")),
    ("loss (log-softmax over the vocabulary)", ("log_softmax", "nll_loss", "cross_entropy")),
)


def op_times(profiler: Any) -> list[dict[str, Any]]:
    """Self CPU time per op group over the profiled steps, largest first (ops named in no group: "other")."""
    totals: dict[str, float] = {}
    for event in profiler.key_averages():
        name = event.key.lower()
        group = next((g for g, keys in OP_GROUPS if any(k.lower() in name for k in keys)), "other")
        totals[group] = totals.get(group, 0.0) + event.self_cpu_time_total / 1e6
    whole = sum(totals.values()) or 1.0
    return [{"group": g, "seconds_per_step": t / PROFILED, "share": t / whole}
            for g, t in sorted(totals.items(), key=lambda kv: -kv[1])]


def train_steps(run: Path, stage: int, steps: int, work: Path) -> dict[str, float]:
    from tacreasoner.train.trainer import train_stage

    config = quickstart_stage_config(run, stage, steps, work / f"stage{stage}")
    meter = StepMeter(count_at=steps // 2, profile_at=steps // 2 + 2 if stage == 2 else None)
    train_stage(config, stage, on_log=meter)
    if meter.counted is None or not meter.rates or (stage == 2 and meter.profile is None):
        raise SystemExit(f"stage {stage}: too few steps to time, count and profile ({steps}); give --steps 12 or more")
    flops, tokens = meter.counted
    per_token = flops / tokens
    rate = statistics.mean(meter.rates)
    return {"steps_timed": len(meter.rates), "s_per_step": statistics.mean(meter.seconds),
            "tokens_per_s": rate, "flops_per_token": per_token, "gflops": per_token * rate / 1e9,
            "precision": config.runtime.mixed_precision, "profile": meter.profile}


def _items(run: Path, n: int) -> tuple[list[Any], Path]:
    from tacreasoner.tasks.bench import load_bench
    from tacreasoner.train.data import bench_video_root

    info, items = load_bench(run / "bench", "val")
    return items[:: max(1, len(items) // n)][:n], bench_video_root(run / "bench", info)


def evaluation(run: Path, n: int, batch_size: int, max_new_tokens: int, work: Path) -> dict[str, float]:
    """``predict_items`` on ``n`` val items, timed, then its FLOPs counted in a second pass."""
    from torch.utils.flop_counter import FlopCounterMode

    from tacreasoner.evaluate.predict import load_trained, predict_items

    model, processor = load_trained(run / "model", dtype="float32")
    items, root = _items(run, n)
    start = time.perf_counter()
    predict_items(model, processor, items, root, work / "timed.jsonl", batch_size=batch_size,
                  max_new_tokens=max_new_tokens)
    seconds = time.perf_counter() - start
    with FlopCounterMode(display=False) as counter:
        predict_items(model, processor, items, root, work / "counted.jsonl", batch_size=batch_size,
                      max_new_tokens=max_new_tokens)
    flops = float(counter.get_total_flops())
    return {"items": len(items), "seconds": seconds, "items_per_s": len(items) / seconds, "flops": flops,
            "gflops": flops / seconds / 1e9}


def serving(run: Path, requests: int = 8) -> dict[str, Any]:
    """One two-video request's time split into its parts, and batching's gain over ``requests`` of them."""
    import torch

    from tacreasoner.serve.engine import Prompt, Sampling, TactileEngine

    engine = TactileEngine.load(run / "model", dtype="float32")
    items, root = _items(run, 200)
    item = next(i for i in items if len(i.videos) == 2)
    prompt = Prompt.ask(item.question, [str(root / v.path) for v in item.videos])
    sampling = Sampling(max_new_tokens=16)
    engine.complete(prompt, sampling)  # warm-up
    prepared = engine.prepare(prompt)
    batch = dict(engine.processor.collate([prepared.row]))
    model = engine._base
    keys = ("input_ids", "pixel_values", "attention_mask", "question_mask", "sensor_ids")
    encoder_s = []
    for _ in range(3):
        start = time.perf_counter()
        with torch.inference_mode():
            model.embed_inputs(**{k: batch[k] for k in keys if k in batch})
        encoder_s.append(time.perf_counter() - start)
    first = engine.complete(prepared, Sampling(max_new_tokens=1))
    whole = engine.complete(prepared, sampling)
    generated = max(whole.completion_tokens - 1, 1)
    one_by_one = time.perf_counter()
    for _ in range(requests):
        engine.complete(engine.prepare(prompt), sampling)
    one_by_one = time.perf_counter() - one_by_one
    together = time.perf_counter()
    engine.complete_batch([engine.prepare(prompt) for _ in range(requests)], [sampling] * requests)
    together = time.perf_counter() - together
    encoder = min(encoder_s)
    return {"prompt_tokens": prepared.prompt_tokens, "prepare_s": prepared.prepare_s, "encoder_s": encoder,
            "prefill_s": max(first.timings["decode_s"] - encoder, 0.0),
            "per_token_s": max(whole.timings["decode_s"] - first.timings["decode_s"], 0.0) / generated,
            "generated_tokens": whole.completion_tokens, "requests": requests, "one_by_one_s": one_by_one,
            "batched_s": together, "batching_gain": one_by_one / together}


def decode_by_dtype(run: Path, rounds: int = 4, tokens: int = 32) -> dict[str, dict[str, float]]:
    """A generated token's and a prefill's seconds with the weights in float32 and in bfloat16, alternated round by
    round (median of the rounds after the first): decoding one token reads every weight once, so its time follows the
    weights' bytes more than their FLOPs. ``tokens`` tokens are forced (no end of turn) so each call decodes alike."""
    import torch

    from tacreasoner.serve.engine import Prompt, TactileEngine

    items, root = _items(run, 200)
    item = next(i for i in items if len(i.videos) == 1)
    prompt = Prompt.ask(item.question, [str(root / v.path) for v in item.videos])
    engines = {d: TactileEngine.load(run / "model", dtype=d) for d in ("float32", "bfloat16")}
    seen: dict[str, list[tuple[float, float]]] = {d: [] for d in engines}
    for k in range(rounds):
        order = list(engines) if k % 2 == 0 else list(reversed(engines))
        for name in order:
            engine = engines[name]
            batch = dict(engine.processor.collate([engine.prepare(prompt).row]))
            pad = engine.processor.tokenizer.pad_token_id
            with torch.inference_mode():
                start = time.perf_counter()
                engine._base.generate(**batch, max_new_tokens=1, do_sample=False, pad_token_id=pad)
                first = time.perf_counter() - start
                start = time.perf_counter()
                engine._base.generate(**batch, max_new_tokens=tokens + 1, min_new_tokens=tokens + 1, do_sample=False,
                                      pad_token_id=pad)
                whole = time.perf_counter() - start
            if k:
                seen[name].append(((whole - first) / tokens, first))
    return {name: {"per_token_s": statistics.median(t for t, _ in v),
                   "encoder_and_prefill_s": statistics.median(f for _, f in v)} for name, v in seen.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--run", type=Path, default=Path("runs/quickstart"), help="A finished quickstart run folder.")
    ap.add_argument("--steps", type=int, default=30, help="Training steps per stage (the first 3 not timed).")
    ap.add_argument("--items", type=int, default=96, help="Val items answered for the evaluation's figure.")
    ap.add_argument("--matmul-n", type=int, default=2048)
    ap.add_argument("--reps", type=int, default=10)
    args = ap.parse_args()
    if not (args.run / "model" / "config.json").is_file():
        sys.exit(f"{args.run}: no model/ — run `tacreasoner quickstart` first")
    import torch

    from tacreasoner.recipes.quickstart import QuickstartSettings

    settings = QuickstartSettings.load()
    info = stamp()
    info["torch_threads"] = torch.get_num_threads()
    peak = {d: matmul_peak(d, args.matmul_n, args.reps) for d in ("float32", "bfloat16")}
    with tempfile.TemporaryDirectory() as tmp:
        stages = {f"stage{s}": train_steps(args.run, s, args.steps, Path(tmp)) for s in (1, 2)}
        answering = evaluation(args.run, args.items, settings.eval_batch_size, settings.max_new_tokens, Path(tmp))
    served = serving(args.run)
    by_dtype = decode_by_dtype(args.run)
    best = max(p["gflops"] for p in peak.values())
    rows = [[f"matmul {args.matmul_n}³, {d}", "", round(p["gflops"], 1), f"{p['gflops'] / best:.0%}"]
            for d, p in peak.items()]
    for name, s in stages.items():
        rows.append([f"Stage {'I' if name == 'stage1' else 'II'} step ({s['precision']} autocast)",
                     f"{s['s_per_step']:.2f} s/step, {s['tokens_per_s']:.0f} tokens/s, "
                     f"{s['flops_per_token'] / 1e6:.0f} MFLOP/token", round(s["gflops"], 1),
                     f"{s['gflops'] / best:.0%}"])
    rows.append(["evaluation (predict_items, float32)", f"{answering['items_per_s']:.2f} items/s over "
                 f"{answering['items']} val items", round(answering["gflops"], 1), f"{answering['gflops'] / best:.0%}"])
    md = header_md("Achieved FLOP/s of the quickstart's training, evaluation and serving against this CPU's peak", info)
    md += (f"Run: `{args.run}`; torch threads {info['torch_threads']}. FLOPs counted by `torch.utils.flop_counter` "
           "(matmuls and convolutions, forward and backward) on one real step or pass, not from a formula; the "
           "peak is the best of a large square matmul in each precision (module docstring).\n\n")
    md += md_table(["what", "rate", "GFLOP/s", "of the best peak"], rows)
    profile = stages["stage2"]["profile"]
    md += (f"\nWhere a Stage II step's time goes ({PROFILED} steps under `torch.profiler`, self CPU time per op "
           "group; the profiled steps are not among the timed ones):\n\n"
           + md_table(["op group", "s per step", "share"],
                      [[p["group"], round(p["seconds_per_step"], 3), f"{p['share']:.0%}"] for p in profile]))
    md += ("\nServing, one two-video request (float32, greedy, 16 tokens at most):\n\n"
           + md_table(["part", "seconds"], [
               ["preparing (decode the clips, tokenise)", round(served["prepare_s"], 3)],
               ["tactile encoder (+ text embeddings)", round(served["encoder_s"], 3)],
               [f"LLM prefill ({served['prompt_tokens']} prompt tokens)", round(served["prefill_s"], 3)],
               ["each generated token", round(served["per_token_s"], 4)],
               [f"{served['requests']} requests one by one", round(served["one_by_one_s"], 2)],
               [f"the same {served['requests']} in one batch (gain {served['batching_gain']:.2f}×)",
                round(served["batched_s"], 2)]]))
    f32, bf16 = by_dtype["float32"], by_dtype["bfloat16"]
    md += ("\nA generated token and the encoder + prefill of a one-video request, weights in float32 against bfloat16 "
           "(`--dtype`), alternated, median of 3 rounds, 32 tokens forced:\n\n"
           + md_table(["weights", "ms per generated token", "encoder + prefill s"],
                      [[d, round(1000 * v["per_token_s"], 1), round(v["encoder_and_prefill_s"], 3)]
                       for d, v in by_dtype.items()])
           + f"\nbfloat16 takes {bf16['per_token_s'] / f32['per_token_s']:.2f}× float32's time per token: decoding "
             "reads every weight once per token, so it goes with the weights' bytes (a 135M model's fp32 weights are "
             "0.54 GB a token).\n")
    publish("train_flops", {**info, "run": str(args.run), "peak": peak, "training": stages,
                             "evaluation": answering, "serving": served, "decode_by_dtype": by_dtype}, md)


if __name__ == "__main__":
    main()
