"""A person's words: single-clip items asked in held-out wordings, answered in one pass (what the models said) or
from the reading vote (their recorded readings of the same clips), per seed: the share of replies of the asked kind
(a level word of the asked property: the strict scorer parses it) and accuracy.

    python experiments/2026-11-29_read_single_clip/measure_wordings.py WORDED_FOLDER READINGS_FOLDER

WORDED_FOLDER: an `evaluate-physiclear --wording heldout|heldout2` output (its bench and one-pass TFA answers);
READINGS_FOLDER: the `--answers stepwise-vote` folder of the same models whose val.steps.jsonl holds the readings.
"""

from __future__ import annotations

import json
import statistics
import sys
from pathlib import Path

from tacreasoner.evaluate.stepwise import VOTE_TEMPLATES, conclude, question_view, steps_for
from tacreasoner.tasks.bench import load_bench
from tacreasoner.tasks.scoring import score_item
from tacreasoner.train.data import bench_video_root, video_key

TFA = ("TFA-hardness", "TFA-roughness", "TFA-bumpiness", "TFA-combined")


def main() -> None:
    worded, readings = Path(sys.argv[1]), Path(sys.argv[2])
    info, items = load_bench(worded / "bench", "val")
    root = bench_video_root(worded / "bench", info)
    table = {}
    for model in sorted(worded.glob("model*")):
        one_pass = {r["id"]: r["prediction"] for r in map(json.loads, (model / "predictions" / "val.jsonl").open())}
        steps = readings / model.name / "predictions" / "val.steps.jsonl"
        said = {r["key"]: r["reply"] for r in map(json.loads, steps.open())}
        rows: dict[str, dict[str, list]] = {}
        for item in (i for i in items if i.task in TFA and i.id in one_pass):
            row = rows.setdefault(item.task, {"one_kind": [], "one_ok": [], "read_kind": [], "read_ok": [],
                                              "unread": [], "missing": []})
            first = score_item(item, one_pass[item.id])
            row["one_kind"].append(not first.parse_failed)
            row["one_ok"].append(first.correct)
            view = question_view(item, single_clip=True)
            keys = [video_key(v, root, item.id) for v in item.videos]
            if view is None:  # the words name no property: answered in one pass, as before
                row["unread"].append(item.meta.get("template"))
                reply = one_pass[item.id]
            elif any(s.key not in said for s in steps_for(view, keys, VOTE_TEMPLATES)):
                row["missing"].append(item.id)
                reply = one_pass[item.id]
            else:
                reply = conclude(view, keys, said, VOTE_TEMPLATES).reply
            read = score_item(item, reply)
            row["read_kind"].append(not read.parse_failed)
            row["read_ok"].append(read.correct)
        table[model.name] = {t: {"n": len(r["one_ok"]), "one_pass_asked_kind": 100 * statistics.mean(r["one_kind"]),
                                 "one_pass": 100 * statistics.mean(r["one_ok"]),
                                 "reading_asked_kind": 100 * statistics.mean(r["read_kind"]),
                                 "reading": 100 * statistics.mean(r["read_ok"]),
                                 "unread": len(r["unread"]), "unread_templates": sorted(set(r["unread"])),
                                 "missing_readings": len(r["missing"])} for t, r in rows.items()}
    print(f"| model | task | n | one pass: asked kind | one pass: right | reading: asked kind | reading: right | "
          f"words naming no property | readings missing |")
    print("|---|---|---|---|---|---|---|---|---|")
    for model, tasks in table.items():
        for task, r in sorted(tasks.items()):
            print(f"| {model} | {task} | {r['n']} | {r['one_pass_asked_kind']:.1f} | {r['one_pass']:.1f} | "
                  f"{r['reading_asked_kind']:.1f} | {r['reading']:.1f} | {r['unread']} "
                  f"{r['unread_templates'] or ''} | {r['missing_readings']} |")
    print(json.dumps(table))


if __name__ == "__main__":
    main()
