"""No object the models trained on may be asked about in the new benchmark's val or test (criteria.md).

    python experiments/2026-12-01_larger_sensor_val/check_disjoint.py \
        --trained runs/swt/bench --new runs/sens300/bench

Compares object ids and physical parameters (every material field but the names) of the training benchmark's train
objects with the new benchmark's val and test objects; exits 1 naming any that match.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

NAMES = ("name", "display_name")


def materials(bench: Path) -> dict[str, tuple]:
    """Object id → its physical parameters, from the manifest of the corpus the benchmark was built from."""
    data = Path(json.loads((bench / "bench.json").read_text())["data"])
    out = {}
    for line in (data / "manifest.jsonl").read_text().splitlines():
        material = json.loads(line)["material"]
        out[material["name"]] = tuple(sorted((k, v) for k, v in material.items() if k not in NAMES))
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--trained", type=Path, required=True, help="the benchmark the models trained on")
    ap.add_argument("--new", type=Path, required=True, help="the new evaluation benchmark")
    args = ap.parse_args()
    trained_splits = json.loads((args.trained / "bench.json").read_text())["splits"]
    new_splits = json.loads((args.new / "bench.json").read_text())["splits"]
    trained = {o for o, s in trained_splits.items() if s == "train"}
    asked = {o for o, s in new_splits.items() if s in ("val", "test")}
    params_trained = {p for o, p in materials(args.trained).items() if o in trained}
    params_new = materials(args.new)
    same_id = sorted(trained & asked)
    same_params = sorted(o for o in asked if params_new[o] in params_trained)
    print(f"{len(trained)} trained objects; {len(asked)} val/test objects in {args.new} "
          f"({sum(s == 'val' for s in new_splits.values())} val)")
    print(f"same id: {same_id or 'none'}; same physical parameters: {same_params or 'none'}")
    sys.exit(1 if same_id or same_params else 0)


if __name__ == "__main__":
    main()
