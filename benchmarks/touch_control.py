"""Removed-touch control (Touch-R1's check): does the trained model answer from touch or from the text alone?

Usage:

    python benchmarks/touch_control.py --model runs/quickstart/model --bench runs/quickstart/bench \
        --split val --out runs/touch_control [--limit N] [--touch-seed 0] [--results-dir DIR]

The same model answers the same items with its real videos, with blank clips and with other items' clips; per task
the table gives accuracy with Wilson 95% intervals, chance, and the exact McNemar p of real against each control
(the method: ``tacreasoner.evaluate.touch_control``, which does the work; this script publishes it).
Predictions (resumable) and reports go under --out (predictions/<split>[_<mode>].jsonl, touch_<mode>/);
results: benchmarks/results/touch_control.{json,md} (or --results-dir; --name for another stem).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, publish, stamp
from tacreasoner.evaluate.touch_control import TITLE, run_touch_control


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", type=Path, required=True, help="trained model directory (stage2/model)")
    parser.add_argument("--bench", type=Path, required=True, help="benchmark directory")
    parser.add_argument("--split", choices=("val", "test"), default="val",
                        help="val by default: test once, after every choice is made")
    parser.add_argument("--out", type=Path, required=True, help="predictions and reports (resumable)")
    parser.add_argument("--limit", type=int, default=None, help="only the first N items (the shuffle draws from them)")
    parser.add_argument("--touch-seed", type=int, default=0, help="seed of the shuffled videos")
    parser.add_argument("--mode", default="strict", help="answer extraction: strict or lenient")
    parser.add_argument("--batch-size", type=int, default=32)
    parser.add_argument("--max-new-tokens", type=int, default=512, help="longest reply (room for TouchCoT)")
    parser.add_argument("--video-cache", type=Path, default=None,
                        help="preprocessed-video cache shared by the three runs (default: <out>/video_cache)")
    parser.add_argument("--results-dir", type=Path, default=None, help="default: benchmarks/results")
    parser.add_argument("--name", default="touch_control", help="result file stem")
    args = parser.parse_args()
    if args.limit is not None and args.limit < 1:
        parser.error("--limit must be at least 1")

    try:
        control = run_touch_control(args.model, args.bench, args.split, args.out, limit=args.limit,
                                    touch_seed=args.touch_seed, mode=args.mode, batch_size=args.batch_size,
                                    max_new_tokens=args.max_new_tokens, video_cache=args.video_cache,
                                    say=lambda line: print(line, flush=True))
    except (ValueError, FileNotFoundError) as e:
        parser.error(str(e))
    info = stamp()
    publish(args.name, {**info, **control.to_dict()}, header_md(TITLE, info) + control.markdown(), args.results_dir)


if __name__ == "__main__":
    main()
