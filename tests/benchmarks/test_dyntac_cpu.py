"""benchmarks/dyntac_cpu.sh run as a user runs it, with a stand-in `tacreasoner` that writes what each command
would: which runs a job list trains and answers, that a rerun repeats nothing (resumable), that the cot variant
trains Stage II only on the recipe's Stage I of its seed, and that ARCHIVE holds every scored run, the quickstart's
linked seed 0 included (a machine lost mid-chain once took the only copy of a table's per-item answers)."""

from __future__ import annotations

import os
import subprocess
import sys
import tarfile
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "dyntac_cpu.sh"

# The stand-in: logs its arguments, and creates the folders and files the chain checks for.
FAKE_TR = r'''
import json, sys
from pathlib import Path
args = sys.argv[1:]
with open(sys.argv[0] + ".calls", "a") as log:
    log.write(" ".join(args) + "\n")
def value(flag):
    return args[args.index(flag) + 1]
def setting(key):
    return next(a.split("=", 1)[1] for a in args if a.startswith(key + "="))
if args[0] == "train":
    (Path(setting("output_dir")) / f"stage{value('--stage')}" / "model").mkdir(parents=True, exist_ok=True)
    (Path(setting("output_dir")) / f"stage{value('--stage')}" / "run.json").write_text("{}")
elif args[0] == "evaluate":
    out = Path(value("--out"))
    for sub in ("scored", "predictions"):
        (out / sub).mkdir(parents=True, exist_ok=True)
        (out / sub / "val.jsonl").write_text(json.dumps({"model": value("--model")}) + "\n")
    (out / "report.json").write_text("{}")
elif args[0] == "build-cot":
    (Path(value("--out")) / "touchcot").mkdir(parents=True)
    (Path(value("--out")) / "touchcot" / "touchcot_train.jsonl").write_text("{}\n")
'''


def _quickstart(root: Path) -> Path:
    """A finished quickstart run folder: what the chain reads, its seed-0 model and that model's val answers."""
    q = root / "quickstart"
    for need in ("bench", "encoder", "llm", "video_cache", "train/seed0/stage1/model"):
        (q / need).mkdir(parents=True)
    (q / "train/seed0/stage2/model").mkdir(parents=True)
    (q / "train/seed0/stage2/model/config.json").write_text("{}")
    (q / "eval_val/scored").mkdir(parents=True)
    (q / "eval_val/scored/val.jsonl").write_text('{"model": "quickstart seed 0"}\n')
    return q


def _chain(tmp_path: Path, jobs: str) -> tuple[subprocess.CompletedProcess, list[str]]:
    fake = tmp_path / "fake_tr.py"
    fake.write_text(FAKE_TR)
    q = tmp_path / "quickstart" if (tmp_path / "quickstart").exists() else _quickstart(tmp_path)
    env = os.environ | {"Q": str(q), "OUT": str(tmp_path / "out"), "TR": f"{sys.executable} {fake}", "JOBS": jobs,
                        "ARCHIVE": str(tmp_path / "results" / "x_inputs" / "scored.tgz")}
    done = subprocess.run(["bash", str(SCRIPT)], env=env, capture_output=True, text=True, timeout=120)
    calls_file = Path(str(fake) + ".calls")
    calls = calls_file.read_text().splitlines() if calls_file.exists() else []
    calls_file.unlink(missing_ok=True)
    return done, calls


def test_a_chain_trains_what_it_lists_archives_every_scored_run_and_repeats_nothing(tmp_path: Path) -> None:
    done, calls = _chain(tmp_path, "cot:0 rec:1")
    assert done.returncode == 0, done.stderr
    trains = [c for c in calls if c.startswith("train")]
    # cot seed 0: Stage II only (its Stage I is the quickstart's seed-0 run); rec seed 1: both stages
    assert [c.split()[2] for c in trains] == ["2", "1", "2"]
    assert "data.stage2_data=touchcot" in trains[0] and "seed=0" in trains[0]
    assert (tmp_path / "out/runs/cot.seed0/stage1").resolve() == (tmp_path / "quickstart/train/seed0/stage1")
    assert sum(c.startswith("build-cot") for c in calls) == 1
    cot_eval = next(c for c in calls if c.startswith("evaluate") and "cot.seed0" in c)
    assert "--max-new-tokens 512" in cot_eval  # TouchCoT's reasoning runs to ~420 tokens

    with tarfile.open(tmp_path / "results/x_inputs/scored.tgz") as tar:
        names = set(tar.getnames())
        linked = tar.extractfile("eval/rec.seed0/val/scored/val.jsonl").read().decode()
    assert {"eval/cot.seed0/val/scored/val.jsonl", "eval/rec.seed1/val/scored/val.jsonl",
            "eval/cot.seed0/val/predictions/val.jsonl", "runs/rec.seed1/stage2/run.json", "chains.log"} <= names
    assert "quickstart seed 0" in linked  # the link's target archived, not the link

    again, calls = _chain(tmp_path, "cot:0 rec:1")
    assert again.returncode == 0, again.stderr
    assert calls == []


def test_a_job_list_entry_of_an_unknown_variant_is_refused_before_any_work(tmp_path: Path) -> None:
    done, calls = _chain(tmp_path, "rec:1 touchcot:0")
    assert done.returncode == 2
    assert "JOBS entry 'touchcot:0'" in done.stderr
    assert calls == []
