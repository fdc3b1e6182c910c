"""The quickstart's training half: its settings equal configs/tiny-cpu.yaml; evaluation and report on a tiny run."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from trainsetup import tiny_config, training_inputs

from tacreasoner.train.config import load_train_config
from tacreasoner.train.quickstart import (
    QuickstartPaths,
    ask_one_test_clip,
    distributed_config,
    evaluate_and_report,
    quickstart_config,
    results_table,
    train_seed,
)
from tacreasoner.train.trainer import train_stage

ROOT = Path(__file__).resolve().parents[2]


def test_quickstart_settings_are_the_tiny_cpu_yaml() -> None:
    yaml_config = load_train_config(ROOT / "configs" / "tiny-cpu.yaml").to_dict()
    quick = quickstart_config(QuickstartPaths(Path("runs/quickstart")), 0).to_dict()
    for section in ("stage1", "stage2", "lora"):
        assert quick[section] == yaml_config[section], section
    for key in ("max_length", "stage2_data", "group_by_length", "cache_appearance"):
        assert quick["data"][key] == yaml_config["data"][key], key
    assert quick["model"]["encoder"] == yaml_config["model"]["encoder"] or not quick["model"]["encoder"]
    assert quick["runtime"] == {**yaml_config["runtime"], "progress": quick["runtime"]["progress"]}


@pytest.fixture(scope="module")
def inputs(small_sim_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> dict:
    return training_inputs(small_sim_dataset, tmp_path_factory.mktemp("train_inputs_qs"))


@pytest.fixture(scope="module")
def trained_run(inputs: dict, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict]:
    root = tmp_path_factory.mktemp("quick")
    shutil.copytree(inputs["bench"], root / "bench")
    config = tiny_config(inputs, root / "train" / "seed0", data={"bench": str(root / "bench")},
                         stage1={"skip": True})
    train_stage(config, 2)
    return root, inputs


def test_evaluate_and_report_writes_tables_verdicts_and_publishes_the_model(trained_run) -> None:
    root, _ = trained_run
    paths = QuickstartPaths(root)
    report = evaluate_and_report(paths, {0: paths.train(0) / "stage2" / "model"}, {"seed0": {"stage2": 1.0}})
    text = report.path.read_text()
    assert "Held-out test objects (`test`)" in text and "held-out sensor style" in text
    assert "| **Average** |" in text and "Beats chance" in text
    data = json.loads((root / "report.json").read_text())
    assert set(data["splits"]) == {"test", "test_heldout_sensor"}
    tasks = {t["task"] for t in data["splits"]["test"]["tasks"]}
    assert set(report.beats_chance["test"]) == tasks
    assert (paths.model / "config.json").is_file(), "the seed-0 model is published for `tacreasoner ask`"
    lines = (paths.evaluation / "test" / "predictions" / "seed0.jsonl").read_text().splitlines()
    again = evaluate_and_report(paths, {0: paths.train(0) / "stage2" / "model"}, {})
    assert (paths.evaluation / "test" / "predictions" / "seed0.jsonl").read_text().splitlines() == lines, \
        "a finished prediction file is reused, not regenerated"
    assert again.summary_lines == report.summary_lines
    info_path = paths.bench / "bench.json"
    info = json.loads(info_path.read_text())
    info_path.write_text(json.dumps({**info, "version": info["version"] + 1}))
    try:  # the benchmark rebuilt at a new version: the old answers move aside and the items are answered anew
        evaluate_and_report(paths, {0: paths.train(0) / "stage2" / "model"}, {})
    finally:
        info_path.write_text(json.dumps(info))
    stale = paths.evaluation / "test" / "predictions" / "seed0.stale.jsonl"
    assert stale.read_text().splitlines() == lines
    fresh = [json.loads(line) for line in (stale.parent / "seed0.jsonl").read_text().splitlines()]
    assert len(fresh) == len(lines) and all(r["answered_by"].endswith(f" v{info['version'] + 1}") for r in fresh)


def test_ask_one_test_clip_prints_a_command_that_can_be_pasted(trained_run, monkeypatch) -> None:
    root, _ = trained_run
    paths = QuickstartPaths(root)
    if not (paths.model / "config.json").is_file():
        evaluate_and_report(paths, {0: paths.train(0) / "stage2" / "model"}, {})
    monkeypatch.chdir(root)
    command, think, answer = ask_one_test_clip(paths)
    video = command.rsplit(" --video ", 1)[1]
    assert Path(video).is_file(), video
    assert command.startswith("$ tacreasoner ask --model model "), "paths under the working directory are relative"
    monkeypatch.chdir(Path(video).parents[2])
    assert ask_one_test_clip(paths)[0].endswith(f" --video {Path(*Path(video).parts[-3:])}")
    assert think.startswith("think:") and answer.startswith("answer:") and "(gold: " in answer


def test_results_table_says_which_tasks_beat_chance(trained_run) -> None:
    from tacreasoner.evaluate.report import evaluate
    from tacreasoner.tasks.bench import load_bench

    root, _ = trained_run
    _, items = load_bench(root / "bench", "test")
    perfect = root / "perfect.jsonl"
    perfect.write_text("".join(json.dumps({"id": i.id, "prediction": f"<answer>{i.answer}</answer>"}) + "\n"
                               for i in items))
    wrong = root / "wrong.jsonl"
    wrong.write_text("".join(json.dumps({"id": i.id, "prediction": "no idea"}) + "\n" for i in items))
    rows, verdict = results_table(evaluate(items, [perfect], "strict", root / "perfect"), {})
    assert len(verdict) > 1 and len(rows[2:-1]) == len(verdict)  # the checks below are never vacuously true
    assert all(verdict.values()) and all(row.endswith("| yes |") for row in rows[2:-1])
    _, wrong_verdict = results_table(evaluate(items, [wrong], "strict", root / "wrong"), {"random": {}})
    assert wrong_verdict.keys() == verdict.keys() and not any(wrong_verdict.values())


def test_quickstart_touchcot_is_the_brief_first_rules_teacher_with_repeats_kept(
        small_sim_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> None:
    from tacreasoner.cli import quickstart_teacher
    from tacreasoner.cot.backends import load_teacher_config
    from tacreasoner.cot.build import build_cot

    shipped = load_teacher_config(ROOT / "configs" / "teacher-rules-brief-first.yaml")
    used = quickstart_teacher()
    assert (used.backend, used.model, used.extra["style"]) == (shipped.backend, shipped.model, shipped.extra["style"])
    inputs = training_inputs(small_sim_dataset, tmp_path_factory.mktemp("train_inputs_qs"))
    out = tmp_path_factory.mktemp("brief_cot")
    shutil.copytree(inputs["touchcot"].parents[1] / "cue_cache", out / "cue_cache")  # cues are the same
    result = build_cot(inputs["bench"], out, used, workers=1)
    samples = [json.loads(line) for line in (out / "samples.jsonl").read_text(encoding="utf-8").splitlines()]
    assert {s["model"] for s in samples} == {"rules-brief-first-v1"}
    assert all(s["output"].startswith(f"<think>Answer: {s['gold_answer']}. ") for s in samples)
    thinks = [s["output"].split("</think>")[0] for s in samples]
    report = json.loads((out / "build_cot.json").read_text(encoding="utf-8"))
    assert result.accepted == result.jobs and "near_duplicate" not in report["filter"]["reasons"]
    full = [json.loads(line)["output"] for line in inputs["touchcot"].read_text(encoding="utf-8").splitlines()]
    assert sum(map(len, thinks)) / len(thinks) < 0.5 * sum(map(len, full)) / len(full)


def test_distributed_config_keeps_the_global_batch_and_refuses_an_uneven_split(tmp_path: Path) -> None:
    config = quickstart_config(QuickstartPaths(tmp_path), 0)
    split = distributed_config(config, 2, 2)
    assert split.stage2.global_batch == config.stage2.batch_size * config.stage2.grad_accum
    assert split.stage2.micro_batch("stage2", 2) * 2 == config.stage2.batch_size
    assert split.stage1 == config.stage1 and split.runtime.threads == 1
    with pytest.raises(ValueError, match=r"does not split into 3 process\(es\)"):
        distributed_config(config, 2, 3)


def test_train_seed_over_two_processes_trains_with_the_same_global_batch(inputs: dict, tmp_path: Path) -> None:
    config = tiny_config(inputs, tmp_path / "run", stage1={"skip": True})
    info = train_seed(config, processes=2)
    run = json.loads((tmp_path / "run" / "stage2" / "run.json").read_text())
    assert run["processes"] == 2 and run["global_batch"] == config.stage2.batch_size
    assert run["steps_done"] == config.stage2.steps
    assert Path(info["model"]).is_dir() and "stage2" in info["seconds"]
    assert train_seed(config, processes=2)["seconds"] == {}  # done: not redone
