"""Which val objects' DIGIT clips are read worse than their Mini clips (val only; the test objects are not studied).

    python experiments/2026-12-01_imprint_recipe/per_object_val.py

Reads the scored answers run.sh left (runs/swt/eval_imprint, runs/mini_ctl/eval_gate): per object family (the name
before the variant number), the share right on Mini and on DIGIT over the three seeds, and how much of the gap
each family carries.
"""

from __future__ import annotations

import json
import re
from collections import defaultdict
from pathlib import Path

RUNS = {"candidate (imprint)": ("runs/swt/eval_imprint", "match+gel+imprint"),
        "control (gate)": ("runs/mini_ctl/eval_gate", "match+gel+swap+gate")}


def family(object_id: str) -> str:
    return re.sub(r"_\d+$", "", object_id)


def val_items() -> dict[str, tuple[str, str]]:
    """Every val item of both styles: id → (task, its first object)."""
    items = {}
    for split in ("val", "val_heldout_sensor"):
        for line in Path(f"runs/sens/bench/{split}.jsonl").read_text().splitlines():
            item = json.loads(line)
            items[item["id"]] = (item["task"], item["objects"][0])
    return items


def main() -> None:
    items = {key: family(obj) for key, (_, obj) in val_items().items()}
    for name, (folder, prep) in RUNS.items():
        right: dict[tuple[str, str], list[int]] = defaultdict(lambda: [0, 0])
        for seed in sorted(Path(folder).glob("seed*")):
            for split, style in (("val", "Mini"), ("val_heldout_sensor", "DIGIT")):
                scored = seed / f"{split}_{prep}" / "scored" / f"{split}.jsonl"
                for line in scored.read_text().splitlines():
                    row = json.loads(line)
                    cell = right[(items[row["id"]], style)]
                    cell[0] += bool(row["correct"])
                    cell[1] += 1
        families = sorted({f for f, _ in right})
        print(f"## {name}\n\n| family (first object of an item) | Mini items (3 seeds) | Mini | DIGIT items | DIGIT | "
              "Mini − DIGIT |")
        print("|---|---|---|---|---|---|")
        rows = []
        for f in families:
            mini, digit = right[(f, "Mini")], right[(f, "DIGIT")]
            rate_m, rate_d = 100 * mini[0] / max(mini[1], 1), 100 * digit[0] / max(digit[1], 1)
            rows.append((rate_m - rate_d, f, mini, digit, rate_m, rate_d))
        for gap, f, mini, digit, rate_m, rate_d in sorted(rows, reverse=True):
            print(f"| {f} | {mini[1]} | {rate_m:.1f} | {digit[1]} | {rate_d:.1f} | {gap:+.1f} |")
        print()


if __name__ == "__main__":
    main()
