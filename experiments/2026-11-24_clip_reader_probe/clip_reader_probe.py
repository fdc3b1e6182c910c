"""How well the clip reader reads the held-out test clips, next to what the model answers on the same items.

Usage (after `tacreasoner quickstart`):

    python benchmarks/clip_reader_probe.py [--run runs/quickstart] [--model DIR] [--scored FILE]

The reader (``encoder.clip_reader``) is fitted when Stage II starts; its read-out of each test clip's traits
bounds what the LLM can answer by reading its level vectors. For a model without a fitted reader, one is fitted
the way the trainer does (on the Stage II training examples of the run). Each single-clip test item (TFA
attributes and combined, RFOR, OCSE) is encoded in its own prompt, as at evaluation, and the reader's levels
are compared with the item's gold; TFA-combined counts as read when all its levels are.
Results: benchmarks/results/clip_reader_probe.{json,md}.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp


def _bank(model, processor, tokenized: list, cache: Path):
    """The videos of ``tokenized``, preprocessed and with the frozen ViT's tokens cached, as the trainer holds them."""
    from tacreasoner.train.data import VideoBank

    bank = VideoBank(processor.video_config, processor.sensor_types)
    bank.build([k for e in tokenized for k in e.videos], cache_dir=cache)
    bank.cache_appearance(model.tactile_encoder)
    return bank


def _test_items(model, processor, bench: Path, cache: Path) -> tuple[list, list]:
    """The single-clip test items and, per item, its video's encoder output."""
    from tacreasoner.tasks.bench import load_bench
    from tacreasoner.train.data import _answer_only, _from_items, bench_video_root, tokenize_examples
    from tacreasoner.train.heads import encoder_outputs
    from tacreasoner.train.reader import item_traits

    info, items = load_bench(bench, "test")
    items = [i for i in items if item_traits(i) and len(i.videos) == 1]
    tokenized, dropped = tokenize_examples(
        processor, _from_items(items, bench_video_root(bench, info), _answer_only), max_length=10_000
    )
    assert not dropped
    videos, _, _ = encoder_outputs(model, processor, tokenized, _bank(model, processor, tokenized, cache))
    return items, videos


def _fit_like_the_trainer(model, processor, run: Path) -> None:
    """Fit a clip reader on the run's Stage II examples, with the quickstart's own data settings."""
    from tacreasoner.train.data import load_examples, tokenize_examples
    from tacreasoner.train.head_settings import reader_vocabulary
    from tacreasoner.train.heads import fit_heads
    from tacreasoner.train.quickstart import QuickstartPaths, quickstart_config

    config = quickstart_config(QuickstartPaths(run), 0)
    data = config.data
    examples = load_examples(2, data.bench, touchcot=data.touchcot, stage2_data=data.stage2_data, tasks=data.tasks)
    tokenized, _ = tokenize_examples(processor, examples, data.max_length)
    bank = _bank(model, processor, tokenized, Path(data.video_cache))
    model.set_clip_reader(*reader_vocabulary())
    fit_heads(model, processor, tokenized, bank, data.bench, seed=config.seed, folds=data.head_folds)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--run", type=Path, default=Path("runs/quickstart"))
    parser.add_argument("--model", type=Path, default=None, help="Default: RUN/model.")
    parser.add_argument(
        "--scored",
        type=Path,
        default=None,
        help="The model's scored test answers. Default: RUN/eval/test/scored/seed0.jsonl.",
    )
    args = parser.parse_args()

    import torch

    from tacreasoner.evaluate.predict import load_trained
    from tacreasoner.train.head_settings import READER_TRAITS
    from tacreasoner.train.reader import item_traits

    model_dir = args.model or args.run / "model"
    model, processor = load_trained(model_dir, device="cpu")
    reader = model.projector.clip_reader
    refitted = reader is None or not reader.fitted
    if refitted:
        _fit_like_the_trainer(model, processor, args.run)
        reader = model.projector.clip_reader
    items, videos = _test_items(model, processor, args.run / "bench", args.run / "video_cache")
    scored = {}
    scored_path = args.scored or args.run / "eval" / "test" / "scored" / "seed0.jsonl"
    if scored_path.is_file():
        for line in scored_path.read_text().splitlines():
            r = json.loads(line)
            scored[r["id"]] = bool(r["correct"])
    per_task: dict[str, dict] = {}
    with torch.no_grad():
        for item, video in zip(items, videos, strict=True):
            levels = reader.levels(video)[0].tolist()
            read = all(levels[READER_TRAITS.index(t)] == level for t, level in item_traits(item).items())
            row = per_task.setdefault(item.task, {"items": 0, "reader": 0, "model": 0, "scored": 0})
            row["items"] += 1
            row["reader"] += int(read)
            if item.id in scored:
                row["scored"] += 1
                row["model"] += int(scored[item.id])
    rows, payload = [], {}
    for task in sorted(per_task):
        r = per_task[task]
        reader_acc = r["reader"] / r["items"]
        model_acc = r["model"] / r["scored"] if r["scored"] == r["items"] else None
        payload[task] = {"items": r["items"], "reader": reader_acc, "model": model_acc}
        rows.append([task, r["items"], 100 * reader_acc, "–" if model_acc is None else 100 * model_acc])
    info = stamp()
    md = header_md("Clip reader on the held-out test clips", info)
    md += (
        f"Model: `{model_dir}`"
        + (
            " (no fitted reader: one fitted as the trainer does)"
            if refitted
            else " (its own reader, fitted when its Stage II started)"
        )
        + ". Each single-clip test item of DynTAC-Sim-Bench (simulated; objects never seen in training) encoded in "
        "its own prompt; the reader's level for the trait asked against the gold (TFA-combined: all four). The "
        f"model column is the model's own strict benchmark accuracy on the same items (`{scored_path}`).\n\n"
    )
    md += md_table(["task", "items", "reader %", "model %"], rows)
    publish("clip_reader_probe", {**info, "model": str(model_dir), "refitted": refitted, "tasks": payload}, md)


if __name__ == "__main__":
    main()
