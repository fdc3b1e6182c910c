"""How mixed the training batches are, with and without length grouping, on a quickstart run's data.

Length grouping sorts chunks of global batches by token length to pad less. On TouchCoT, length follows
the task (each task has its own question and reasoning template) and, within a task, the answer (answer
names differ in length), so sorted batches hold one task and one answer far more often than a shuffle's.
A batch of one answer teaches "say this answer"; this script measures that, per stage's data:

- task purity: mean share of a batch taken by its most common task (1 = single-task batches);
- answer purity: the same for (task, answer);
- padding: share of the padded token grid that is padding (what grouping saves).

    python benchmarks/batch_mix.py --run runs/quickstart [--time-steps 60]

Results: benchmarks/results/batch_mix.{json,md}. The purities replay ``batch_plan`` for one epoch's worth
of steps per setting; ``--time-steps N`` also trains Stage II for N steps (from the pre-trained LLM, in a
temporary directory) with and without grouping, back to back, and reports the seconds per step.
"""

from __future__ import annotations

import argparse
import re
import sys
import tempfile
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp
from tacreasoner.train.data import batch_plan, batch_purity, load_examples, padding_fraction, tokenize_examples
from tacreasoner.train.quickstart import QuickstartPaths, quickstart_config

ANSWER = re.compile(r"<answer>(.*?)</answer>", re.S)
SETTINGS = [("shuffle (group_by_length: false)", False, 1), ("grouped, chunks of 4 batches", True, 4),
            ("grouped, chunks of 8 batches", True, 8), ("grouped, chunks of 32 batches (old default)", True, 32)]


def measure(run: Path, stage: int, processor: Any) -> list[dict]:
    config = quickstart_config(QuickstartPaths(run), 0)
    examples = load_examples(stage, config.data.bench, touchcot=config.data.touchcot,
                             stage2_data=config.data.stage2_data)
    tokenized, _ = tokenize_examples(processor, examples, config.data.max_length)
    by_key = {e.key: e for e in examples}
    lengths = [len(t.input_ids) for t in tokenized]
    tasks = [by_key[t.key].task for t in tokenized]
    answers = [(by_key[t.key].task, m.group(1).strip() if (m := ANSWER.search(by_key[t.key].target)) else "")
               for t in tokenized]
    batch = config.stage(stage).batch_size
    steps = len(lengths) // batch
    rows = []
    for name, group, chunk in SETTINGS:
        batches = [batch_plan(lengths, batch, s, config.seed, group, chunk) for s in range(steps)]
        rows.append({"stage": stage, "setting": name, "group_by_length": group, "length_group_batches": chunk,
                     "examples": len(lengths), "batch_size": batch, "batches": steps,
                     "task_purity": round(batch_purity(batches, tasks), 3),
                     "answer_purity": round(batch_purity(batches, answers), 3),
                     "padding": round(padding_fraction(lengths, batches), 3)})
    return rows


def time_steps(run: Path, steps: int) -> list[dict]:
    """Seconds per Stage II step without and with grouping, measured back to back (compare the ratio)."""
    from tacreasoner.train.trainer import train_stage

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, group in (("shuffle", False), ("grouped, chunks of 32", True)):
            config = quickstart_config(QuickstartPaths(run), 0, {
                "stage1": {"skip": True}, "stage2": {"steps": steps},
                "data": {"group_by_length": group, "length_group_batches": 32},
                "runtime": {"log_with": "none", "progress": False, "checkpoint_every": steps}},
                output_dir=Path(tmp) / name.split(",")[0])
            result = train_stage(config, 2)
            rows.append({"setting": name, "steps": steps, "train_seconds": round(result.train_seconds, 1),
                         "seconds_per_step": round(result.train_seconds / steps, 3)})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--run", type=Path, default=Path("runs/quickstart"), help="a finished quickstart run")
    parser.add_argument("--time-steps", type=int, default=0, help="also time this many Stage II steps per setting")
    args = parser.parse_args()
    info = stamp()
    from tacreasoner.model.build import build_model

    config = quickstart_config(QuickstartPaths(args.run), 0)
    _, processor = build_model(config.model.llm, appearance=config.model.appearance, encoder=config.model.encoder)
    rows = measure(args.run, 1, processor) + measure(args.run, 2, processor)
    timing = time_steps(args.run, args.time_steps) if args.time_steps > 0 else []
    md = header_md("Batch mixing with and without length grouping", info)
    md += ("One epoch of `batch_plan` per setting on the quickstart's Stage I (description) and Stage II "
           "(brief TouchCoT) data. Purity is the mean share of a batch taken by its most common task, or "
           "(task, answer); padding is the share of the padded token grid that is padding.\n\n")
    md += md_table(["Stage", "Setting", "Examples", "Batch", "Task purity", "Answer purity", "Padding"],
                   [[r["stage"], r["setting"], r["examples"], r["batch_size"], r["task_purity"],
                     r["answer_purity"], r["padding"]] for r in rows])
    if timing:
        md += (f"\nStage II step time, {args.time_steps} steps each, back to back on this machine (batch "
               f"{config.stage2.batch_size}, from the pre-trained LLM):\n\n")
        md += md_table(["Setting", "Seconds per step"], [[r["setting"], r["seconds_per_step"]] for r in timing])
        saved = 1 - timing[1]["seconds_per_step"] / timing[0]["seconds_per_step"]
        md += f"\nGrouping saves {saved:.0%} of step time.\n"
    md += ("\nWhat the mixing costs in accuracy (hand runs on the quickstart's data, same settings but the "
           "grouping): docs/training.md, \"Where the tiny model stands\".\n")
    publish("batch_mix", {**info, "run": str(args.run), "rows": rows, "timing": timing}, md)


if __name__ == "__main__":
    main()
