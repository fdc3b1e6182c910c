"""criteria.md's rule read from the two result files run.sh writes (candidate and control, same seeds, one split).

    python experiments/2026-12-01_imprint_recipe/rule.py [--split val]
"""

from __future__ import annotations

import argparse
import json
import statistics
from pathlib import Path

RESULTS = Path(__file__).resolve().parents[2] / "benchmarks" / "results"


def figures(name: str, preparation: str) -> tuple[list[float], list[float]]:
    """Per seed (result-file order): the seen style's and the held-out style's average, in points."""
    results = json.loads((RESULTS / f"{name}.json").read_text())["results"]
    seen = [100 * row[f"seen_{preparation}"]["average"] for row in results.values()]
    held = [100 * row[preparation]["average"] for row in results.values()]
    return seen, held


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--split", default="val", choices=("val", "test"))
    args = ap.parse_args()
    cand = figures(f"sensor_transfer_imprint_recipe_{args.split}", "match+gel+imprint")
    ctl = figures(f"sensor_transfer_imprint_recipe_control_{args.split}", "match+gel+swap+gate")
    for name, (seen, held) in (("candidate (imprint)", cand), ("control (gate)", ctl)):
        print(f"{name}: Mini {statistics.mean(seen):.1f} ± {statistics.stdev(seen):.1f} "
              f"({', '.join(f'{v:.1f}' for v in seen)}), DIGIT {statistics.mean(held):.1f} ± "
              f"{statistics.stdev(held):.1f} ({', '.join(f'{v:.1f}' for v in held)}), "
              f"gap {statistics.mean(seen) - statistics.mean(held):.2f}")
    gap_c = statistics.mean(cand[0]) - statistics.mean(cand[1])
    gap_k = statistics.mean(ctl[0]) - statistics.mean(ctl[1])
    checks = {
        "1. DIGIT above the control's in every seed": all(a > b for a, b in zip(cand[1], ctl[1], strict=True)),
        "2. Mini mean not more than 1 point below the control's":
            statistics.mean(cand[0]) >= statistics.mean(ctl[0]) - 1,
        "3. gap at most 5 and smaller than the control's": gap_c <= 5 and gap_c < gap_k,
    }
    for check, ok in checks.items():
        print(f"{check}: {'yes' if ok else 'no'}")
    print("adopted" if all(checks.values()) else "not adopted")


if __name__ == "__main__":
    main()
