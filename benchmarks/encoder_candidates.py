"""Which appearance encoder reads real touch best? Frozen-encoder linear probes of every candidate, side by side.

Issue 37, point 2. Candidates:

* the project's masked-video ViT (``--vit``: a ``pretrain-encoder`` folder, pre-trained on train and unlabelled
  clips only), 8 uniform frames of 64×64, the imprint alone (background subtracted);
* EfficientNet-Lite0 with its ImageNet weights (``tacreasoner encoder get``), frozen, cut at three depths (block112:
  112 channels at stride 16; block320: 320 at stride 32; head: the 1280-channel head), under the field's tactile
  preprocessing choices: which 8 frames (``contact``: strongest contact; ``uniform``), the sensor image as it is or
  the imprint alone (``keep`` / ``subtract`` the no-contact frame), and two input sizes (120×160, 240×320).

Each candidate's feature of a clip is its CLS token (the first appearance token the LLM receives: for the backbone,
the mean of every frame's feature map). One multinomial logistic regression per property reads it. **The choice is
made on PhysiCLeAR's train objects only**: object-level 5-fold cross-validation repeated over 3 fold seeds, the L2
strength chosen per candidate by the same cross-validation; the candidate with the best mean accuracy over hardness,
roughness and bumpiness wins, and a cheaper one (smaller input) wins instead when it is within one standard deviation
(over fold seeds) of the best. Val objects are scored once per candidate, with the L2 chosen on train, and are
reported beside: they choose nothing.

``--sim-bench`` (a DynTAC-Sim benchmark folder) adds the same probe on the simulated clips (train objects →
cross-validation, val objects scored once) for the ViT and the ``--sim-top`` best PhysiCLeAR candidates: what the
quickstart's simulated benchmark uses is decided there, the same way.

    python benchmarks/encoder_candidates.py --vit runs/quickstart/encoder [--sim-bench runs/quickstart/bench]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import clip_cls_tokens, header_md, md_table, publish, stamp

PHYSICLEAR_ATTRIBUTES = ("hardness", "roughness", "bumpiness")
SIM_ATTRIBUTES = ("hardness", "protrusion", "elasticity", "friction")
L2_GRID = (1e-2, 1e-1, 1.0, 10.0)
FOLD_SEEDS = (0, 1, 2)
SIZES = {"120x160": (120, 160), "240x320": (240, 320)}
LAYERS = ("block112", "block320", "head")


def backbone_features(clips: list, sampling: str, background: str, size: tuple[int, int], cache: Path,
                      ) -> dict[str, np.ndarray]:
    """Per clip the CLS token (mean over frames and cells) at each of LAYERS, from one pass of the network."""
    if cache.is_file():
        data = np.load(cache)
        return {k: data[k] for k in LAYERS}
    import torch

    from tacreasoner.model.efficientnet import EfficientNetAppearance, backbone_settings, load_imagenet_weights
    from tacreasoner.model.video_processing import preprocess_video

    encoder, video = backbone_settings("head", size, 8, sampling, background)
    net = EfficientNetAppearance(encoder)
    load_imagenet_weights(net)
    cut = {10: "block112", 15: "block320"}
    out: dict[str, list[np.ndarray]] = {k: [] for k in LAYERS}
    with torch.no_grad():
        for clip in clips:
            x = net.stem(torch.from_numpy(preprocess_video(clip, video)))
            for i, block in enumerate(net.blocks):
                x = block(x, drop_connect_rate=0.0)
                if i in cut:
                    out[cut[i]].append(x.mean(dim=(0, 2, 3)).numpy())
            out["head"].append(net.head(x).mean(dim=(0, 2, 3)).numpy())
    feats = {k: np.stack(v).astype(np.float64) for k, v in out.items()}
    cache.parent.mkdir(parents=True, exist_ok=True)
    np.savez(cache, **feats)
    return feats


def timed(cache: Path, name: str, compute, previous: dict[str, float]) -> tuple:
    """(features, seconds to compute them): read from the cache, the seconds are those recorded when they were
    computed (a sidecar file, or the previous result file for caches older than the sidecars), never the read."""
    sidecar = cache.with_suffix(".seconds.json")
    cached = cache.is_file()
    t0 = time.perf_counter()
    value = compute()
    if not cached:
        seconds = time.perf_counter() - t0
        sidecar.write_text(json.dumps(seconds))
    else:
        seconds = json.loads(sidecar.read_text()) if sidecar.is_file() else previous.get(name, float("nan"))
    return value, seconds


def _previous_seconds(path: Path) -> dict[str, float]:
    return json.loads(path.read_text()).get("feature_seconds", {}) if path.is_file() else {}


def vit_features(clips: list, encoder_dir: Path, cache: Path) -> np.ndarray:
    if cache.is_file():
        return np.load(cache)["cls"]
    from tacreasoner.model.appearance import AppearanceEncoder
    from tacreasoner.model.build import appearance_video_settings
    from tacreasoner.model.video_processing import VideoProcessingConfig

    encoder = AppearanceEncoder.from_pretrained(encoder_dir).eval()
    video = VideoProcessingConfig(num_frames=encoder.config.num_frames, image_size=encoder.config.image_size,
                                  **appearance_video_settings(encoder_dir))
    cls = clip_cls_tokens(encoder, clips, video, batch=32)
    cache.parent.mkdir(parents=True, exist_ok=True)
    np.savez(cache, cls=cls)
    return cls


def probe(x: np.ndarray, labels: dict[str, np.ndarray], groups: np.ndarray, train: np.ndarray, val: np.ndarray
          ) -> dict:
    """Repeated object-level CV on the train rows (L2 chosen there), then val scored once with that L2."""
    from tacreasoner.evaluate.probe import LinearProbe, cross_validate_probe

    by_l2 = {}
    for l2 in L2_GRID:
        per_seed = [[cross_validate_probe(x[train], labels[a][train], groups[train], 5, seed, l2).accuracy
                     for a in labels] for seed in FOLD_SEEDS]
        by_l2[l2] = np.asarray(per_seed)  # seeds × attributes
    l2 = max(L2_GRID, key=lambda v: (by_l2[v].mean(), v))
    cv = by_l2[l2]
    hits = {a: LinearProbe(l2).fit(x[train], labels[a][train]).predict(x[val]) == labels[a][val] for a in labels}
    val_acc = {a: float(h.mean()) for a, h in hits.items()}
    val_acc["combined"] = float(np.all(list(hits.values()), axis=0).mean())
    return {"l2": l2, "cv_mean": float(cv.mean()), "cv_std_over_fold_seeds": float(cv.mean(axis=1).std()),
            "cv": {a: float(cv[:, i].mean()) for i, a in enumerate(labels)}, "val": val_acc, "val_n": len(val)}


def choose(results: dict[str, dict], cost: dict[str, float]) -> str:
    best = max(results, key=lambda k: results[k]["cv_mean"])
    near = [k for k in results
            if results[k]["cv_mean"] >= results[best]["cv_mean"] - results[best]["cv_std_over_fold_seeds"]]
    return min(near, key=lambda k: (cost[k], -results[k]["cv_mean"]))


def rows_for(results: dict[str, dict], attrs: tuple[str, ...], chosen: str) -> list[list]:
    order = sorted(results, key=lambda k: -results[k]["cv_mean"])
    return [[("**" + k + "**") if k == chosen else k,
             f"{100 * r['cv_mean']:.1f} ± {100 * r['cv_std_over_fold_seeds']:.1f}",
             *[f"{100 * r['cv'][a]:.1f}" for a in attrs], f"{r['l2']:g}",
             *[f"{100 * r['val'][a]:.1f}" for a in (*attrs, "combined")]]
            for k, r in ((k, results[k]) for k in order)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vit", type=Path, required=True, help="a pretrain-encoder folder (train/unlabelled clips only)")
    ap.add_argument("--data", type=Path, default=None, help="PhysiCLeAR folder (default: ../shared/data/physiclear)")
    ap.add_argument("--sim-bench", type=Path, default=None, help="a DynTAC-Sim build-bench folder")
    ap.add_argument("--sim-top", type=int, default=3, help="PhysiCLeAR's best candidates also probed on DynTAC-Sim")
    ap.add_argument("--cache", type=Path, default=Path("runs/encoder_candidates"))
    ap.add_argument("--name", default="encoder_candidates")
    args = ap.parse_args()

    import torch

    from tacreasoner.data.readers import read_physiclear
    from tacreasoner.train.pretrain_encoder import splits_seen

    torch.set_num_threads(2)
    info = stamp()
    seen = splits_seen(args.vit)
    if seen is None or set(seen) - {"train", "unlabelled"}:
        raise SystemExit(f"{args.vit}: pre-trained on {seen or 'unrecorded splits'}; the comparison needs an encoder "
                         "that never saw val or test clips")
    clips = [c for c in read_physiclear(args.data, on_error="raise") if c.split in ("train", "val")]
    split = np.asarray([c.split for c in clips])
    groups = np.asarray([c.object_id for c in clips])
    labels = {a: np.asarray([c.labels["physiclear"][a] for c in clips]) for a in PHYSICLEAR_ATTRIBUTES}
    train, val = np.flatnonzero(split == "train"), np.flatnonzero(split == "val")

    results, cost, seconds = {}, {}, {}
    previous = _previous_seconds(Path(__file__).resolve().parent / "results" / f"{args.name}.json")
    cache = args.cache / "pc_vit.npz"
    vit, seconds["vit"] = timed(cache, "vit", lambda: vit_features(clips, args.vit, cache), previous)
    results["vit (64x64, uniform, subtract)"] = probe(vit, labels, groups, train, val)
    cost["vit (64x64, uniform, subtract)"] = 64 * 64
    for size_name, size in SIZES.items():
        for sampling in ("contact", "uniform"):
            for background in ("keep", "subtract"):
                name, cache = f"{size_name} {sampling} {background}", \
                    args.cache / f"pc_effnet_{size_name}_{sampling}_{background}.npz"
                feats, seconds[name] = timed(cache, name, lambda cache=cache, sampling=sampling, size=size,
                                             background=background: backbone_features(clips, sampling, background,
                                                                                      size, cache), previous)
                for layer in LAYERS:
                    key = f"efficientnet_lite0 {layer} ({size_name}, {sampling}, {background})"
                    results[key] = probe(feats[layer], labels, groups, train, val)
                    cost[key] = size[0] * size[1]
                print(f"{size_name} {sampling} {background}: {seconds[f'{size_name} {sampling} {background}']:.0f} s",
                      flush=True)
    chosen = choose(results, cost)

    sim = None
    if args.sim_bench is not None:
        sim = probe_sim(args, results, chosen)

    attrs = PHYSICLEAR_ATTRIBUTES
    md = header_md("Appearance-encoder candidates: frozen linear probes on PhysiCLeAR", info)
    md += (f"{len(train)} train clips of {len(set(groups[train]))} objects (the choice: object-level 5-fold "
           f"cross-validation, fold seeds {list(FOLD_SEEDS)}, L2 from {list(L2_GRID)} chosen by the same CV); "
           f"{len(val)} val clips of {len(set(groups[val]))} objects scored once per candidate (they choose nothing). "
           f"Feature: the CLS token. The ViT was pre-trained on {seen} clips. Rule: best mean CV accuracy over "
           f"the three properties; a smaller input within one fold-seed standard deviation of the best wins instead. "
           f"**Chosen: {chosen}.** Seconds to compute the features of the {len(clips)} train and val clips, per "
           f"preprocessing (decoding, frame choice and the network, as recorded when first computed, not the cache "
           f"read; other work shared the machine at times, so read them as rough costs): "
           f"{json.dumps({k: round(v) for k, v in seconds.items()})}.\n\n")
    md += md_table(["candidate", "train CV % (mean ± sd over fold seeds)", *[f"CV {a}" for a in attrs], "L2",
                    *[f"val {a}" for a in attrs], "val combined"], rows_for(results, attrs, chosen))
    if sim is not None:
        md += (f"\n## DynTAC-Sim ({args.sim_bench}): train objects (CV) → val objects\n\n"
               f"The ViT and the {args.sim_top} best PhysiCLeAR candidates, same rule; **chosen for the simulated "
               f"benchmark: {sim['chosen']}**.\n\n")
        md += md_table(["candidate", "train CV %", *[f"CV {a}" for a in SIM_ATTRIBUTES], "L2",
                        *[f"val {a}" for a in SIM_ATTRIBUTES], "val all four"],
                       rows_for(sim["results"], SIM_ATTRIBUTES, sim["chosen"]))
    publish(args.name, {**info, "vit": str(args.vit), "vit_splits_seen": seen, "chosen": chosen,
                        "results": results, "feature_seconds": seconds, "sim": sim}, md)


def probe_sim(args: argparse.Namespace, physiclear: dict[str, dict], chosen: str) -> dict:
    """The ViT and the best PhysiCLeAR candidates, probed on DynTAC-Sim's train (CV) and val objects."""
    from tacreasoner.data.readers import read_sim_dataset

    info = json.loads((args.sim_bench / "bench.json").read_text())
    split_of = info["splits"]
    clips = [c for c in read_sim_dataset(info["data"]) if split_of.get(c.object_id) in ("train", "val")]
    split = np.asarray([split_of[c.object_id] for c in clips])
    groups = np.asarray([c.object_id for c in clips])
    labels = {a: np.asarray([c.labels["vtv150k"][a] for c in clips]) for a in SIM_ATTRIBUTES}
    train, val = np.flatnonzero(split == "train"), np.flatnonzero(split == "val")
    results, cost = {}, {}
    results["vit (64x64, uniform, subtract)"] = probe(vit_features(clips, args.vit, args.cache / "sim_vit.npz"),
                                                      labels, groups, train, val)
    cost["vit (64x64, uniform, subtract)"] = 64 * 64
    top = [k for k in sorted(physiclear, key=lambda k: -physiclear[k]["cv_mean"]) if k.startswith("efficientnet")]
    for key in dict.fromkeys([*top[:args.sim_top], *([chosen] if chosen.startswith("efficientnet") else [])]):
        layer, rest = key.removeprefix("efficientnet_lite0 ").split(" (")
        size_name, sampling, background = rest.rstrip(")").split(", ")
        feats = backbone_features(clips, sampling, background, SIZES[size_name],
                                  args.cache / f"sim_effnet_{size_name}_{sampling}_{background}.npz")
        results[key] = probe(feats[layer], labels, groups, train, val)
        cost[key] = SIZES[size_name][0] * SIZES[size_name][1]
    return {"results": results, "chosen": choose(results, cost)}


if __name__ == "__main__":
    main()
