"""The rule of criteria.md applied: TFA answered by the reading vote vs one pass, per seed, from what the shipped
models already said (PhysiCLeAR val, `evaluate-physiclear --answers stepwise-vote` folders; the vote's readings are
the sub-replies recorded in model<k>/predictions/val.steps.jsonl). Readings not recorded there are counted, and
the item is left out of both columns when any is missing (reported).

    python experiments/2026-11-29_read_single_clip/measure.py [FOLDER ...]
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


def measure(folder: Path) -> dict:
    info, items = load_bench(folder / "bench", "val")
    root = bench_video_root(folder / "bench", info)
    out: dict = {}
    for model in sorted(folder.glob("model*")):
        one_pass = {r["id"]: r["prediction"] for r in map(json.loads, (model / "predictions" / "val.jsonl").open())}
        said = {r["key"]: r["reply"] for r in map(json.loads, (model / "predictions" / "val.steps.jsonl").open())}
        per_task: dict[str, dict] = {t: {"one_pass": [], "vote": [], "read": 0, "missing": 0, "unread": 0}
                                     for t in TFA}
        for item in (i for i in items if i.task in TFA):
            row = per_task[item.task]
            view = question_view(item, single_clip=True)
            if view is None:
                row["unread"] += 1
                continue
            keys = [video_key(v, root, item.id) for v in item.videos]
            if any(s.key not in said for s in steps_for(view, keys, VOTE_TEMPLATES)):
                row["missing"] += 1
                continue
            reply = conclude(view, keys, said, VOTE_TEMPLATES).reply
            row["read"] += 1
            row["vote"].append(score_item(item, reply).correct)
            row["one_pass"].append(score_item(item, one_pass[item.id]).correct)
        out[model.name] = {t: {"n": r["read"], "missing": r["missing"], "unread": r["unread"],
                               "one_pass": 100 * statistics.mean(r["one_pass"]) if r["one_pass"] else None,
                               "vote": 100 * statistics.mean(r["vote"]) if r["vote"] else None}
                           for t, r in per_task.items()}
    return out


def main() -> None:
    folders = [Path(a) for a in sys.argv[1:]] or \
        [Path("runs/physiclear/eval_val_stepwise_vote/rec.seeds0-1-2")]
    for folder in folders:
        result = measure(folder)
        print(f"## {folder}")
        print("| model | task | n | missing readings | unread question | one pass | vote |")
        print("|---|---|---|---|---|---|---|")
        for model, tasks in result.items():
            for task, r in tasks.items():
                fmt = (lambda v: "–" if v is None else f"{v:.1f}")
                print(f"| {model} | {task} | {r['n']} | {r['missing']} | {r['unread']} | {fmt(r['one_pass'])} | "
                      f"{fmt(r['vote'])} |")
        print(json.dumps(result))


if __name__ == "__main__":
    main()
