"""Choose a recipe among candidates by their **val** scores only, and say which one won and why.

Reads ``<eval>/<candidate>/val/report.json`` (``tacreasoner evaluate --split val`` output) for each candidate, in the
order given, and picks the highest unweighted task average (the papers' convention). A candidate within ``--tie``
points of the best counts as tied, and among tied ones the earliest listed wins: list candidates from the cheapest
(fewest steps, smallest rank) so that a tie goes to the cheaper recipe. Test reports are never read. Prints the
winner's name (for a shell to use) and writes the table of candidates as JSON.

    python benchmarks/choose_on_val.py --eval /tmp/w/eval --out choice.json plain_s500 plain cot
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def val_average(eval_dir: Path, name: str) -> float:
    path = eval_dir / name / "val" / "report.json"
    try:
        return float(json.loads(path.read_text())["average"]["value"])
    except (OSError, KeyError, TypeError, ValueError) as e:
        raise SystemExit(f"{path}: no val report with average.value ({e})") from None


def choose(scores: dict[str, float], tie: float) -> str:
    """The earliest-listed candidate within ``tie`` (a fraction) of the best val average."""
    best = max(scores.values())
    return next(name for name, score in scores.items() if score >= best - tie)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("candidates", nargs="+", help="names under --eval, cheapest first")
    ap.add_argument("--eval", type=Path, required=True, help="folder of <name>/val/report.json")
    ap.add_argument("--tie", type=float, default=0.0, help="points (of 100) within which candidates count as tied")
    ap.add_argument("--out", type=Path, help="write {candidates: {name: val average}, winner, tie} here")
    args = ap.parse_args()
    available = [c for c in args.candidates if (args.eval / c / "val" / "report.json").is_file()]
    missing = sorted(set(args.candidates) - set(available))
    if not available:
        raise SystemExit(f"{args.eval}: none of the candidates has a val report")
    scores = {name: val_average(args.eval, name) for name in available}
    winner = choose(scores, args.tie / 100)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps({"split": "val", "candidates": scores, "missing": missing, "winner": winner,
                                        "tie_points": args.tie}, indent=2) + "\n")
    for name, score in scores.items():
        print(f"{name}: val average {100 * score:.1f}", file=sys.stderr)
    print(winner)


if __name__ == "__main__":
    main()
