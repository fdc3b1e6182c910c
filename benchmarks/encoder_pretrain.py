"""Does masked-video pre-training give the appearance encoder better frozen features than random init?

Objects of a DynTAC-Sim dataset are split in two halves. The encoder is pre-trained with the default
settings (``pretrain_encoder`` defaults, the same as ``tacreasoner pretrain-encoder``) on the clips of
the first half plus every PhysiCLeAR clip when that data is present (real video, labels unused). The
clips of the other half — objects the encoder never saw — are encoded by the FROZEN encoder, and a
linear probe (multinomial logistic regression, 5-fold cross-validation with object-level folds)
reads the VTV-150K attributes and real vs fake from two clip features: the CLS token and the mean of
the patch tokens. The same architecture with random initialisation (several seeds) is the baseline.
Encoder throughput is timed too (forward only, batch of 8 clips, float32).

    python benchmarks/encoder_pretrain.py [--data runs/bench/sim_learnability] [--no-physiclear]
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import time
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp
from tacreasoner.data.readers import default_physiclear_dir, read_physiclear, read_sim_dataset
from tacreasoner.data.splits import object_level_split
from tacreasoner.evaluate.probe import cross_validate_probe
from tacreasoner.model.appearance import AppearanceEncoder, num_parameters
from tacreasoner.model.encoder_config import TactileEncoderConfig
from tacreasoner.model.video_processing import VideoProcessingConfig, preprocess_video
from tacreasoner.sim.generate import generate_dataset
from tacreasoner.train.pretrain_encoder import DEFAULTS, pretrain_encoder
from tacreasoner.train.threads import free_threads

TASKS = [("hardness", "vtv150k", "hardness"), ("protrusion", "vtv150k", "protrusion"),
         ("elasticity", "vtv150k", "elasticity"), ("friction", "vtv150k", "friction")]
REAL_TASKS = [("hardness", "physiclear", "hardness"), ("roughness", "physiclear", "roughness"),
              ("bumpiness", "physiclear", "bumpiness")]
REAL_FAKE = "real vs fake (fruit only)"


FEATURES = {"cls": "CLS token", "mean_patch": "mean patch token",
            "slice_means": "mean patch token per time slice (CLS-less part of F_app at tokens_per_video=5)"}


def features(encoder: AppearanceEncoder, videos: torch.Tensor, batch: int = 32) -> dict[str, np.ndarray]:
    """Per clip, from the frozen encoder: CLS token, mean patch token, and the patch-token mean of each time slice
    (what ``DynamicTactileEncoder.appearance_tokens`` pools the patch tokens into when tokens_per_video − 1 equals
    the number of time slices)."""
    encoder.eval()
    slices = encoder.config.grid[0]
    out: dict[str, list[torch.Tensor]] = {name: [] for name in FEATURES}
    with torch.no_grad():
        for i in range(0, len(videos), batch):
            tokens = encoder(videos[i:i + batch])
            patches = tokens[:, 1:]
            out["cls"].append(tokens[:, 0])
            out["mean_patch"].append(patches.mean(dim=1))
            out["slice_means"].append(patches.reshape(len(patches), slices, -1, patches.shape[-1]).mean(2).flatten(1))
    return {name: torch.cat(parts).double().numpy() for name, parts in out.items()}


def probe_all(feats: dict[str, np.ndarray], clips: list, tasks: list[tuple[str, str, str]], seed: int,
              real_fake: bool) -> dict[str, dict[str, dict]]:
    """{feature: {task: probe result}} with object-level folds."""
    groups = np.asarray([c.object_id for c in clips])
    out: dict[str, dict[str, dict]] = {}
    for name, x in feats.items():
        res = {}
        for title, vocab, attr in tasks:
            y = np.asarray([c.labels[vocab][attr] for c in clips])
            res[title] = cross_validate_probe(x, y, groups, n_splits=5, seed=seed).__dict__
        if real_fake:
            fruit = np.asarray([c.labels.get("real") is not None for c in clips])
            y = np.asarray([int(bool(c.labels.get("real"))) for c in clips])
            res[REAL_FAKE] = cross_validate_probe(x[fruit], y[fruit], groups[fruit], n_splits=5, seed=seed).__dict__
        out[name] = res
    return out


def comparison(results: dict[str, dict], pretrained: list[str], random: list[str]) -> tuple[list[list], dict]:
    """Table rows (feature, task, pre-trained mean ± std, random mean ± std, Δ) and a summary per feature."""
    rows, summary = [], {}
    for feat in FEATURES:
        tasks = list(results[pretrained[0]][feat])
        pt = np.asarray([[results[k][feat][t]["balanced_accuracy"] for t in tasks] for k in pretrained])
        rnd = np.asarray([[results[k][feat][t]["balanced_accuracy"] for t in tasks] for k in random])
        summary[feat] = {"pretrained_mean": float(pt.mean()), "pretrained_std_over_seeds": float(pt.mean(1).std()),
                         "random_mean": float(rnd.mean()), "random_std_over_seeds": float(rnd.mean(1).std()),
                         "delta": float(pt.mean() - rnd.mean())}
        for i, task in enumerate(tasks):
            rows.append([feat, task, f"{pt[:, i].mean():.3f} ± {pt[:, i].std():.3f}",
                         f"{rnd[:, i].mean():.3f} ± {rnd[:, i].std():.3f}", float(pt[:, i].mean() - rnd[:, i].mean()),
                         results[pretrained[0]][feat][task]["majority_baseline"]])
        rows.append([feat, f"**mean of {len(tasks)}**", f"**{pt.mean():.3f}** ± {pt.mean(1).std():.3f}",
                     f"{rnd.mean():.3f} ± {rnd.mean(1).std():.3f}", float(pt.mean() - rnd.mean()), ""])
    return rows, summary


def throughput(encoder: AppearanceEncoder, config: TactileEncoderConfig, repeats: int = 20) -> float:
    """Clips per second, forward only, batch of 8 (median of ``repeats`` timed batches after 3 warm-up)."""
    x = torch.randn(8, config.num_frames, 3, *config.image_size)
    encoder.eval()
    times = []
    with torch.no_grad():
        for i in range(repeats + 3):
            t = time.perf_counter()
            encoder(x)
            if i >= 3:
                times.append(time.perf_counter() - t)
    return 8 / float(np.median(times))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default="runs/bench/sim_learnability", help="DynTAC-Sim dataset (made if missing)")
    ap.add_argument("--objects", type=int, default=150)
    ap.add_argument("--repeats", type=int, default=4)
    ap.add_argument("--physiclear", action=argparse.BooleanOptionalAction, default=True)
    ap.add_argument("--out", default="runs/bench/encoder_pretrain", help="where the pre-trained encoders go")
    ap.add_argument("--steps", type=int, default=DEFAULTS.steps)
    ap.add_argument("--pretrain-seeds", type=int, default=2)
    ap.add_argument("--random-seeds", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    generate_dataset(args.data, args.objects, args.repeats, ["mini"], seed=0, workers=2)
    sim = list(read_sim_dataset(args.data))
    split = object_level_split([c.object_id for c in sim], (0.5, 0.5), seed=args.seed, names=("pretrain", "probe"))
    pre = [c for c in sim if split[c.object_id] == "pretrain"]
    probe = [c for c in sim if split[c.object_id] == "probe"]
    real = list(read_physiclear(min_frames=8)) if args.physiclear and default_physiclear_dir() else []
    config = TactileEncoderConfig()
    video = VideoProcessingConfig(num_frames=config.num_frames, image_size=config.image_size)

    runs = []
    for k in range(args.pretrain_seeds):
        out = Path(args.out) / f"seed-{args.seed + k}"
        shutil.rmtree(out, ignore_errors=True)
        threads = free_threads()
        t0 = time.perf_counter()
        pretrain_encoder(pre + real, out, encoder_config=config, video_config=video, steps=args.steps,
                         seed=args.seed + k, progress=False)
        log = [json.loads(line) for line in (out / "pretrain_log.jsonl").read_text().splitlines()]
        runs.append({"seed": args.seed + k, "dir": str(out), "threads": threads,
                     "time_s": round(time.perf_counter() - t0, 1), "preprocess_s": log[-1]["preprocess_s"],
                     "first_loss": log[0]["loss"], "final_loss": log[-1]["loss"]})
        print(f"pre-trained seed {args.seed + k}: {runs[-1]}", flush=True)

    sim_videos = torch.from_numpy(np.stack([preprocess_video(c, video) for c in probe]))
    labelled_real = [c for c in real if c.labels.get("physiclear")]
    real_videos = torch.from_numpy(np.stack([preprocess_video(c, video) for c in labelled_real])) if real else None
    encoders = {f"pretrained_{r['seed']}": AppearanceEncoder.from_pretrained(r["dir"]) for r in runs}
    for s in range(args.random_seeds):
        torch.manual_seed(s)
        encoders[f"random_{s}"] = AppearanceEncoder(config)
    results, results_real = {}, {}
    for name, encoder in encoders.items():
        results[name] = probe_all(features(encoder, sim_videos), probe, TASKS, args.seed, real_fake=True)
        if real_videos is not None:
            results_real[name] = probe_all(features(encoder, real_videos), labelled_real, REAL_TASKS, args.seed,
                                           real_fake=False)
    pretrained_keys = [k for k in encoders if k.startswith("pretrained")]
    random_keys = [k for k in encoders if k.startswith("random")]
    rows, summary = comparison(results, pretrained_keys, random_keys)
    speed_threads = torch.get_num_threads()
    speed = throughput(encoders[pretrained_keys[0]], config)

    info = stamp()
    first = runs[0]
    payload = {**info, "settings": {**vars(args), "pretrain_defaults": DEFAULTS.__dict__},
               "encoder_config": config.to_dict(), "parameters": num_parameters(encoders[pretrained_keys[0]]),
               "n_pretrain_clips": {"sim": len(pre), "physiclear": len(real)},
               "n_probe_clips": len(probe), "n_probe_objects": len({c.object_id for c in probe}),
               "pretrain_runs": runs, "throughput_clips_per_s": round(speed, 1), "throughput_threads": speed_threads,
               "summary": summary, "results": results}
    md = header_md("Appearance encoder: masked-video pre-training vs random init, frozen features on unseen objects",
                   info)
    n_pre_objects = len({c.object_id for c in pre})
    md += (f"Pre-training: default settings ({args.steps} steps, batch {DEFAULTS.batch_size}, mask ratio "
           f"{DEFAULTS.mask_ratio}, lr {DEFAULTS.lr}) on {len(pre)} simulated clips of {n_pre_objects} "
           f"objects + {len(real)} PhysiCLeAR clips (real, labels unused), {args.pretrain_seeds} seeds. Seed "
           f"{first['seed']}: **{first['time_s']:.0f} s wall in all** ({first['preprocess_s']:.0f} s of it decoding "
           f"and preprocessing, {first['threads']} torch thread(s)); reconstruction loss {first['first_loss']:.4f} → "
           f"{first['final_loss']:.4f}. All runs: "
           + ", ".join(f"seed {r['seed']} {r['time_s']:.0f} s ({r['threads']} thread(s))" for r in runs) + ".\n\n"
           f"Probe: {len(probe)} clips of {payload['n_probe_objects']} other objects, never seen in pre-training; "
           "frozen features → multinomial logistic regression, 5-fold cross-validation with object-level folds. "
           f"Pre-trained: mean ± std over the {args.pretrain_seeds} pre-training seeds; random init: the same "
           f"architecture, {args.random_seeds} initialisation seeds. Balanced accuracy (chance 0.333 for the ranks, "
           "0.5 for real vs fake); Δ = pre-trained − random; majority = accuracy of the training folds' most "
           "frequent class.\n\n")
    headers = ["feature", "task", "pre-trained", "random init", "Δ", "majority acc."]
    md += md_table(headers, rows)
    md += "\nFeatures: " + "; ".join(f"*{k}* = {v}" for k, v in FEATURES.items()) + ".\n"
    if results_real:
        rows_real, summary_real = comparison(results_real, pretrained_keys, random_keys)
        payload.update(summary_real_physiclear=summary_real, results_real_physiclear=results_real,
                       n_real_probe_clips=len(labelled_real))
        md += (f"\n## Secondary: real GelSight Mini (PhysiCLeAR), {len(labelled_real)} labelled clips of "
               f"{len({c.object_id for c in labelled_real})} objects\n\nSame probe with object-level folds, but "
               "these objects' videos were part of pre-training (without labels), so this is transductive, not "
               "unseen-object, evaluation.\n\n")
        md += md_table(headers, rows_real)
    md += (f"\nEncoder: {payload['parameters'] / 1e6:.2f} M parameters, {config.num_frames}×{config.image_size[0]}×"
           f"{config.image_size[1]} input, {config.num_patches} tubelets; forward **{speed:.0f} clips/s** "
           f"(batch 8, float32, CPU, {speed_threads} threads).\nSimulated data (DynTAC-Sim), not the paper's "
           "DynTAC-Bench.\n")
    publish("encoder_pretrain", payload, md)


if __name__ == "__main__":
    main()
