"""Choose a recipe among candidates by their **val** scores only, and say which one won and why.

Reads ``<eval>/<candidate>/val/report.json`` (``tacreasoner evaluate --split val`` output) for each candidate, in the
order given, and picks the highest unweighted task average; within ``--tie`` points the earliest listed wins, so list
candidates from the cheapest. Test reports are never read (the rule: ``tacreasoner.evaluate.recipe_choice``). Prints
the winner's name (for a shell to use) and writes the table of candidates as JSON.

    python benchmarks/choose_on_val.py --eval /tmp/w/eval --out choice.json plain_s500 plain cot
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from tacreasoner.evaluate.recipe_choice import choose_on_val


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("candidates", nargs="+", help="names under --eval, cheapest first")
    ap.add_argument("--eval", type=Path, required=True, help="folder of <name>/val/report.json")
    ap.add_argument("--tie", type=float, default=0.0, help="points (of 100) within which candidates count as tied")
    ap.add_argument("--out", type=Path, help="write {candidates: {name: val average}, winner, tie} here")
    args = ap.parse_args()
    try:
        choice = choose_on_val(args.eval, args.candidates, args.tie)
    except ValueError as e:
        raise SystemExit(str(e)) from None
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(choice.to_dict(), indent=2) + "\n")
    for name, score in choice.scores.items():
        print(f"{name}: val average {100 * score:.1f}", file=sys.stderr)
    print(choice.winner)


if __name__ == "__main__":
    main()
