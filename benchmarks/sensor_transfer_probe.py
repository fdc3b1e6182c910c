"""Which frame preparation lets the appearance encoder read a sensor style it never saw? Linear probes, side by side.

Issue 60, point 2 (a person's own sensor). The quickstart's appearance branch (EfficientNet-Lite0, ImageNet weights,
frozen, cut at ``block112``, 8 contact frames at 120×160) is probed under several frame preparations:

* ``keep``: the sensor image as it is (the quickstart's today);
* ``subtract``: the imprint alone, (frame − gel at rest), as Sparsh and the field's tactile encoders do;
* ``magnitude``: the imprint's size of change per pixel, the same on the three channels (no LED colours);
* each of them ``+ match``: a portrait frame (DIGIT's 320×240) turned a quarter to the model's landscape size.

One multinomial logistic regression per DynTAC-Sim property (hardness, protrusion, elasticity, friction) reads the
clip's mean feature; its L2 is chosen by object-level cross-validation on the **train objects' seen-style clips**; it
is then scored once on the val objects in the seen style (``val``) and in the held-out style (``val_heldout_sensor``).
No test object is read.

**Rule, fixed before the first run**: the preparation with the best mean held-out-style val accuracy among those
whose seen-style val mean is within 2 points of ``keep``'s wins; the full model is then trained with it (3 seeds) and
compared with today's on ``val_heldout_sensor`` before anything changes (benchmarks/results/sensor_transfer.md).

    python benchmarks/sensor_transfer_probe.py --bench runs/sens/bench
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

ATTRIBUTES = ("hardness", "protrusion", "elasticity", "friction")
L2_GRID = (1e-2, 1e-1, 1.0, 10.0)
CANDIDATES = {
    "keep": {"background": "keep"},
    "keep + match": {"background": "keep", "orientation": "match"},
    "subtract": {"background": "subtract"},
    "subtract + match": {"background": "subtract", "orientation": "match"},
    "magnitude": {"background": "subtract", "colour": "magnitude"},
    "magnitude + match": {"background": "subtract", "colour": "magnitude", "orientation": "match"},
}


def features(clips: list, settings: dict, cache: Path) -> np.ndarray:
    """Per clip the mean block112 feature over frames and cells (the CLS token the LLM receives)."""
    if cache.is_file():
        return np.load(cache)["x"]
    import dataclasses

    from tacreasoner.model.efficientnet import EfficientNetAppearance, backbone_settings, load_imagenet_weights

    encoder, video = backbone_settings("block112", (120, 160), 8, "contact", settings["background"])
    video = dataclasses.replace(video, **{k: v for k, v in settings.items() if k != "background"})
    net = EfficientNetAppearance(encoder).eval()
    load_imagenet_weights(net)
    x = clip_cls_tokens(net, clips, video)
    cache.parent.mkdir(parents=True, exist_ok=True)
    np.savez(cache, x=x)
    return x


def probe(x: dict[str, np.ndarray], labels: dict[str, dict[str, np.ndarray]], groups: np.ndarray) -> dict:
    """L2 by object-level 5-fold CV on train (seen style), then val and val_heldout_sensor scored once."""
    from tacreasoner.evaluate.probe import LinearProbe, cross_validate_probe

    cv = {l2: np.mean([cross_validate_probe(x["train"], labels["train"][a], groups, 5, 0, l2).accuracy
                       for a in ATTRIBUTES]) for l2 in L2_GRID}
    l2 = max(L2_GRID, key=lambda v: (cv[v], v))
    result: dict = {"l2": l2, "train_cv": float(cv[l2])}
    for split in ("val", "val_heldout_sensor"):
        hits = {a: LinearProbe(l2).fit(x["train"], labels["train"][a]).predict(x[split]) == labels[split][a]
                for a in ATTRIBUTES}
        result[split] = {a: float(h.mean()) for a, h in hits.items()}
        result[split]["mean"] = float(np.mean([result[split][a] for a in ATTRIBUTES]))
        result[split]["n"] = len(x[split])
    return result


def choose(results: dict[str, dict]) -> str:
    floor = results["keep"]["val"]["mean"] - 0.02
    allowed = [k for k, r in results.items() if r["val"]["mean"] >= floor]
    return max(allowed, key=lambda k: results[k]["val_heldout_sensor"]["mean"])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bench", type=Path, required=True, help="a DynTAC-Sim build-bench folder with a held-out sensor")
    ap.add_argument("--cache", type=Path, default=Path("runs/sensor_transfer_probe"))
    args = ap.parse_args()

    import torch

    from tacreasoner.data.readers import read_sim_dataset

    torch.set_num_threads(2)
    info = stamp()
    bench = json.loads((args.bench / "bench.json").read_text())
    held, split_of = bench.get("heldout_sensor"), bench["splits"]
    if not held:
        raise SystemExit(f"{args.bench}: no held-out sensor (build it with `tacreasoner build-bench --heldout-sensor`)")
    rows = {"train": [], "val": [], "val_heldout_sensor": []}
    for clip in read_sim_dataset(bench["data"]):
        split = split_of.get(clip.object_id)
        name = split if clip.sensor != held else f"{split}_heldout_sensor"
        if name in rows:
            rows[name].append(clip)
    labels = {s: {a: np.asarray([c.labels["vtv150k"][a] for c in clips]) for a in ATTRIBUTES}
              for s, clips in rows.items()}
    groups = np.asarray([c.object_id for c in rows["train"]])
    results, seconds = {}, {}
    for name, settings in CANDIDATES.items():
        t0 = time.perf_counter()
        x = {s: features(clips, settings, args.cache / f"{name.replace(' + ', '_')}_{s}.npz")
             for s, clips in rows.items()}
        seconds[name] = round(time.perf_counter() - t0, 1)
        results[name] = probe(x, labels, groups)
        print(f"{name}: val {100 * results[name]['val']['mean']:.1f}, held-out style "
              f"{100 * results[name]['val_heldout_sensor']['mean']:.1f} ({seconds[name]} s)", flush=True)
    chosen = choose(results)
    data = {**info, "bench": str(args.bench), "seen_sensors": sorted(set(bench["sensors"]) - {held}),
            "heldout_sensor": held, "splits": "train objects (fit, CV) -> val objects in the seen and held-out style",
            "clips": {s: len(c) for s, c in rows.items()}, "results": results, "feature_seconds": seconds,
            "chosen": chosen}
    md = header_md("Sensor transfer: linear probes of the appearance encoder under each frame preparation", info)
    md += (f"\nProbes fitted on the train objects' `{', '.join(data['seen_sensors'])}` clips (L2 by object-level CV "
           f"there), scored once on the val objects in that style and in the held-out `{held}` style "
           f"({data['clips']['val']} and {data['clips']['val_heldout_sensor']} clips). Rule fixed before the run: "
           "the best held-out-style mean among preparations whose seen-style mean is within 2 points of `keep`'s. "
           "No test object is read.\n\n")
    md += md_table(["preparation", "train CV %", "val mean", *[f"val {a}" for a in ATTRIBUTES],
                    f"{held} mean", *[f"{held} {a}" for a in ATTRIBUTES], "gap"],
                   [[f"**{k}**" if k == chosen else k, f"{100 * r['train_cv']:.1f}",
                     f"{100 * r['val']['mean']:.1f}", *[f"{100 * r['val'][a]:.1f}" for a in ATTRIBUTES],
                     f"{100 * r['val_heldout_sensor']['mean']:.1f}",
                     *[f"{100 * r['val_heldout_sensor'][a]:.1f}" for a in ATTRIBUTES],
                     f"{100 * (r['val']['mean'] - r['val_heldout_sensor']['mean']):+.1f}"]
                    for k, r in results.items()])
    md += f"\nChosen: **{chosen}**.\n"
    publish("sensor_transfer_probe", data, md)


if __name__ == "__main__":
    main()
