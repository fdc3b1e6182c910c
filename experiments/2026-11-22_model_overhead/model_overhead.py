"""What does the tactile path cost? One training step of the full model vs the bare LLM, same text tokens.

Both run the same batch of token ids (the bare LLM sees the placeholder ids as ordinary tokens), the
same LoRA adapter on q/k/v/o and AdamW. The full model adds the frozen appearance ViT, the temporal
branch, fusion and projector. Steps of the variants are interleaved (round robin) so machine noise
hits them alike; the ratio of medians is the figure. Also: encoder throughput in clips/s (forward,
no grad) and the CPU cost of preparing a clip (decode + sample + resize + background subtraction).

    python benchmarks/model_overhead.py [--steps 12 --batch 8]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp
from tacreasoner.model.configuration import TacReasonerConfig
from tacreasoner.model.encoder_config import TactileEncoderConfig
from tacreasoner.model.modeling import TacReasonerForCausalLM
from tacreasoner.model.stages import LoraSettings, configure_stage
from tacreasoner.model.tiny import tiny_qwen2_config

VOCAB = 4096
TACTILE_ID = 4095


def make_batch(batch: int, tpv: int, question: int, answer: int, seed: int, vocab: int = VOCAB,
               tactile_id: int = TACTILE_ID) -> dict[str, torch.Tensor]:
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


def build(encoder: TactileEncoderConfig, seed: int = 0) -> TacReasonerForCausalLM:
    torch.manual_seed(seed)
    text = tiny_qwen2_config(VOCAB).to_dict()
    return TacReasonerForCausalLM(TacReasonerConfig(text_config=text, encoder=encoder.to_dict(),
                                                    tactile_token_id=TACTILE_ID)).train()


def step_fn(module: torch.nn.Module, inputs: dict, lr: float = 1e-4):
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


def time_steps(steps: dict[str, object], n: int, warmup: int = 2) -> dict[str, list[float]]:
    for fn in steps.values():
        for _ in range(warmup):
            fn()
    times: dict[str, list[float]] = {k: [] for k in steps}
    for _ in range(n):
        for name, fn in steps.items():
            times[name].append(fn())
    return times


def encoder_throughput(model: TacReasonerForCausalLM, batch: int, repeats: int) -> dict[str, float]:
    enc = model.tactile_encoder.eval()
    c = enc.config
    pv = torch.randn(batch, c.num_frames, 3, *c.image_size)
    q = torch.randn(batch, model.config.text_hidden_size)
    out = {}
    with torch.no_grad():
        for name, fn in (("appearance ViT only", lambda: enc.appearance(pv)),
                         ("full tactile encoder + projector", lambda: model.projector(enc(pv, q)))):
            fn()
            t0 = time.perf_counter()
            for _ in range(repeats):
                fn()
            out[name] = batch * repeats / (time.perf_counter() - t0)
    return out


def preprocessing_throughput(n_clips: int) -> dict[str, float]:
    import tempfile

    from tacreasoner.data.cache import clear_cache
    from tacreasoner.data.readers import read_sim_dataset
    from tacreasoner.model.video_processing import VideoProcessingConfig, preprocess_video
    from tacreasoner.sim.generate import generate_dataset

    with tempfile.TemporaryDirectory() as tmp:
        generate_dataset(tmp, n_objects=n_clips, repeats=1, sensors=["mini"], seed=0, workers=2)
        clips = list(read_sim_dataset(tmp))
        config = VideoProcessingConfig()
        clear_cache()
        t0 = time.perf_counter()
        for clip in clips:
            preprocess_video(clip, config)
        cold = len(clips) / (time.perf_counter() - t0)
        t0 = time.perf_counter()
        for clip in clips:
            preprocess_video(clip, config)
        warm = len(clips) / (time.perf_counter() - t0)
    return {"decode + prepare (cold cache)": cold, "prepare (frames cached)": warm}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=12)
    ap.add_argument("--batch", type=int, default=8)
    ap.add_argument("--question-tokens", type=int, default=48)
    ap.add_argument("--answer-tokens", type=int, default=96)
    ap.add_argument("--lora-r", type=int, default=128)
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    info = stamp()
    encoder = TactileEncoderConfig()
    data = make_batch(args.batch, encoder.tokens_per_video, args.question_tokens, args.answer_tokens, seed=0)
    n_videos = data.pop("n_videos")
    text_only = dict(data)
    lora = LoraSettings(r=args.lora_r, alpha=2 * args.lora_r, dropout=0.05)
    from peft import LoraConfig, get_peft_model

    bare = get_peft_model(build(encoder).language_model, LoraConfig(
        r=lora.r, lora_alpha=lora.alpha, lora_dropout=lora.dropout, target_modules=list(lora.target_modules)))
    pixel_values = torch.randn(n_videos, encoder.num_frames, 3, *encoder.image_size)
    full = {**data, "pixel_values": pixel_values}
    stage2 = configure_stage(build(encoder), 2, lora)
    stage1 = configure_stage(build(encoder), 1)
    cls_only = configure_stage(build(encoder.replace(tokens_per_video=1)), 2, lora)
    cls_data = make_batch(args.batch, 1, args.question_tokens, args.answer_tokens, seed=0)
    cls_data.pop("n_videos")
    with torch.no_grad():
        cached = stage2.base_model.model.tactile_encoder.appearance_tokens(pixel_values)
    steps = {
        "bare LLM + LoRA": step_fn(bare, text_only),
        "TacReasoner Stage II (LoRA + projector)": step_fn(stage2, full),
        "TacReasoner Stage II, appearance tokens cached": step_fn(stage2, {**full, "appearance_tokens": cached}),
        "TacReasoner Stage I (temporal + fusion + projector)": step_fn(stage1, full),
        "TacReasoner Stage II, CLS-only (1 token/video)": step_fn(cls_only, {**cls_data, "pixel_values": pixel_values}),
    }
    times = time_steps(steps, args.steps)
    base = statistics.median(times["bare LLM + LoRA"])
    rows, results = [], {}
    for name, ts in times.items():
        med = statistics.median(ts)
        results[name] = {"median_s": med, "ratio_vs_bare": med / base, "times_s": ts}
        rows.append([name, med * 1000, med / base])
    throughput = encoder_throughput(stage2.base_model.model, args.batch, repeats=5)
    prep = preprocessing_throughput(16)
    tokens = int(data["attention_mask"].sum())
    params = {"llm": sum(p.numel() for p in stage2.base_model.model.language_model.parameters()),
              "appearance": sum(p.numel() for p in stage2.base_model.model.tactile_encoder.appearance.parameters()),
              "temporal+fusion": sum(p.numel() for n, p in stage2.base_model.model.tactile_encoder.named_parameters()
                                     if not n.startswith("appearance")),
              "projector": sum(p.numel() for p in stage2.base_model.model.projector.parameters())}
    payload = {**info, "settings": vars(args), "tokens_per_batch": tokens, "videos_per_batch": n_videos,
               "encoder": encoder.to_dict(), "parameters": params, "train_step": results,
               "encoder_clips_per_s": throughput, "preprocessing_clips_per_s": prep}
    md = header_md("Tactile path overhead (tiny default config, CPU)", info)
    md += (f"Batch: {args.batch} samples with 1/2/3 videos in turn ({n_videos} videos, {tokens} tokens; "
           f"{args.question_tokens} question + {args.answer_tokens} answer tokens each, "
           f"{encoder.tokens_per_video} tactile tokens per video). LoRA r={lora.r}, α={lora.alpha} on q/k/v/o; "
           f"AdamW. Median of {args.steps} interleaved steps, torch threads = {args.threads}.\n\n")
    md += md_table(["variant", "step (ms)", "× bare LLM"], rows)
    md += "\nParameters: " + ", ".join(f"{k} {v / 1e6:.2f} M" for k, v in params.items()) + "\n\n"
    md += f"## Encoder throughput (forward, no grad, batch of {args.batch})\n\n"
    md += md_table(["part", "clips/s"], [[k, v] for k, v in throughput.items()])
    md += "\n## Preparing clips (PyAV decode, sample 8 frames, resize to 64×64, background subtraction)\n\n"
    md += md_table(["path", "clips/s"], [[k, v] for k, v in prep.items()])
    publish("model_overhead", payload, md)


if __name__ == "__main__":
    main()
