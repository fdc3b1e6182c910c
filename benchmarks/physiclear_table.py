"""The PhysiCLeAR results table in Octopi's columns: several rows (baselines, the probe, models) side by side.

Each ``--row LABEL=PATH`` is either a report directory with per-item scored records (``scored/*.jsonl``, from
``tacreasoner score``, ``evaluate`` or ``evaluate-physiclear``; several files = several seeds, mean ± std), the JSON
of ``benchmarks/physiclear_probe.py``, or ``benchmarks/results/encoder_candidates.json#CANDIDATE`` (that candidate's
frozen-encoder probe on val; description columns only). Accuracy with Wilson 95% intervals, chance, and
Octopi's published test-object rows beneath (a different split: Octopi's test objects are held out from this copy).

    python benchmarks/physiclear_table.py --split val --name physiclear_val \\
        --row "random=runs/physiclear/baselines/random" --row "majority=runs/physiclear/baselines/majority" \\
        --row "linear probe=benchmarks/results/physiclear_probe.json" --row "SmolLM2 core=runs/physiclear/eval_val"
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, publish, stamp


def row_table(path: Path) -> tuple[dict, int]:
    """(Octopi-column table, number of runs) of one row's source."""
    from tacreasoner.evaluate.octopi import OCTOPI_COLUMNS, octopi_table
    from tacreasoner.evaluate.report import load_scored, summarize

    path, _, candidate = str(path).partition("#")
    path = Path(path)
    if path.suffix == ".json" and candidate:  # benchmarks/encoder_candidates.json#<candidate>: its val probe
        from tacreasoner.intervals import wilson_interval

        found = json.loads(path.read_text())["results"][candidate]
        n = found["val_n"]
        cells = {}
        for c, acc in found["val"].items():
            low, high = wilson_interval(round(acc * n), n)
            cells[c] = {"n": n, "accuracy": acc, "ci_low": low, "ci_high": high}
        return {c: ({**cells[c], "runs": 1, "std": float("nan"), "task": t, "parse_failure_rate": 0.0,
                     "chance": 1 / 27 if c == "combined" else 1 / 3} if c in cells else None)
                for c, t in OCTOPI_COLUMNS}, 1
    if path.suffix == ".json":
        val = json.loads(path.read_text())["val"]
        return {c: ({**val[c], "runs": 1, "std": float("nan"), "task": t, "parse_failure_rate": 0.0}
                     if c in val else None) for c, t in OCTOPI_COLUMNS}, 1
    files = sorted((path / "scored").glob("*.jsonl"))
    if not files:
        raise SystemExit(f"{path}: no scored/*.jsonl (run `tacreasoner score` or `evaluate` first)")
    return octopi_table(summarize({f.stem: load_scored(f) for f in files})), len(files)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--row", action="append", required=True, metavar="LABEL=PATH")
    ap.add_argument("--split", default="val")
    ap.add_argument("--name", default="physiclear_val")
    ap.add_argument("--notes", default="", help="what was trained where, and how")
    args = ap.parse_args()
    from tacreasoner.evaluate.octopi import OCTOPI_COLUMNS, PUBLISHED, octopi_markdown

    rows, spec_of = {}, {}
    for spec in args.row:
        label, sep, path = spec.partition("=")
        if not sep:
            raise SystemExit(f"--row {spec!r}: expected LABEL=PATH")
        rows[label], spec_of[label] = row_table(Path(path)), path
    info = stamp()
    md = header_md(f"PhysiCLeAR {args.split}: Octopi's task set", info) + (args.notes + "\n\n" if args.notes else "")
    columns = [c for c, _ in OCTOPI_COLUMNS]
    first = True
    for label, (table, runs) in rows.items():
        text = octopi_markdown(table, label=f"{label}{f' ({runs} runs)' if runs > 1 else ''}", split=args.split)
        lines = text.splitlines()
        # one header, one chance line and the published rows once, at the end
        body = [line for line in lines[2:] if line.startswith(f"| {label}")]
        if first:
            md += "\n".join(lines[:2]) + "\n"
            n_line = next(line for line in lines if line.startswith("| n items"))
            chance = next(line for line in lines if line.startswith("| chance"))
            first = False
        md += "\n".join(body) + "\n"
        if (Path(spec_of[label]) / "settings.json").is_file():  # a model's replies (evaluate's folder)
            md += (f"| ↳ {label}: replies in the asked form % | "
                   + " | ".join("–" if table.get(c) is None else f"{100 * (1 - table[c]['parse_failure_rate']):.1f}"
                                for c in columns) + " |\n")
            if any(not math.isnan(table[c].get("follows_rate", math.nan)) for c in columns if table.get(c)):
                md += (f"| ↳ {label}: answer follows from the levels it stated % | "
                       + " | ".join("–" if table.get(c) is None or math.isnan(table[c].get("follows_rate", math.nan))
                                    else f"{100 * table[c]['follows_rate']:.1f}" for c in columns) + " |\n")
    md += n_line + "\n" + chance + "\n"
    md += "\n".join(f"| {name} (published, Octopi's test objects) | "
                    + " | ".join(f"{row[c]:.1f}" if c in row else "–" for c in columns) + " |"
                    for name, row in PUBLISHED.items()) + "\n"
    md += ("\nAccuracy in % with the Wilson 95% interval over items (± std over runs when several); strict scorer; "
           f"n items is the first row's. PSS = SOI, POM = OSC, PSR = TSA (zero-shot). The {args.split} split holds "
           "few objects, and clips of one object are not independent: read the intervals as optimistic. 'Answer "
           "follows from the levels it stated': of all replies (pooled over runs), those whose answer is one the "
           "levels their reasoning stated imply (tasks/conclude.py); shown only for rows whose replies state levels.\n")
    publish(args.name, {**info, "split": args.split, "rows": {k: {"runs": r, "table": t} for k, (t, r) in
                                                              rows.items()}, "published": PUBLISHED,
                        "notes": args.notes}, md)


if __name__ == "__main__":
    main()
