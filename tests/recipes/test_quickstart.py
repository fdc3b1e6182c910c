"""The quickstart: its settings are package data naming the recommended model; evaluation, report and the asked
question on a tiny trained run."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from tacreasoner.recipes.quickstart import (
    QUICKSTART_SETTINGS,
    QuickstartPaths,
    QuickstartRun,
    QuickstartSettings,
    quickstart_config,
    quickstart_stages,
)
from tacreasoner.recipes.quickstart_report import ask_one_test_clip, evaluate_and_report, results_table
from tacreasoner.train.config import SHIPPED_CONFIGS, load_train_config
from tacreasoner.train.trainer import train_stage
from tests.train.trainsetup import tiny_config, training_inputs


def test_quickstart_settings_ship_with_the_package_and_name_the_recommended_model(tmp_path: Path) -> None:
    settings = QuickstartSettings.load()
    assert settings.train_config in SHIPPED_CONFIGS and settings.llm == "smollm2"
    shipped = load_train_config(settings.train_config).to_dict()
    assert shipped["data"]["stage2_data"] == "plain" and shipped["model"]["encoder"]["cross_video"] > 0
    config = quickstart_config(QuickstartPaths(tmp_path / "qs"), 3).to_dict()
    assert config["model"]["llm"] == str(tmp_path / "qs" / "llm")
    assert config["model"]["appearance"] == str(tmp_path / "qs" / "encoder")
    assert config["data"]["bench"] == str(tmp_path / "qs" / "bench") and config["seed"] == 3
    assert config["output_dir"] == str(tmp_path / "qs" / "train" / "seed3")
    for section in ("stage1", "stage2", "lora"):
        assert config[section] == shipped[section], section
    given = QuickstartPaths(tmp_path / "qs", llm_dir=tmp_path / "my_llm")
    assert quickstart_config(given, 0).model.llm == str(tmp_path / "my_llm")
    assert settings.eval_dtype == "auto"  # bf16 answering only where the hardware has it (chosen on val)
    assert settings.answers == "auto"  # how ask/serve/demo answer the published model (chosen on val)
    assert settings.gel_reference == "train" and "gel_reference" not in settings.encoder  # chosen on val
    assert settings.gel_swap == "imprint" and "gel_swap" not in settings.encoder  # chosen on val


def test_quickstart_stages_follow_the_data_flow(tmp_path: Path) -> None:
    stages = quickstart_stages(QuickstartRun(tmp_path / "qs"))
    names = [stage.name for stage in stages]
    assert names == ["simulate", "preview", "benchmark", "baselines", "llm", "encoder", "swap", "train", "evaluate",
                     "ask"]
    assert any(word in stages[7].purpose for word in ("bf16", "float32"))  # said before the long wait, not after
    data_only = [stage.name for stage in quickstart_stages(QuickstartRun(tmp_path / "qs", train=False))]
    assert data_only == names[:4]


def test_training_on_swapped_frames_adds_a_swap_stage_before_training(tmp_path: Path) -> None:
    from dataclasses import replace

    settings = QuickstartSettings.load()
    for swap, extra in (("imprint", ["swap"]), ("gate", []), ("none", [])):
        stages = quickstart_stages(QuickstartRun(tmp_path / "qs"), replace(settings, gel_swap=swap))
        names = [stage.name for stage in stages]
        assert names == ["simulate", "preview", "benchmark", "baselines", "llm", "encoder", *extra, "train",
                         "evaluate", "ask"], swap


def test_a_broken_settings_file_is_named(tmp_path: Path) -> None:
    broken = tmp_path / "quickstart.yaml"
    broken.write_text("simulate: {objects: 3}\n")
    with pytest.raises(ValueError, match=r"quickstart\.yaml: not a quickstart settings file"):
        QuickstartSettings.load(broken)
    swap = QuickstartSettings.load().gel_swap
    for shipped, edited, message in [  # one bad value at a time, each named
            ("dtype: auto", "dtype: fp8", r"not a quickstart settings file \(dtype must be one of .*got 'fp8'\)"),
            ("gel_reference: train", "gel_reference: val", r"gel_reference must be one of train, none, got 'val'"),
            ("background: keep", "background: subtract", r"gel_reference 'train' needs background 'keep'"),
            (f"gel_swap: {swap}", "gel_swap: always", r"gel_swap must be one of imprint, gate, none, got 'always'"),
            ("gel_reference: train", "gel_reference: none", rf"gel_swap '{swap}' needs gel_reference 'train'")]:
        assert shipped in QUICKSTART_SETTINGS.read_text()
        broken.write_text(QUICKSTART_SETTINGS.read_text().replace(shipped, edited))
        with pytest.raises(ValueError, match=message):
            QuickstartSettings.load(broken)


def test_auto_answers_in_bf16_only_where_the_hardware_computes_it(monkeypatch: pytest.MonkeyPatch) -> None:
    from tacreasoner.evaluate import predict
    from tacreasoner.train import precision

    monkeypatch.setattr(predict.torch.cuda, "is_available", lambda: False)
    for native, expected in ((True, "bfloat16"), (False, "float32")):
        monkeypatch.setattr(precision, "bf16_supported", lambda native=native: native)
        assert predict.resolve_dtype("auto") == expected
    assert predict.resolve_dtype("float32") == "float32" and predict.resolve_dtype(None) is None


@pytest.fixture(scope="module")
def inputs(small_sim_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> dict:
    return training_inputs(small_sim_dataset, tmp_path_factory)


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
    report = evaluate_and_report(paths, {0: paths.train(0) / "stage2" / "model"}, {"seed0": {"stage2": 1.0}},
                                 answers="auto")
    text = report.path.read_text()
    assert "Held-out test objects (`test`)" in text and "held-out sensor style" in text
    precision = json.loads((paths.train(0) / "stage2" / "run.json").read_text())["mixed_precision"]
    assert f"trained in {'float32' if precision == 'no' else 'bf16 autocast'};" in text  # timings depend on it
    assert "| **Average** |" in text and "Beats chance" in text
    data = json.loads((root / "report.json").read_text())
    assert set(data["splits"]) == {"test", "test_heldout_sensor"}
    tasks = {t["task"] for t in data["splits"]["test"]["tasks"]}
    assert set(report.beats_chance["test"]) == tasks
    assert (paths.model / "config.json").is_file(), "the seed-0 model is published for `tacreasoner ask`"
    from tacreasoner.serve.stepwise import model_answers

    assert model_answers(paths.model) == "auto" and model_answers(paths.train(0) / "stage2" / "model") == "direct"
    lines = (paths.evaluation / "test" / "predictions" / "seed0.jsonl").read_text().splitlines()
    cut = sum(json.loads(line)["cut"] for line in lines)  # each line says whether the 64-token budget stopped it
    assert ("stopped at the 64-token budget" in text) == (cut > 0)
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


def test_the_report_warns_of_replies_the_budget_cut(tmp_path: Path) -> None:
    from tacreasoner.recipes.quickstart_report import _cut_lines

    # seed0.stale.jsonl: answers set aside (another model or benchmark version), not this report's
    for name, cut in (("seed0", [True, False]), ("seed1", [True, True]), ("seed0.stale", [True, True])):
        path = tmp_path / "test" / "predictions" / f"{name}.jsonl"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("".join(json.dumps({"id": f"i{k}", "task": ["OSC", "SFD"][k], "prediction": "", "cut": c})
                                + "\n" for k, c in enumerate(cut)))
    lines = _cut_lines(tmp_path, ["test"], [0, 1], 64)
    assert lines[0].startswith("**Warning** (`test`): 3 replies stopped at the 64-token budget")
    assert lines[0].endswith("OSC 2, SFD 1.")
    for path in (tmp_path / "test" / "predictions").glob("seed?.jsonl"):
        path.write_text(path.read_text().replace('"cut": true', '"cut": false'))
    assert _cut_lines(tmp_path, ["test"], [0, 1], 64) == []


def test_ask_one_test_clip_prints_a_command_that_can_be_pasted(trained_run, monkeypatch) -> None:
    root, _ = trained_run
    paths = QuickstartPaths(root)
    if not (paths.model / "config.json").is_file():
        evaluate_and_report(paths, {0: paths.train(0) / "stage2" / "model"}, {})
    monkeypatch.chdir(root)
    command, *rest = ask_one_test_clip(paths)
    answer = rest[-1]
    video = command.rsplit(" --video ", 1)[1]
    assert Path(video).is_file(), video
    assert command.startswith("$ tacreasoner ask --model model "), "paths under the working directory are relative"
    monkeypatch.chdir(Path(video).parents[2])
    assert ask_one_test_clip(paths)[0].endswith(f" --video {Path(*Path(video).parts[-3:])}")
    assert answer.startswith("answer:") and "(gold: " in answer
    assert all(line.startswith("think:") for line in rest[:-1])


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


def test_reports_name_the_cpu_model_not_just_the_architecture() -> None:
    from tacreasoner.recipes.machine import cpu_name

    info = "processor\t: 0\nvendor_id\t: GenuineIntel\nmodel name\t: Intel(R) Xeon(R) Processor @ 2.50GHz\n"
    assert cpu_name(info) == "Intel(R) Xeon(R) Processor @ 2.50GHz"
    assert cpu_name("processor\t: 0\n")  # no model name line: platform's answer, never empty


def test_the_gel_reference_is_measured_on_train_clips_of_the_trained_sensor_only(trained_run) -> None:
    from tacreasoner.data.readers import read_sim_dataset
    from tacreasoner.model.video_processing import measure_gel_reference
    from tacreasoner.recipes.quickstart_parts import train_gel_reference

    root, _ = trained_run
    info = json.loads((root / "bench" / "bench.json").read_text())
    assert info["heldout_sensor"] == "digit" and {"val", "test"} <= set(info["splits"].values())
    paths = QuickstartPaths(root / "gel")
    shutil.copytree(root / "bench", paths.bench)
    reference, line = train_gel_reference(paths, max_clips=6)
    saved = json.loads(paths.gel_reference.read_text())
    clips = {c.clip_id: c for c in read_sim_dataset(info["data"])}
    used = [clips[c] for c in saved["clips"]]
    assert len(used) == 6 and saved["split"] == "train" and saved["sensors"] == ["mini"]
    assert all(info["splits"][c.object_id] == "train" and c.sensor == "mini" for c in used)
    assert reference == measure_gel_reference(used) and "6 train clips (mini)" in line
    everything = measure_gel_reference(list(clips.values())[:12])
    assert everything != reference, "the check above could tell other clips apart"
    assert train_gel_reference(paths)[0] == reference, "kept, not measured again"


def test_the_gel_swap_is_measured_on_train_clips_and_swaps_only_the_other_sensors(trained_run) -> None:
    from tacreasoner.data.readers import read_sim_dataset
    from tacreasoner.model.video_processing import VideoProcessingConfig, preprocess_video
    from tacreasoner.recipes.quickstart_parts import train_gel_reference, train_gel_swap

    root, _ = trained_run
    info = json.loads((root / "bench" / "bench.json").read_text())
    paths = QuickstartPaths(root / "swap")
    shutil.copytree(root / "bench", paths.bench)
    reference, _ = train_gel_reference(paths)
    video = {"num_frames": 4, "image_size": [24, 32], "background": "keep", "orientation": "match",
             "gel_reference": reference}
    swap, line = train_gel_swap(paths, video, max_clips=4)
    saved = json.loads(paths.gel_swap.read_text())
    clips = list(read_sim_dataset(info["data"]))
    train = [c for c in clips if info["splits"][c.object_id] == "train" and c.sensor == "mini"]
    assert saved["sensors"] == ["mini"] and saved["swap_above_clips"] == len(train) and saved["image_clips"] == 4
    assert np.asarray(swap["image"]).shape == (6, 8, 3) and f"any of {len(train)} train clips" in line
    gated = VideoProcessingConfig.from_dict({**video, "gel_image": swap["image"], "gel_swap_above": swap["swap_above"]})
    mapped = VideoProcessingConfig.from_dict(video)
    for clip in train:  # every train clip of the trained sensor is left as the colour map leaves it
        assert np.array_equal(preprocess_video(clip, gated), preprocess_video(clip, mapped))
    always = VideoProcessingConfig.from_dict({**video, "gel_image": swap["image"]})
    digit = [c for c in clips if c.sensor == "digit"][:4]
    for clip in digit:  # another sensor's clips are swapped
        assert np.array_equal(preprocess_video(clip, gated), preprocess_video(clip, always))
    assert train_gel_swap(paths, video)[1].startswith("already there")  # kept while the frames are prepared alike
    assert not train_gel_swap(paths, {**video, "image_size": [48, 64]})[1].startswith("already there")


def _run_folder_with_a_model(trained_run, tmp_path: Path) -> tuple[QuickstartPaths, Path, Path, dict]:
    """A fresh run folder holding the trained run's benchmark, and a copy of its model: (paths, model folder, its
    processor_config.json, that file's contents)."""
    root, _ = trained_run
    paths = QuickstartPaths(tmp_path / "qs")
    shutil.copytree(root / "bench", paths.bench)
    model = shutil.copytree(QuickstartPaths(root).train(0) / "stage2" / "model", tmp_path / "model")
    config_path = model / "processor_config.json"
    return paths, model, config_path, json.loads(config_path.read_text())


def test_the_quickstart_answers_with_its_gel_reference_and_publishes_it(trained_run, tmp_path: Path) -> None:
    from tacreasoner.model.processing import TacReasonerProcessor

    paths, model, config_path, config = _run_folder_with_a_model(trained_run, tmp_path)
    config["video"]["background"] = "keep"  # the quickstart's frames keep their gel colours
    config_path.write_text(json.dumps(config))
    report = evaluate_and_report(paths, {0: model}, {}, gel_reference="train")
    saved = json.loads(paths.gel_reference.read_text())  # measured on the run's train clips (test above)
    reference = {k: saved[k] for k in ("mean", "std")}
    for folder in (model, paths.model):
        assert TacReasonerProcessor.from_pretrained(folder).video_config.to_dict()["gel_reference"] == reference
    assert "colours mapped to the gel at rest of the run's train clips" in report.path.read_text()
    assert any(line.startswith("colour map (video.gel_reference)") for line in report.summary_lines)
    answered = json.loads((paths.evaluation / "test" / "predictions" / "seed0.jsonl").read_text().splitlines()[0])
    assert " processor=" in answered["answered_by"]
    gated = evaluate_and_report(paths, {0: model}, {}, gel_reference="train", gel_swap="gate")
    swap = json.loads(paths.gel_swap.read_text())
    for folder in (model, paths.model):
        video = TacReasonerProcessor.from_pretrained(folder).video_config.to_dict()
        assert video["gel_reference"] == reference and video["gel_swap_above"] == swap["swap_above"]
        assert video["gel_image"] == swap["image"]
    assert "gel at rest swapped for their average" in gated.path.read_text()
    assert any(line.startswith("gel swap for another sensor") for line in gated.summary_lines)
    evaluate_and_report(paths, {0: model}, {}, gel_reference="none")  # switched off: removed, answers redone
    video = json.loads(config_path.read_text())["video"]
    assert not {"gel_reference", "gel_image", "gel_swap_above"} & set(video)
    redone = json.loads((paths.evaluation / "test" / "predictions" / "seed0.jsonl").read_text().splitlines()[0])
    assert " processor=" in redone["answered_by"] and redone["answered_by"] != answered["answered_by"]


def _train_clips_of(root: Path, sensor: str = "mini") -> list:
    from tacreasoner.data.readers import read_sim_dataset

    info = json.loads((root / "bench" / "bench.json").read_text())
    return [c for c in read_sim_dataset(info["data"]) if info["splits"][c.object_id] == "train" and c.sensor == sensor]


def test_the_swap_stage_writes_the_train_clips_gel_at_rest_into_the_frames_training_reads(trained_run) -> None:
    from tacreasoner.model.video_processing import VideoProcessingConfig, measure_gel_image, preprocess_video
    from tacreasoner.recipes.quickstart_parts import swap_in_training, train_gel_reference

    root, _ = trained_run
    paths = QuickstartPaths(root / "swap_trained")
    shutil.copytree(root / "bench", paths.bench)
    paths.encoder.mkdir(parents=True)
    plain = {"num_frames": 4, "image_size": [24, 32], "background": "keep", "orientation": "match"}
    (paths.encoder / "video_processing.json").write_text(json.dumps(plain))
    lines = swap_in_training(paths, max_clips=4)
    video = json.loads((paths.encoder / "video_processing.json").read_text())
    reference, _ = train_gel_reference(paths)  # kept from the swap stage, measured on train clips only
    mapped = VideoProcessingConfig.from_dict({**plain, "gel_reference": reference})
    train = _train_clips_of(root)
    assert video["gel_reference"] == reference and "gel_swap" not in video  # training swaps the whole rest frame
    kept = json.loads(paths.gel_image.read_text())
    assert video["gel_image"] == measure_gel_image(train[:4], mapped) == kept["image"]
    assert kept["clips"] == [c.clip_id for c in train[:4]] and kept["split"] == "train"
    swapped = VideoProcessingConfig.from_dict(video)
    assert not np.array_equal(preprocess_video(train[0], swapped), preprocess_video(train[0], mapped))
    assert "4 train clips swapped into every frame Stage I and II read" in lines[-1]
    assert swap_in_training(paths)[0].startswith("already there")  # re-run: the models keep the frames they read
    stale = QuickstartPaths(root / "trained_plain")
    shutil.copytree(paths.bench, stale.bench)
    shutil.copytree(paths.encoder, stale.encoder)
    (stale.encoder / "video_processing.json").write_text(json.dumps(plain))
    (stale.train(0) / "stage1").mkdir(parents=True)
    with pytest.raises(ValueError, match=r"seed0 trained on frames without the gel swap; move them aside"):
        swap_in_training(stale)


def test_a_swap_trained_model_answers_with_the_imprint_at_its_own_scale(trained_run, tmp_path: Path) -> None:
    from tacreasoner.model.processing import TacReasonerProcessor
    from tacreasoner.model.video_processing import VideoProcessingConfig, measure_gel_image

    root, _ = trained_run
    paths, model, config_path, config = _run_folder_with_a_model(trained_run, tmp_path)
    with pytest.raises(ValueError, match=r"trained without a gel swap \(no video.gel_image\)"):
        evaluate_and_report(paths, {0: model}, {}, gel_reference="train", gel_swap="imprint")
    reference = {k: v for k, v in json.loads(paths.gel_reference.read_text()).items() if k in ("mean", "std")}
    video = {**config["video"], "background": "keep", "gel_reference": reference}
    image = measure_gel_image(_train_clips_of(root)[:3], VideoProcessingConfig.from_dict(video))
    config["video"] = {**video, "gel_image": image}  # as the swap stage leaves the frames training reads
    config_path.write_text(json.dumps(config))
    report = evaluate_and_report(paths, {0: model}, {}, gel_reference="train", gel_swap="imprint")
    for folder in (model, paths.model):
        answered = TacReasonerProcessor.from_pretrained(folder).video_config.to_dict()
        assert answered["gel_swap"] == "imprint" and answered["gel_image"] == image
        assert answered["gel_reference"] == reference and "gel_swap_above" not in answered  # every clip swapped
    assert "its change from its own rest added at its own scale" in report.path.read_text()
    assert any(line.startswith("gel swap in training and answering") for line in report.summary_lines)
    # the train clips' imprint strength is kept beside each model: a user's sensor is calibrated from its clips alone
    from tacreasoner.model.video_processing import measure_imprint_gain, measure_imprint_reference

    train = _train_clips_of(root)
    answering = TacReasonerProcessor.from_pretrained(model).video_config
    for folder in (model, paths.model):
        kept = json.loads((folder / "sensor_reference.json").read_text())
        assert np.allclose(kept["imprint_strength"], measure_imprint_reference(train, answering), atol=1e-5)
        assert kept["clips"] == len(train) and kept["sensors"] == ["mini"] and kept["split"] == "train"
    assert any(line.startswith("another sensor's imprint strength") for line in report.summary_lines)
    from tacreasoner.recipes.quickstart_parts import record_train_sensor_reference

    assert record_train_sensor_reference(paths, [model]).startswith("already there")  # a rerun measures nothing
    from typer.testing import CliRunner

    from tacreasoner.cli import app

    digit = _train_clips_of(root, "digit")
    sim = json.loads((paths.bench / "bench.json").read_text())["data"]
    out = tmp_path / "for_digit"
    result = CliRunner().invoke(app, ["calibrate-sensor", "--model", str(paths.model), "--clips", sim, "--sensor",
                                      "digit", "--bench", str(paths.bench), "--out", str(out)])
    assert result.exit_code == 0, result.output
    gain = json.loads((out / "processor_config.json").read_text())["video"]["imprint_gain"]
    assert np.allclose(gain, measure_imprint_gain(digit, train, answering), atol=2e-4)  # DIGIT train objects only
    assert f"from {len(digit)} clips" in result.output and f"--model {out}" in result.output
    assert "imprint_gain" not in json.loads((paths.model / "processor_config.json").read_text())["video"]
    refused = CliRunner().invoke(app, ["calibrate-sensor", "--model", str(paths.model), "--clips", sim,
                                       "--out", str(tmp_path / "unsplit")])
    assert refused.exit_code == 2 and "carry no split; give --bench" in refused.output  # eval objects unread
