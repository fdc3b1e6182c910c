"""Publish a quickstart run: per-stage wall times from its console log, and its results report.

The quickstart is measured from a fresh clone with the README's first command, its output kept:

    git clone <repo> fresh && cd fresh
    (time (python3 -m venv .venv && .venv/bin/pip install -q -e ".[train]" && .venv/bin/tacreasoner quickstart)) \\
        > quickstart.log 2>&1
    python benchmarks/quickstart_summary.py --log quickstart.log --run runs/quickstart

Results: benchmarks/results/quickstart.{json,md} (the run's report.md is embedded; ``--name`` for another stem).
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp

STAGE = re.compile(r"^\[(\d+)/(\d+)\] ([\w-]+): (.*)$")
DONE = re.compile(r"^\s+done in ([\d.]+) s$")
REAL = re.compile(r"^real\s+(\d+)m([\d.]+)s$")


def parse_log(text: str) -> tuple[list[dict], float | None, list[str]]:
    """Stages with seconds, the `time` total (seconds, install included) and the `ask` stage's lines."""
    stages: list[dict] = []
    total = None
    ask: list[str] = []
    current = None
    for line in text.replace("\r", "\n").splitlines():
        if m := STAGE.match(line):
            current = {"stage": m.group(3), "purpose": m.group(4), "seconds": None}
            stages.append(current)
        elif (m := DONE.match(line)) and current is not None:
            current["seconds"] = float(m.group(1))
            current = None
        elif m := REAL.match(line.strip()):
            total = 60 * int(m.group(1)) + float(m.group(2))
        elif current is not None and current["stage"] == "ask" and line.startswith("    "):
            ask.append(line.strip())
    return stages, total, ask


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--log", type=Path, required=True)
    parser.add_argument("--run", type=Path, default=Path("runs/quickstart"))
    parser.add_argument("--note", default="", help="What else ran on the machine meanwhile, etc.")
    parser.add_argument("--name", default="quickstart", help="Result file stem under benchmarks/results/ (e.g. "
                                                             "quickstart_seeds for a --seeds 3 re-run of a run).")
    parser.add_argument("--command", default='python3 -m venv .venv && .venv/bin/pip install -q -e ".[train]" && '
                                             '.venv/bin/tacreasoner quickstart (from a fresh clone, fresh virtual '
                                             'environment)')
    parser.add_argument("--title", default="Quickstart: the whole pipeline from a fresh clone")
    parser.add_argument("--target-minutes", type=float, default=None, help="The wall-time bar to state beside it.")
    args = parser.parse_args()
    stages, total, ask = parse_log(args.log.read_text(encoding="utf-8", errors="replace"))
    if not stages:
        sys.exit(f"{args.log}: no quickstart stages found")
    report = (args.run / "report.md").read_text(encoding="utf-8") if (args.run / "report.md").is_file() else ""
    results = json.loads((args.run / "report.json").read_text()) if (args.run / "report.json").is_file() else {}
    stage_total = sum(s["seconds"] or 0 for s in stages)
    info = stamp()
    info["command"] = args.command
    md = header_md(args.title, info)
    md += (f"**Wall time: {stage_total / 60:.1f} min for the quickstart's stages**"
           + (f"; {total / 60:.1f} min including creating the virtual environment and installing" if total else "")
           + (f". Target: ≤ {args.target_minutes:g} minutes." if args.target_minutes else ".") + "\n\n"
           + (f"Note: {args.note}\n\n" if args.note else ""))
    md += md_table(["stage", "what", "seconds"], [[s["stage"], s["purpose"], s["seconds"] or "–"] for s in stages])
    if ask:
        md += "\nThe `ask` stage (one held-out test clip):\n\n```\n" + "\n".join(ask) + "\n```\n"
    md += f"\n---\n\nThe run's own report (`{args.run / 'report.md'}`):\n\n" + report.replace("# ", "## ", 1)
    publish(args.name, {**info, "note": args.note, "stages": stages, "stage_seconds": stage_total,
                           "total_seconds": total, "ask": ask, "results": results}, md)


if __name__ == "__main__":
    main()
