"""Stage I → Stage II on a tiny real setup: outputs, resume equality, accumulation equivalence, NaN guard."""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import pytest
import torch
from safetensors.torch import load_file

from tacreasoner.model.modeling import TacReasonerForCausalLM
from tacreasoner.train.trainer import NonFiniteLossError, train_stage
from tests.train.trainsetup import ENCODER, tiny_config, training_inputs


@pytest.fixture(scope="module")
def inputs(small_sim_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return training_inputs(small_sim_dataset, tmp_path_factory)


@pytest.fixture(scope="module")
def two_stage_run(inputs, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("two_stage")
    config = tiny_config(inputs, out, runtime={"log_with": "tensorboard"})
    train_stage(config, 1)
    train_stage(config, 2)
    return out


def _adapter_weights(run: Path) -> dict[str, torch.Tensor]:
    return load_file(str(run / "stage2" / "adapter" / "adapter_model.safetensors"))


def test_two_stages_write_models_adapter_logs_and_run_reports(two_stage_run: Path) -> None:
    for stage in (1, 2):
        root = two_stage_run / f"stage{stage}"
        assert (root / "model" / "config.json").is_file() and (root / "model" / "processor_config.json").is_file()
        # the benchmark's vocabulary is recorded, so ask/serve/demo read clips in the model's own level words
        from tacreasoner.serve.stepwise import model_vocabulary

        assert model_vocabulary(root / "model") == "vtv150k"
        log = [json.loads(line) for line in (root / "train_log.jsonl").read_text().splitlines()]
        assert [r["step"] for r in log] == [1, 2, 3]
        assert all(r["loss"] > 0 and r["tokens_per_s"] > 0 for r in log)
        run = json.loads((root / "run.json").read_text())
        assert run["steps_done"] == 3 and run["examples"] > 0 and run["trainable_parameters"] > 0
        assert list((root / "logs").rglob("events.out.tfevents*")), "TensorBoard event file missing"
    assert (two_stage_run / "stage2" / "adapter" / "adapter_config.json").is_file()
    names = set(_adapter_weights(two_stage_run))
    assert any("lora_A" in n for n in names) and any("projector" in n for n in names)
    stage1 = json.loads((two_stage_run / "stage1" / "run.json").read_text())
    stage2 = json.loads((two_stage_run / "stage2" / "run.json").read_text())
    # Stage I trains the temporal branch etc. with the LLM frozen; Stage II only LoRA + projector
    assert stage1["trainable_parameters"] != stage2["trainable_parameters"]


def test_the_stage_two_adapter_on_the_stage_one_model_answers_as_the_merged_model(inputs, tmp_path) -> None:
    """The adapter folder is complete: LoRA + projector (PEFT's file) and, beside it, the new tokens' rows, which
    Stage II trains too: on an LLM that lacks the project's tokens, the Stage I model plus the adapter answers as the
    merged Stage II model, and not as it would without the rows."""
    from tacreasoner.evaluate.predict import load_trained
    from tests.train.trainsetup import llm_with_new_rows, training_prompt_logits

    llm = llm_with_new_rows(inputs, tmp_path / "llm", untie=False)
    config = tiny_config(inputs, tmp_path / "run", model={"llm": str(llm)}, stage1={"steps": 2},
                         stage2={"steps": 3, "lr": 3e-2, "projector_lr": 3e-2}, lora={"r": 4, "alpha": 8},
                         runtime={"log_with": "none", "progress": False, "mixed_precision": "no"})
    train_stage(config, 1)
    train_stage(config, 2)
    run = tmp_path / "run"
    adapter = run / "stage2" / "adapter"
    merged, processor = load_trained(run / "stage2" / "model", device="cpu")
    on_top, _ = load_trained(run / "stage1" / "model", adapter, device="cpu")
    assert merged.config.new_token_ids and (adapter / "token_rows.safetensors").is_file()
    expected = training_prompt_logits(merged, processor, inputs)
    torch.testing.assert_close(training_prompt_logits(on_top, processor, inputs), expected, rtol=1e-4, atol=1e-4)
    (adapter / "token_rows.safetensors").unlink()
    without_rows, _ = load_trained(run / "stage1" / "model", adapter, device="cpu")
    assert not torch.allclose(training_prompt_logits(without_rows, processor, inputs), expected, atol=1e-4)


def test_stage_two_changes_what_stage_one_produced(two_stage_run: Path) -> None:
    from tacreasoner.model.build import load_model

    one, _ = load_model(two_stage_run / "stage1" / "model")
    two, _ = load_model(two_stage_run / "stage2" / "model")
    q1 = one.language_model.model.layers[0].self_attn.q_proj.weight
    q2 = two.language_model.model.layers[0].self_attn.q_proj.weight
    assert not torch.equal(q1, q2), "the merged LoRA should have changed q_proj"
    t1, t2 = one.tactile_encoder.temporal.state_dict(), two.tactile_encoder.temporal.state_dict()
    assert all(torch.equal(t1[k], t2[k]) for k in t1), "Stage II must not touch the temporal branch"


def test_killed_run_resumes_to_the_uninterrupted_result(inputs, tmp_path) -> None:
    def run(out: Path, stop_after: int | None = None) -> None:
        config = tiny_config(inputs, out, stage1={"skip": True}, stage2={"steps": 5},
                             lora={"r": 8, "alpha": 16, "dropout": 0.1})
        train_stage(config, 2, stop_after=stop_after)

    run(tmp_path / "straight")
    run(tmp_path / "killed", stop_after=3)  # checkpoint at step 2, then "killed" during step 3
    assert not (tmp_path / "killed" / "stage2" / "adapter").exists()
    with pytest.raises(ValueError, match="resume"):
        run(tmp_path / "killed")
    config = tiny_config(inputs, tmp_path / "killed", stage1={"skip": True}, stage2={"steps": 5},
                         lora={"r": 8, "alpha": 16, "dropout": 0.1})
    result = train_stage(config, 2, resume=True)
    assert result.resumed_from == 2
    a, b = _adapter_weights(tmp_path / "straight"), _adapter_weights(tmp_path / "killed")
    assert a.keys() == b.keys()
    for name in a:
        torch.testing.assert_close(a[name], b[name], rtol=0, atol=1e-6, msg=name)
    log = [json.loads(line)["step"] for line in (tmp_path / "killed" / "stage2" / "train_log.jsonl").read_text()
           .splitlines()]
    assert log == [1, 2, 3, 4, 5], "the log must not repeat the redone steps"


def test_gradient_accumulation_matches_a_larger_batch(inputs, tmp_path) -> None:
    common = {"stage1": {"skip": True}}
    big = tiny_config(inputs, tmp_path / "big", stage2={"steps": 2, "batch_size": 4, "grad_accum": 1}, **common)
    acc = tiny_config(inputs, tmp_path / "acc", stage2={"steps": 2, "batch_size": 2, "grad_accum": 2}, **common)
    train_stage(big, 2)
    train_stage(acc, 2)
    a, b = _adapter_weights(tmp_path / "big"), _adapter_weights(tmp_path / "acc")
    for name in a:
        torch.testing.assert_close(a[name], b[name], rtol=1e-4, atol=1e-5, msg=name)


def test_packed_rows_train_to_the_same_weights_as_padded_batches(inputs, tmp_path) -> None:
    common = {"stage1": {"skip": True}, "stage2": {"steps": 2, "batch_size": 4}}
    padded = tiny_config(inputs, tmp_path / "padded", runtime={"pack_sequences": False}, **common)
    packed = tiny_config(inputs, tmp_path / "packed", **common)  # the default on the CPU
    train_stage(padded, 2)
    train_stage(packed, 2)
    runs = [json.loads((tmp_path / name / "stage2" / "run.json").read_text()) for name in ("padded", "packed")]
    assert [run["packed"] for run in runs] == [False, True]
    a, b = _adapter_weights(tmp_path / "padded"), _adapter_weights(tmp_path / "packed")
    for name in a:
        torch.testing.assert_close(a[name], b[name], rtol=1e-4, atol=1e-5, msg=name)


def test_activation_checkpointing_trains_to_the_same_weights_without_deprecation_warnings(inputs, tmp_path) -> None:
    common = {"stage1": {"skip": True}, "stage2": {"steps": 2}}
    plain = tiny_config(inputs, tmp_path / "plain", **common)
    checkpointed = tiny_config(inputs, tmp_path / "ckpt", model={"gradient_checkpointing": True}, **common)
    train_stage(plain, 2)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        train_stage(checkpointed, 2)
    assert not [str(w.message) for w in caught if "checkpointing" in str(w.message) and "deprecated" in str(w.message)]
    a, b = _adapter_weights(tmp_path / "plain"), _adapter_weights(tmp_path / "ckpt")
    for name in a:
        torch.testing.assert_close(a[name], b[name], rtol=1e-4, atol=1e-5, msg=name)


def test_non_finite_loss_stops_naming_the_step_and_examples(inputs, tmp_path) -> None:
    config = tiny_config(inputs, tmp_path, stage1={"steps": 4})

    def poison(step: int, micro: int, loss: torch.Tensor) -> torch.Tensor:
        return loss * float("nan") if step == 2 else loss

    with pytest.raises(NonFiniteLossError,
                       match=r"not finite at step 3 \(micro-batch 1 of 1\) on process\(es\) \[0\]; here nan on "
                             r"examples \['"):
        train_stage(config, 1, loss_hook=poison)
    assert not (tmp_path / "stage1" / "model").exists()


def test_a_bf16_llm_trains_fp32_master_weights_under_autocast(inputs, tmp_path) -> None:
    """The frozen LLM stays bf16; every trained tensor (temporal branch, fusion, projector, new token rows, LoRA)
    is fp32 in the checkpoints, both stages train, and the saved model loads."""
    from tacreasoner.model.build import load_model

    config = tiny_config(inputs, tmp_path, model={"dtype": "bfloat16"}, stage1={"steps": 2}, stage2={"steps": 2},
                         runtime={"mixed_precision": "bf16"})
    for stage in (1, 2):
        train_stage(config, stage)
        checkpoint = sorted((tmp_path / f"stage{stage}" / "checkpoints").glob("step-*"))[-1]
        weights = load_file(str(checkpoint / "model.safetensors"))
        assert weights and {str(w.dtype) for w in weights.values()} == {"torch.float32"}, stage
    model, _ = load_model(tmp_path / "stage2" / "model")
    assert model.language_model.model.layers[0].self_attn.q_proj.weight.dtype == torch.bfloat16


def test_a_small_update_survives_in_fp32_master_weights_and_not_in_bf16() -> None:
    from tacreasoner.train.trainer import master_weights_in_fp32

    frozen, trained = torch.nn.Linear(4, 4).to(torch.bfloat16), torch.nn.Linear(4, 4).to(torch.bfloat16)
    frozen.requires_grad_(False)
    module = torch.nn.Sequential(frozen, trained)
    with torch.no_grad():
        trained.weight.fill_(1.0)
        stepped = trained.weight + 1e-4  # the size of an Adam step at lr 1e-4 on a weight of 1
    assert torch.equal(stepped, trained.weight), "bf16 keeps such a step (the premise no longer holds)"
    assert master_weights_in_fp32(module, "bf16") == 20
    assert trained.weight.dtype == torch.float32 and frozen.weight.dtype == torch.bfloat16
    with torch.no_grad():
        assert not torch.equal(trained.weight + 1e-4, trained.weight)
    with pytest.raises(ValueError, match=r"runtime\.mixed_precision: bf16"):
        master_weights_in_fp32(torch.nn.Linear(2, 2).to(torch.bfloat16), "no")


def test_stage_two_without_stage_one_output_is_refused_before_loading(inputs, tmp_path) -> None:
    config = tiny_config(inputs, tmp_path)
    with pytest.raises(FileNotFoundError, match="no Stage I model"):
        train_stage(config, 2)


def test_sigkilled_cli_run_resumes_to_the_uninterrupted_result(inputs, tmp_path) -> None:
    """A real `kill -9` of `tacreasoner train` mid-run, then `--resume`: the same adapter as a straight run."""
    import os
    import signal
    import subprocess
    import sys
    import time

    import yaml

    def config_file(out: Path) -> Path:
        config = tiny_config(inputs, out, stage1={"skip": True}, stage2={"steps": 8},
                             runtime={"checkpoint_every": 1, "keep_checkpoints": 8})
        path = out.with_suffix(".yaml")
        path.write_text(yaml.safe_dump(config.to_dict()))
        return path

    def train(path: Path, *extra: str) -> subprocess.Popen:
        return subprocess.Popen([sys.executable, "-m", "tacreasoner", "train", "--stage", "2", "--config",
                                 str(path), *extra], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                env={**os.environ, "OMP_NUM_THREADS": "1"})

    straight = train(config_file(tmp_path / "straight"))
    killed_cfg = config_file(tmp_path / "killed")
    victim = train(killed_cfg)
    ckpts = tmp_path / "killed" / "stage2" / "checkpoints"
    deadline = time.monotonic() + 240
    while not (ckpts.is_dir() and any(p.name == "step-00000003" for p in ckpts.iterdir())):
        assert victim.poll() is None, victim.stdout.read().decode()[-2000:]
        assert time.monotonic() < deadline, "no checkpoint appeared"
        time.sleep(0.05)
    victim.send_signal(signal.SIGKILL)
    victim.wait()
    assert not (tmp_path / "killed" / "stage2" / "adapter").exists(), "killed before the end"
    resumed = train(killed_cfg, "--resume")
    for proc in (straight, resumed):
        out = proc.communicate(timeout=300)[0].decode()
        assert proc.returncode == 0, out[-2000:]
    a, b = _adapter_weights(tmp_path / "straight"), _adapter_weights(tmp_path / "killed")
    for name in a:
        torch.testing.assert_close(a[name], b[name], rtol=0, atol=1e-6, msg=name)


def test_deepspeed_gets_the_micro_batch_and_refuses_accumulation_and_zero3() -> None:
    from types import SimpleNamespace

    from tacreasoner.train.config import StageSettings
    from tacreasoner.train.trainer import _configure_deepspeed

    plugin = SimpleNamespace(deepspeed_config={"train_micro_batch_size_per_gpu": "auto"})
    accelerator = SimpleNamespace(state=SimpleNamespace(deepspeed_plugin=plugin))
    settings = StageSettings(global_batch=12)
    _configure_deepspeed(accelerator, settings, settings.micro_batch("stage2", 2))  # 12 examples over 2 GPUs
    assert plugin.deepspeed_config == {"train_micro_batch_size_per_gpu": 6, "gradient_accumulation_steps": 1,
                                       "gradient_clipping": settings.max_grad_norm}
    with pytest.raises(ValueError, match="grad_accum: 1"):
        _configure_deepspeed(accelerator, StageSettings(batch_size=6, grad_accum=2), 6)
    _configure_deepspeed(SimpleNamespace(state=SimpleNamespace()), StageSettings(grad_accum=4), 8)  # no DeepSpeed
    zero3 = SimpleNamespace(state=SimpleNamespace(deepspeed_plugin=SimpleNamespace(zero_stage=3, deepspeed_config={})))
    with pytest.raises(ValueError, match="ZeRO-3 is not supported"):
        _configure_deepspeed(zero3, settings, 6)


def test_evaluate_and_ask_commands_on_a_trained_model(two_stage_run: Path, inputs, tmp_path) -> None:
    from typer.testing import CliRunner

    from tacreasoner.cli import app
    from tacreasoner.tasks.bench import load_bench

    model = two_stage_run / "stage2" / "model"
    runner = CliRunner()
    result = runner.invoke(app, ["evaluate", "--model", str(model), "--bench", str(inputs["bench"]), "--out",
                                 str(tmp_path / "eval"), "--limit", "6", "--max-new-tokens", "16"])
    assert result.exit_code == 0, result.output
    preds = (tmp_path / "eval" / "predictions" / "val.jsonl").read_text().splitlines()  # val unless asked
    assert len(preds) == 6 and all("prediction" in json.loads(p) for p in preds)
    assert (tmp_path / "eval" / "report.md").is_file() and "Average" in result.output
    assert f"scored split: val of {inputs['bench']}" in " ".join(result.output.split())

    info, items = load_bench(inputs["bench"], "test")
    video = Path(info["video_root"]) / items[0].videos[0].path
    result = runner.invoke(app, ["ask", "Is <tactile> soft?", "--video", str(video), "--model", str(model),
                                 "--max-new-tokens", "8"])
    assert result.exit_code == 0, result.output
    assert "think:" in result.output and "answer:" in result.output
    result = runner.invoke(app, ["ask", "Is <tactile> soft?", "--video", str(tmp_path / "missing.mp4"), "--model",
                                 str(model)])
    assert result.exit_code == 2 and "missing.mp4: no such file" in result.output
    result = runner.invoke(app, ["ask", "Compare <tactile> and <tactile>", "--video", str(video), "--model",
                                 str(model)])
    assert result.exit_code == 2 and "2 <tactile> placeholder(s) but 1 video(s)" in result.output


def test_stage_two_fits_the_comparator_first_and_keeps_it_frozen(inputs, tmp_path, request) -> None:
    from tacreasoner.model.build import load_model
    from tests.train.trainsetup import ENCODER, fewer_comparator_fit_steps

    request.addfinalizer(fewer_comparator_fit_steps())  # where and when it is fitted, not how well: fewer steps

    def run(out: Path, steps: int) -> tuple[dict, TacReasonerForCausalLM]:
        config = tiny_config(inputs, out, stage1={"skip": True}, stage2={"steps": steps},
                             model={"encoder": {**ENCODER, "cross_video": 3}})
        train_stage(config, 2)
        return json.loads((out / "stage2" / "run.json").read_text()), load_model(out / "stage2" / "model")[0]

    info, model = run(tmp_path / "three", 3)
    fitted = info["comparator"]
    assert fitted["comparisons"] > 0 and 0.0 <= fitted["pick"] <= 1.0
    assert fitted["attribute"] > 0.9  # the attribute is plain in the question
    # Stage II's prompts carry out-of-fold verdicts: one copy per distinct set of the 5 object folds a prompt
    # touches (a comparison spans several), each fitted without those folds' objects
    sets = [tuple(f["folds"]) for f in fitted["folds"]]
    assert len(sets) == len(set(sets)) >= 5 and all(set(s) <= set(range(5)) for s in sets)
    assert any(len(s) > 1 for s in sets) and 0.0 <= fitted["held_out_agreement"] <= 1.0
    assert all(f["fitted_on"] < info["examples"] for f in fitted["folds"])
    # and the name matcher on the OSC items (three videos, three listed names)
    named = info["name_matcher"]
    assert named["named"] > 0 and 0.0 <= named["assigned"] <= 1.0 and "held_out_agreement" in named
    fusion = model.projector.cross_video
    assert bool(fusion.directions.abs().sum() > 0) and bool((fusion.feature_mean != 0).any())
    assert fusion.names_fitted.tolist() == [False, False, False, True]
    _, shorter = run(tmp_path / "one", 1)
    other = shorter.projector.cross_video
    # fitted the same way (seeded, fixed features) and untouched by Stage II's steps, which do train the rest
    for name in ("directions", "feature_mean", "feature_var", "attribute.1.weight", "comparative.1.weight",
                 "names.weight", "name_mean"):
        buffer = name in ("feature_mean", "feature_var", "name_mean")
        assert torch.equal(fusion.get_buffer(name) if buffer else fusion.get_parameter(name),
                           other.get_buffer(name) if buffer else other.get_parameter(name)), name
    assert not torch.equal(model.projector.linear_1.weight, shorter.projector.linear_1.weight)


def test_stage_two_fits_the_clip_reader_on_train_gold_even_on_a_stage_one_model_without_one(
        inputs, two_stage_run, tmp_path) -> None:
    import shutil

    from tacreasoner.model.build import load_model
    from tacreasoner.train.head_settings import READER_TRAITS
    from tests.train.trainsetup import ENCODER

    out = tmp_path / "reader"
    shutil.copytree(two_stage_run / "stage1", out / "stage1", ignore=shutil.ignore_patterns("checkpoint-*"))
    assert load_model(out / "stage1" / "model")[0].projector.clip_reader is None  # Stage I was built without it
    config = tiny_config(inputs, out, model={"encoder": {**ENCODER, "clip_reader": True}})
    train_stage(config, 2)
    fitted = json.loads((out / "stage2" / "run.json").read_text())["clip_reader"]
    assert fitted["videos"] > 0 and "hardness" in fitted
    assert all(0.0 <= fitted[t]["read"] <= 1.0 and fitted[t]["videos"] > 0 for t in READER_TRAITS if t in fitted)
    model, _ = load_model(out / "stage2" / "model")
    reader = model.projector.clip_reader
    assert model.encoder_config.clip_reader and reader is not None and reader.fitted
    assert bool(reader.readout_weight.abs().sum() > 0) and bool(reader.readings.abs().sum() > 0)


def test_extra_benches_join_the_training_examples_in_the_same_vocabulary(inputs, small_sim_dataset, tmp_path) -> None:
    from tacreasoner.tasks.bench import build_bench
    from tacreasoner.train.data import load_examples

    extra = tmp_path / "extra"
    build_bench("sim", small_sim_dataset, extra, seed=1, heldout_sensor="digit")
    config = tiny_config(inputs, tmp_path / "run", stage1={"steps": 1},
                         data={"stage2_data": "plain", "extra_benches": [str(extra)]})
    train_stage(config, 1)
    run = json.loads((tmp_path / "run" / "stage1" / "run.json").read_text())
    assert run["examples"] == len(load_examples(1, inputs["bench"])) + len(load_examples(1, extra))

    other = tmp_path / "other_words"
    build_bench("sim", small_sim_dataset, other, seed=1, heldout_sensor="digit", vocabulary="physiclear")
    config = tiny_config(inputs, tmp_path / "run2", data={"stage2_data": "plain", "extra_benches": [str(other)]})
    with pytest.raises(ValueError, match=r"other_words answers in the physiclear vocabulary, data.bench in vtv150k"):
        train_stage(config, 1)
    config = tiny_config(inputs, tmp_path / "run3", data={"stage2_data": "plain", "extra_benches": ["nowhere"]})
    with pytest.raises(FileNotFoundError, match=r"data\.extra_benches: nowhere is not a benchmark directory"):
        train_stage(config, 1)


def test_standardized_appearance_is_measured_on_the_training_clips_and_kept(inputs, tmp_path) -> None:
    """encoder.standardize_appearance: Stage I measures each channel's mean and spread over the training clips'
    appearance tokens before its first step, and the saved model carries them into Stage II and inference."""
    from tacreasoner.model.build import load_model
    from tacreasoner.train.data import VideoBank, load_examples

    encoder = {**tiny_config(inputs, tmp_path).model.encoder, "standardize_appearance": True}
    config = tiny_config(inputs, tmp_path / "run", stage1={"steps": 1}, stage2={"steps": 1},
                         data={"stage2_data": "plain"}, model={"encoder": encoder})
    train_stage(config, 1)
    model, processor = load_model(tmp_path / "run" / "stage1" / "model")
    tactile = model.tactile_encoder
    assert tactile.appearance_measured
    bank = VideoBank(processor.video_config, processor.sensor_types)
    bank.build(list(dict.fromkeys(k for e in load_examples(1, inputs["bench"]) for k in e.videos)))
    tokens = bank.appearance_tokens(tactile)  # standardised with the saved statistics
    flat = tokens.reshape(-1, tokens.shape[-1]).double()
    torch.testing.assert_close(flat.mean(0), torch.zeros(flat.shape[1], dtype=torch.float64), atol=1e-4, rtol=0)
    torch.testing.assert_close(flat.std(0), torch.ones(flat.shape[1], dtype=torch.float64), atol=1e-3, rtol=0)
    train_stage(config, 2)
    merged, _ = load_model(tmp_path / "run" / "stage2" / "model")
    assert torch.equal(merged.tactile_encoder.appearance_mean, tactile.appearance_mean)
    # off (the default), the tokens pass as they are
    plain = tiny_config(inputs, tmp_path / "plain", stage1={"steps": 1}, data={"stage2_data": "plain"})
    train_stage(plain, 1)
    assert not load_model(tmp_path / "plain" / "stage1" / "model")[0].tactile_encoder.appearance_measured


def test_a_max_length_that_leaves_out_a_whole_task_stops_the_run_and_a_partial_loss_is_counted(
        inputs, tmp_path, capfd) -> None:
    """Long TouchCoT targets at a plain-answer recipe's max_length once dropped every OSC example silently."""
    from tacreasoner.model.build import build_model
    from tacreasoner.train.data import load_examples, tokenize_examples

    tasks = ["TFA-hardness", "TFA-combined"]
    _, processor = build_model(str(inputs["llm"]), encoder=dict(ENCODER))
    tokenized, _ = tokenize_examples(processor, load_examples(1, inputs["bench"], tasks=tasks), 10**6)
    lengths = {task: [len(t.input_ids) for t in tokenized if t.task == task] for task in tasks}
    cut = min(lengths["TFA-combined"])  # combined asks for four attributes: its replies are the longer ones
    assert min(lengths["TFA-hardness"]) < cut
    config = tiny_config(inputs, tmp_path / "lost", data={"tasks": tasks, "max_length": cut - 1})
    with pytest.raises(ValueError, match="leaves out every example of TFA-combined"):
        train_stage(config, 1)
    over = {task: sum(n > cut for n in lengths[task]) for task in tasks}
    assert over["TFA-combined"] > 0
    partial = tiny_config(inputs, tmp_path / "partial", stage1={"steps": 1}, data={"tasks": tasks, "max_length": cut})
    train_stage(partial, 1)
    run = json.loads((tmp_path / "partial" / "stage1" / "run.json").read_text(encoding="utf-8"))
    assert run["dropped_too_long"] == sum(over.values())
    assert run["dropped_by_task"] == {task: n for task, n in sorted(over.items()) if n}
    assert f"longer than data.max_length={cut} and left out (TFA-combined {over['TFA-combined']}" in \
        capfd.readouterr().err


def test_stage2_trains_on_compact_reasoning_beside_text_only_object_knowledge(inputs, tmp_path) -> None:
    """data.stage2_data: compact with data.knowledge: all: the reasoned items' targets describe each video, the
    text-only knowledge examples (no video) join them whatever data.tasks says, Stage II trains on both, and a batch
    made only of text-only examples gives a finite loss with gradients."""
    from tacreasoner.model.build import build_model
    from tacreasoner.train.data import VideoBank, collate, load_examples, tokenize_examples

    examples = load_examples(2, inputs["bench"], stage2_data="compact", knowledge="all", tasks=["SOI"])
    knowledge = [e for e in examples if e.task == "knowledge"]
    assert knowledge and all(e.videos == () and "<tactile>" not in e.question for e in knowledge)
    assert {e.task for e in examples} == {"SOI", "knowledge"}
    assert all(e.target.startswith("<think>Video 1: ") for e in examples if e.task == "SOI")
    config = tiny_config(inputs, tmp_path / "run", stage1={"skip": True}, stage2={"steps": 2, "batch_size": 4},
                         data={"stage2_data": "compact", "knowledge": "all", "tasks": ["SOI"]})
    train_stage(config, 2)
    run = json.loads((tmp_path / "run" / "stage2" / "run.json").read_text())
    assert run["examples"] == len(examples)
    losses = [json.loads(line)["loss"] for line in (tmp_path / "run" / "stage2" / "train_log.jsonl").open()]
    assert losses and all(math.isfinite(v) for v in losses)

    model, processor = build_model(str(inputs["llm"]), encoder=dict(ENCODER))
    tokenized, _ = tokenize_examples(processor, knowledge[:3], 1024)
    bank = VideoBank(processor.video_config, processor.sensor_types)
    bank.build(list(examples[0].videos))  # training builds the bank over every example; this batch has no video
    batch = collate(processor, tokenized, bank, None)
    assert batch["pixel_values"].shape[0] == 0
    loss = model.train()(**batch).loss
    loss.backward()
    assert math.isfinite(float(loss.detach()))
    assert any(p.grad is not None for p in model.parameters() if p.requires_grad)
