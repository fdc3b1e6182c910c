"""DynTAC-Sim val in the second held-out wording set (`paraphrase-bench --wording heldout2`), the quickstart's three
seeds answering direct (one pass, `evaluate`'s default) and stepwise-vote (a one-clip question in untrained words
read from the clip), beside the same items in the benchmark's wordings (direct): accuracy and the share of replies
in the asked form, per task, mean over seeds.

    python experiments/2026-11-29_read_single_clip/dyntac_wordings.py
"""

from __future__ import annotations

import json
import statistics
from pathlib import Path

ROWS = {
    "benchmark wordings, direct": ["runs/dyn_val_direct", "runs/dyn3/direct/seed1", "runs/dyn3/direct/seed2"],
    "heldout2, direct": [f"runs/dyn_h2/direct/seed{k}" for k in range(3)],
    "heldout2, stepwise-vote": [f"runs/dyn_h2/stepwise-vote/seed{k}" for k in range(3)],
}


def tasks(folder: str) -> dict[str, dict]:
    return {t["task"]: t for t in json.loads((Path(folder) / "report.json").read_text())["tasks"]}


def main() -> None:
    worded = tasks(ROWS["heldout2, direct"][0])
    names = [t for t in worded]
    print("| val, 3 seeds | " + " | ".join(names) + " |")
    print("|---|" + "---|" * len(names))
    for label, folders in ROWS.items():
        runs = [tasks(f) for f in folders]
        cells = []
        for name in names:
            acc = [100 * r[name]["accuracy"] for r in runs]
            kind = [100 * (1 - r[name]["parse_failure_rate"]) for r in runs]
            cells.append(f"{statistics.mean(acc):.1f} ± {statistics.stdev(acc):.1f} ({statistics.mean(kind):.0f}%)")
        print(f"| {label} | " + " | ".join(cells) + " |")
    print("\nCells: accuracy % mean ± std over the 3 seeds (share of replies in the asked form).")


if __name__ == "__main__":
    main()
