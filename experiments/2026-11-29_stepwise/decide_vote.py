"""Applies the addendum of criteria.md (written before the vote was built) to B and B-vote's per-seed val records.

    python experiments/2026-11-29_stepwise/decide_vote.py runs/physiclear/eval_val_stepwise/rec.seeds0-1-2 \\
        runs/physiclear/eval_val_stepwise_vote/rec.seeds0-1-2 > experiments/2026-11-29_stepwise/decision_vote.md
"""

from __future__ import annotations

import statistics
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "2026-11-28_compact_reasoning"))
from decide import per_seed  # the same per-seed columns as the compact experiment's rule

DECIDED_BY_READINGS = ("PC", "PSS")


def main() -> None:
    single, vote = (per_seed(Path(a)) for a in sys.argv[1:3])
    if len(single) != len(vote) or len(single) < 3:
        raise SystemExit(f"need the same seeds (at least 3): {len(single)} and {len(vote)}")
    lines = ["| seed | B: mean of PC, PSS | B-vote: mean of PC, PSS |", "|---|---|---|"]
    wins = 0
    for s, (b, v) in enumerate(zip(single, vote, strict=True)):
        mb, mv = (statistics.fmean(x[c] for c in DECIDED_BY_READINGS) for x in (b, v))
        wins += mv > mb
        lines.append(f"| {s} | {100 * mb:.1f} | {100 * mv:.1f} |")
    verdict = "B-vote replaces B" if wins == len(single) else "B stays"
    lines += ["", f"B-vote higher in {wins} of {len(single)} seed pairs. **Verdict: {verdict}** "
              "(criteria.md, addendum)."]
    print("\n".join(lines))


if __name__ == "__main__":
    main()
