"""How far can an LLM take zero-shot TSA when perception is perfect? The TSA items with every video replaced by words.

Each ``<tactile>`` placeholder of a DynTAC-Sim-Bench TSA item becomes nothing, the attributes the scenario needs, or
all four attributes, in the benchmark's own phrases, and the LLM as shipped (no tactile training, no LoRA) answers the
text: greedy (strict and lenient scoring) and by next-token log-probabilities. Chance is 50%. The method and its
conditions: ``tacreasoner.evaluate.tsa_ceiling`` (which does the work; this script publishes it). Re-run it for a new
base LLM: one that cannot choose above chance from the gold words gives a tactile model built on it nothing to reach
TSA with zero-shot. Results: benchmarks/results/tsa_ceiling.{json,md} (``--name`` for another stem).

    python benchmarks/tsa_ceiling.py --llm runs/smollm2 --bench runs/quickstart/bench [--splits val,test]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, publish, stamp
from tacreasoner.evaluate.tsa_ceiling import TITLE, run_tsa_ceiling


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--llm", type=Path, default=Path("runs/smollm2"), help="a Hugging Face causal LM folder")
    ap.add_argument("--bench", type=Path, default=Path("runs/quickstart/bench"))
    ap.add_argument("--splits", default="val,test")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--max-new-tokens", type=int, default=48)
    ap.add_argument("--name", default="tsa_ceiling")
    args = ap.parse_args()

    info = stamp()
    splits = tuple(s.strip() for s in args.splits.split(",") if s.strip())
    try:
        ceiling = run_tsa_ceiling(args.llm, args.bench, splits, max_new_tokens=args.max_new_tokens,
                                  threads=args.threads, say=lambda line: print(line, flush=True))
    except ValueError as e:
        raise SystemExit(str(e)) from None
    publish(args.name, {**info, **ceiling.to_dict()}, header_md(TITLE, info) + ceiling.markdown())
    print(json.dumps({k: [v[w]["accuracy"] for w in ("logprob", "ordinal")] for k, v in ceiling.results.items()}))


if __name__ == "__main__":
    main()
