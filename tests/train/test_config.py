"""The training config (``train.config``): a strict schema whose errors name ``file:line`` and the key,
dotted overrides, the shipped configs, the ``train`` command's argument errors (no model is loaded),
and the Accelerate launch configs under configs/accelerate/."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from tacreasoner.train.config import TrainConfig, apply_override, load_train_config

CONFIGS = Path(__file__).resolve().parents[2] / "configs"


def config_file(name: str) -> Path:
    """A repository config under configs/, or one shipped inside the package (the PhysiCLeAR recipe's)."""
    from tacreasoner.train.config import shipped_config

    return shipped_config(name) or CONFIGS / f"{name}.yaml"
runner = CliRunner()


def write(tmp_path: Path, text: str, name: str = "train.yaml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def error_of(path: Path, overrides: dict | None = None) -> tuple[int, str]:
    """(line, message) of the ValueError that loading ``path`` raises; the message must start ``path:LINE:``."""
    with pytest.raises(ValueError) as info:
        load_train_config(path, overrides)
    message = str(info.value)
    match = re.match(rf"{re.escape(str(path))}:(\d+): ", message)
    assert match, f"the error does not start with {path}:LINE: {message}"
    return int(match.group(1)), message


# ------------------------------------------------------------------------------------------ unknown keys


def test_an_unknown_top_level_key_is_an_error_naming_file_line_and_key(tmp_path: Path) -> None:
    path = write(tmp_path, "seed: 0\nmodle:\n  llm: x\n")
    _, message = error_of(path)
    assert "'modle'" in message and "known: output_dir, seed, model" in message


@pytest.mark.parametrize(("text", "key", "lines"), [
    ("seed: 0\nstage2:\n  steps: 5\n  lerning_rate: 1.0e-4\n", "lerning_rate", (2, 4)),
    ("seed: 0\nruntime:\n  log_wiht: none\n", "log_wiht", (2, 3)),
    ("seed: 0\ndata:\n  bench: b\n  task: [SFD]\n", "task", (2, 4)),
    ("seed: 0\nlora:\n  rank: 8\n", "rank", (2, 3)),
    ("seed: 0\nmodel:\n  encoder:\n    use_temporl: false\n", "use_temporl", (2, 3, 4)),
])
def test_an_unknown_section_key_is_an_error_naming_file_line_and_key(tmp_path, text, key, lines) -> None:
    line, message = error_of(write(tmp_path, text))
    assert f"'{key}'" in message and "known:" in message
    assert line in lines, f"line {line} is neither the section's nor the key's: {message}"


@pytest.mark.parametrize(("text", "line"), [
    ("seed: 0\n\nmodle:\n  llm: x\n", 3),
    ("seed: 0\nstage2:\n  steps: 5\n  lerning_rate: 1.0e-4\n", 4),
])
def test_an_unknown_key_error_points_at_the_key_itself(tmp_path, text, line) -> None:
    assert error_of(write(tmp_path, text))[0] == line


# ------------------------------------------------------------------------------------------ bad values


@pytest.mark.parametrize(("text", "needles"), [
    ("seed: 0\nstage1:\n  steps: -1\n", ["stage1.steps", "at least 1", "-1"]),
    ("seed: 0\nstage2:\n  batch_size: 0\n", ["stage2.batch_size", "at least 1"]),
    ("seed: 0\nstage2:\n  grad_accum: 0\n", ["stage2.grad_accum"]),
    ("seed: 0\nstage2:\n  lr: 0\n", ["stage2.lr", "positive"]),
    ("seed: 0\nstage2:\n  lr: 1e-4\n", ["stage2.lr", "'1e-4'"]),  # YAML 1.1: a string, not a float (1.0e-4 is)
    ("seed: 0\nstage1:\n  projector_lr: -1.0\n", ["stage1.projector_lr", "positive"]),
    ("seed: 0\nstage2:\n  warmup_ratio: 1.5\n", ["stage2.warmup_ratio", "[0, 1)", "1.5"]),
    ("seed: 0\nstage2:\n  min_lr_ratio: 2.0\n", ["stage2.min_lr_ratio"]),
    ("seed: 0\ndata:\n  stage2_data: cot\n", ["data.stage2_data", "'cot'", "touchcot, plain"]),
    ("seed: 0\ndata:\n  tasks: [SFD, TSA]\n", ["data.tasks", "TSA", "never trained on"]),
    ("seed: 0\ndata:\n  tasks: [SFD, XYZ]\n", ["data.tasks", "'XYZ'", "known:"]),
    ("seed: 0\ndata:\n  max_length: 8\n", ["data.max_length", "16"]),
    ("seed: 0\ndata:\n  repeat:\n    XYZ: 2\n", ["data.repeat", "'XYZ'", "known:"]),
    ("seed: 0\ndata:\n  repeat:\n    OSC: 0\n", ["data.repeat.OSC", "≥ 1", "0"]),
    ("seed: 0\ndata:\n  repeat:\n    OSC: 2.5\n", ["data.repeat.OSC", "2.5"]),
    ("seed: 0\ndata:\n  repeat: [OSC]\n", ["data.repeat", "mapping"]),
    ("seed: 0\ndata:\n  length_group_batches: 0\n", ["data.length_group_batches", "at least 1"]),
    ("seed: 0\ndata:\n  stage2_data: touchcot\n  extra_benches: [b]\n",
     ["data.extra_benches", "plain or compact answers only"]),
    ("seed: 0\ndata:\n  extra_benches: b\n", ["data.extra_benches", "list of strings", "'b'"]),
    ("seed: 0\ndata:\n  stage2_data: plain\n  extra_benches: [b]\nmodel:\n  encoder:\n    cross_video: 3\n",
     ["data.extra_benches", "read-out heads"]),
    ("seed: 0\nruntime:\n  mixed_precision: fp8\n", ["runtime.mixed_precision", "'fp8'", "bf16"]),
    ("seed: 0\nruntime:\n  log_with: wandb\n", ["runtime.log_with", "'wandb'", "tensorboard"]),
    ("seed: 0\nruntime:\n  checkpoint_every: 0\n", ["runtime.checkpoint_every"]),
    ("seed: 0\nruntime:\n  threads: 0\n", ["runtime.threads"]),
    ("seed: 0\nmodel:\n  dtype: fp32\n", ["model.dtype", "'fp32'", "bfloat16"]),
    ("seed: 0\nmodel:\n  encoder:\n    tokens_per_video: 0\n", ["model.encoder", "tokens_per_video"]),
    ("seed: 0\nlora:\n  r: 0\n", ["lora", "r must be"]),
    ("seed: 0\nlora:\n  dropout: 1.0\n", ["lora", "dropout"]),
    ("seed: 0\nstage1: [1, 2]\n", ["stage1 must be a mapping", "list"]),
    ("seed: abc\n", ["seed must be an integer", "'abc'"]),
])
def test_bad_values_are_errors_naming_file_line_and_key(tmp_path, text, needles) -> None:
    line, message = error_of(write(tmp_path, text))
    for needle in needles:
        assert needle in message, f"{needle!r} missing from: {message}"
    assert line <= text.count("\n"), message


@pytest.mark.parametrize(("text", "needles"), [
    ("stage2:\n  warmup_ratio: x\n", ["stage2.warmup_ratio", "'x'"]),   # TypeError ('<=' between int and str)
    ("data:\n  max_length: long\n", ["data.max_length", "'long'"]),     # TypeError
    ("runtime:\n  log_every: often\n", ["runtime.log_every"]),          # TypeError
    ("stage2:\n  steps: ten\n", ["stage2.steps", "'ten'"]),             # "invalid literal for int()": no key
    ("stage2:\n  steps: 2.5\n", ["stage2.steps", "2.5"]),               # accepted; range() fails in training
    ("data:\n  tasks: SFD\n", ["data.tasks", "'SFD'"]),                 # a string: checked letter by letter
    ("model:\n  gradient_checkpointing: maybe\n", ["model.gradient_checkpointing"]),  # accepted as true
])
def test_values_of_the_wrong_type_are_errors_naming_the_key(tmp_path, text, needles) -> None:
    _, message = error_of(write(tmp_path, text))
    for needle in needles:
        assert needle in message, message


def test_mixed_precision_no_is_accepted_unquoted(tmp_path: Path) -> None:
    assert load_train_config(write(tmp_path, "runtime:\n  mixed_precision: no\n")).runtime.mixed_precision == "no"
    # what `--set runtime.mixed_precision=no` hands over (values are parsed as YAML scalars)
    config = load_train_config(config_file("quickstart-smollm2-cpu"), {"runtime.mixed_precision": False})
    assert config.runtime.mixed_precision == "no"


def test_a_file_that_is_not_a_config_is_refused(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="no such training config"):
        load_train_config(tmp_path / "missing.yaml")
    with pytest.raises(ValueError, match="must be a mapping of sections, got list"):
        load_train_config(write(tmp_path, "- stage1\n- stage2\n"))
    line, message = error_of(write(tmp_path, "seed: 0\nstage1:\n  steps: [1\n"))
    assert "invalid YAML" in message and line >= 3


# ------------------------------------------------------------------------------------------ overrides


def test_overrides_replace_values_and_create_sections(tmp_path: Path) -> None:
    base = load_train_config(config_file("quickstart-smollm2-cpu"))
    config = load_train_config(config_file("quickstart-smollm2-cpu"), {"stage2.steps": 7, "runtime.threads": 1,
                                                            "output_dir": str(tmp_path), "lora.r": 16})
    assert (config.stage2.steps, config.runtime.threads, config.output_dir, config.lora.r) == (7, 1, str(tmp_path),
                                                                                              16)
    assert config.stage2.batch_size == base.stage2.batch_size and config.stage1 == base.stage1
    assert config.lora.alpha == base.lora.alpha  # the rest of a section is kept
    minimal = load_train_config(write(tmp_path, "seed: 3\n"), {"stage1.skip": True, "data.tasks": ["SFD"]})
    assert minimal.seed == 3 and minimal.stage1.skip and minimal.data.tasks == ["SFD"]


def test_bad_overrides_are_refused_naming_the_key(tmp_path: Path) -> None:
    _, message = error_of(config_file("quickstart-smollm2-cpu"), {"stage1.steps": -1})
    assert "stage1.steps must be at least 1, got -1" in message
    _, message = error_of(config_file("quickstart-smollm2-cpu"), {"stage2.stepz": 1})
    assert "'stepz'" in message
    with pytest.raises(ValueError, match="seed is not a section"):
        load_train_config(config_file("quickstart-smollm2-cpu"), {"seed.value": 1})
    data = {"stage2": {"steps": 1}}
    apply_override(data, "stage2.lr", 0.5)
    apply_override(data, "runtime.log_with", "none")
    assert data == {"stage2": {"steps": 1, "lr": 0.5}, "runtime": {"log_with": "none"}}


# ------------------------------------------------------------------------------------------ shipped configs


def test_every_shipped_config_is_tested() -> None:
    tested = {"quickstart-smollm2-cpu", "qwen2.5-7b", "qwen2.5-14b", "smollm2-135m", "smollm2-135m-touchcot",
              "smollm2-135m-cpu", "smollm2-135m-heads-cpu", "physiclear-smollm2-cpu"}
    from tacreasoner.train.config import SHIPPED_CONFIGS

    training = {p.stem for p in CONFIGS.glob("*.yaml") if not p.stem.startswith("teacher-")} | set(SHIPPED_CONFIGS)
    assert training == tested


@pytest.mark.parametrize("name", ["quickstart-smollm2-cpu", "qwen2.5-7b", "qwen2.5-14b", "smollm2-135m",
                                  "smollm2-135m-touchcot", "smollm2-135m-cpu", "smollm2-135m-heads-cpu",
                                  "physiclear-smollm2-cpu"])
def test_the_shipped_configs_load_check_and_round_trip(name: str) -> None:
    config = load_train_config(config_file(name))
    config.check()
    assert TrainConfig.from_dict(config.to_dict()) == config  # what the DDP test hands its workers


@pytest.mark.parametrize("name", ["smollm2-135m", "smollm2-135m-touchcot", "smollm2-135m-cpu",
                                  "physiclear-smollm2-cpu"])
def test_the_smollm2_configs_are_the_paper_core_on_the_llm_get_folder(name: str) -> None:
    """No read-out heads, and room for the longest TouchCoT example (234 SmolLM2 tokens)."""
    config = load_train_config(config_file(name))
    assert config.model.llm == "runs/smollm2" and config.model.system_prompt
    encoder = config.model.encoder
    assert encoder["use_temporal"] and encoder["question_conditioning"]
    assert encoder["cross_video"] == 0 and encoder["clip_reader"] is False
    assert config.data.max_length >= 240


def test_the_smollm2_recipes_hold_what_was_chosen_on_val() -> None:
    """The default: plain answers with LoRA r16 (chosen on val); TouchCoT: the paper's adapter and learning rate;
    the CPU variant: the default, shortened."""
    chosen = load_train_config(CONFIGS / "smollm2-135m.yaml")
    assert chosen.data.stage2_data == "plain" and (chosen.lora.r, chosen.lora.alpha) == (16, 32)
    assert chosen.stage2.lr == 2e-4 and (chosen.stage1.steps, chosen.stage2.steps) == (1000, 1000)
    paper = load_train_config(CONFIGS / "smollm2-135m-touchcot.yaml")
    assert paper.data.stage2_data == "touchcot" and (paper.lora.r, paper.lora.alpha) == (128, 256)
    assert paper.stage2.lr == 2e-4 and paper.output_dir != chosen.output_dir
    cpu = load_train_config(CONFIGS / "smollm2-135m-cpu.yaml")
    assert (cpu.stage1.steps, cpu.stage2.steps) == (300, 600) and cpu.output_dir not in (chosen.output_dir,
                                                                                         paper.output_dir)
    assert (cpu.lora, cpu.data.stage2_data, cpu.stage2.lr) == (chosen.lora, "plain", chosen.stage2.lr)


@pytest.mark.parametrize(("name", "llm", "steps"), [("qwen2.5-7b", "Qwen/Qwen2.5-7B-Instruct", 10000),
                                                    ("qwen2.5-14b", "Qwen/Qwen2.5-14B-Instruct", 10000)])
def test_the_paper_configs_hold_the_paper_settings(name: str, llm: str, steps: int) -> None:
    config = load_train_config(config_file(name))
    assert config.model.llm == llm and config.model.dtype == "bfloat16" and config.model.gradient_checkpointing
    assert config.model.appearance
    assert (config.lora.r, config.lora.alpha, config.lora.dropout) == (128, 256, 0.05)
    assert set(config.lora.target_modules) == {"q_proj", "k_proj", "v_proj", "o_proj"}
    assert config.stage2.lr == 2e-4 and config.stage2.steps == steps <= 10000
    assert config.runtime.mixed_precision == "bf16" and config.runtime.log_with == "tensorboard"
    assert config.runtime.checkpoint_every == 500
    for stage in (config.stage1, config.stage2):  # the paper's global batch, on its 2 GPUs or any other count
        assert stage.global_batch == 32 and stage.micro_batch("stage", 2) * stage.grad_accum * 2 == 32


# ------------------------------------------------------------------------------------------ the command


def assert_one_line_error(result, *needles: str) -> str:
    assert result.exit_code == 2, (result.exit_code, result.output, result.exception)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    for needle in needles:
        assert needle in lines[0], lines[0]
    assert "Traceback" not in result.output
    return lines[0]


@pytest.fixture
def cli(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """Run ``tacreasoner`` in an empty directory (so no runs/ of the checkout is found); no model may load."""
    from tacreasoner.cli import app
    from tacreasoner.train import trainer

    def no_model(*args, **kwargs):
        raise AssertionError("a model was about to be built: the arguments should have been refused before")

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(trainer, "_build", no_model)
    monkeypatch.delenv("TACREASONER_DEBUG", raising=False)
    return lambda *args: runner.invoke(app, [str(a) for a in args])


def test_train_refuses_an_unknown_config_key_in_one_line(cli, tmp_path: Path) -> None:
    path = write(tmp_path, "seed: 0\nstage1:\n  steps: 5\n  lerning_rate: 1.0e-3\n", "bad.yaml")
    line = assert_one_line_error(cli("train", "--stage", "1", "--config", path), "lerning_rate")
    assert re.search(rf"{re.escape(str(path))}:\d+:", line)


def test_train_refuses_a_bad_override_in_one_line(cli) -> None:
    result = cli("train", "--stage", "1", "--config", config_file("quickstart-smollm2-cpu"), "--set", "stage1.steps=-1")
    assert_one_line_error(result, "stage1.steps", "-1")
    result = cli("train", "--stage", "1", "--config", config_file("quickstart-smollm2-cpu"), "--set", "stage1.steps")
    assert_one_line_error(result, "--set", "KEY=VALUE")


def test_train_refuses_a_missing_config_in_one_line(cli, tmp_path: Path) -> None:
    assert_one_line_error(cli("train", "--stage", "1", "--config", tmp_path / "nope.yaml"), "nope.yaml")


def test_train_refuses_stage_3_when_the_inputs_exist(cli, tmp_path: Path) -> None:
    (tmp_path / "bench").mkdir()
    (tmp_path / "bench" / "bench.json").write_text("{}")
    (tmp_path / "llm").mkdir()
    (tmp_path / "llm" / "config.json").write_text("{}")
    path = write(tmp_path, f"model:\n  llm: {tmp_path / 'llm'}\ndata:\n  bench: {tmp_path / 'bench'}\n", "ok.yaml")
    assert_one_line_error(cli("train", "--stage", "3", "--config", path), "stage", "3")


def test_train_refuses_stage_3_before_looking_at_the_inputs(cli) -> None:
    assert_one_line_error(cli("train", "--stage", "3", "--config", config_file("quickstart-smollm2-cpu")), "stage", "3")


# ------------------------------------------------------------------------------------------ accelerate configs


ACCELERATE = {"ddp-2gpu.yaml": ("MULTI_GPU", 2, False), "fsdp-2gpu.yaml": ("FSDP", 2, False),
              "deepspeed-zero2-2gpu.yaml": ("DEEPSPEED", 2, False), "cpu-ddp-2proc.yaml": ("MULTI_GPU", 2, True)}


def test_every_accelerate_config_is_tested() -> None:
    assert {p.name for p in (CONFIGS / "accelerate").glob("*.yaml")} == set(ACCELERATE)


@pytest.mark.parametrize("name", sorted(ACCELERATE))
def test_accelerate_configs_parse_with_the_expected_setup(name: str) -> None:
    from accelerate.commands.config.config_args import load_config_from_file
    from accelerate.commands.launch import launch_command_parser

    path = CONFIGS / "accelerate" / name
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    distributed_type, processes, cpu = ACCELERATE[name]
    assert (data["distributed_type"], data["num_processes"], data["use_cpu"]) == (distributed_type, processes, cpu)
    assert data["compute_environment"] == "LOCAL_MACHINE" and data["num_machines"] == 1
    assert data["mixed_precision"] == ("no" if cpu else "bf16")
    config = load_config_from_file(str(path))  # Accelerate's own reader: unknown keys are errors there
    assert config.num_processes == processes and config.distributed_type.value == distributed_type
    options = {o for action in launch_command_parser()._actions for o in action.option_strings}
    for key in {**data.get("fsdp_config", {}), **data.get("deepspeed_config", {})}:
        assert f"--{key}" in options, f"{name}: {key} is not an `accelerate launch` setting"


def test_the_fsdp_config_wraps_qwen2_decoder_layers(monkeypatch: pytest.MonkeyPatch) -> None:
    """The FSDP config through `accelerate launch`'s own argument → environment → plugin path (no GPU needed)."""
    from accelerate.commands.launch import _validate_launch_command, launch_command_parser
    from accelerate.utils import FullyShardedDataParallelPlugin
    from accelerate.utils.launch import prepare_multi_gpu_env
    from transformers.models.qwen2 import modeling_qwen2

    args = launch_command_parser().parse_args(["--config_file", str(CONFIGS / "accelerate" / "fsdp-2gpu.yaml"),
                                               "train.py"])
    args = _validate_launch_command(args)[0]
    assert args.use_fsdp and args.num_processes == 2
    env = prepare_multi_gpu_env(args)
    for key, value in env.items():
        if key.startswith("FSDP_") or key == "ACCELERATE_USE_FSDP":
            monkeypatch.setenv(key, value)
    plugin = FullyShardedDataParallelPlugin()
    assert plugin.fsdp_version == 2 and plugin.transformer_cls_names_to_wrap == ["Qwen2DecoderLayer"]
    assert hasattr(modeling_qwen2, "Qwen2DecoderLayer")
    assert plugin.state_dict_type.name == "FULL_STATE_DICT" and plugin.reshard_after_forward is True


def test_set_reads_exponent_numbers_without_a_dot_as_floats() -> None:
    from tacreasoner.cli.app import parse_overrides as _parse_overrides

    # YAML 1.1 reads "1e-4" as a string; `--set stage2.lr=1e-4` must still set a float
    overrides = _parse_overrides(["stage2.lr=1e-4", "stage1.lr=2.5E+0", "output_dir=run1e5", "seed=3"])
    assert overrides == {"stage2.lr": 1e-4, "stage1.lr": 2.5, "output_dir": "run1e5", "seed": 3}
    config = load_train_config(CONFIGS / "smollm2-135m.yaml", overrides)
    assert config.stage2.lr == pytest.approx(1e-4) and config.stage1.lr == pytest.approx(2.5)


def test_the_heads_and_physiclear_variants_change_only_what_they_say() -> None:
    """smollm2-135m-heads-cpu: the CPU recipe with the heads on; physiclear-smollm2-cpu: the CPU recipe on
    PhysiCLeAR's benchmark (plain answers, so no TouchCoT file) with the EfficientNet-Lite0 appearance encoder,
    shortened to fit 60 minutes on 2 cores (Stage I 200, Stage II 400 steps), with paraphrased training wordings and
    length-grouped batches (issue 37: chosen on val, docs/real-data.md)."""
    cpu = load_train_config(CONFIGS / "smollm2-135m-cpu.yaml").to_dict()
    heads = load_train_config(CONFIGS / "smollm2-135m-heads-cpu.yaml").to_dict()
    real = load_train_config(config_file("physiclear-smollm2-cpu")).to_dict()
    assert heads["model"]["encoder"]["cross_video"] == 3 and heads["model"]["encoder"]["clip_reader"] is True
    for variant, changed in ((heads, {"output_dir", "model"}),
                             (real, {"output_dir", "data", "model", "stage1", "stage2"})):
        assert {k for k in cpu if cpu[k] != variant[k]} == changed
    for stage, steps in (("stage1", 200), ("stage2", 400)):
        assert {k for k in cpu[stage] if cpu[stage][k] != real[stage][k]} == {"steps"}
        assert real[stage]["steps"] == steps
    assert {k for k in cpu["model"] if cpu["model"][k] != heads["model"][k]} == {"encoder"}
    # the real-data recipe's appearance branch is the pretrained backbone (`encoder get`), not the simulated ViT
    assert {k for k in cpu["model"] if cpu["model"][k] != real["model"][k]} <= {"appearance", "encoder"}
    assert real["model"]["appearance"] == "runs/effnet"
    encoder_changes = {k for k in {*cpu["model"]["encoder"], *real["model"]["encoder"]}
                       if cpu["model"]["encoder"].get(k) != real["model"]["encoder"].get(k)}
    assert encoder_changes <= {"standardize_appearance"}
    assert {k for k in cpu["data"] if cpu["data"][k] != real["data"][k]} == {"bench", "video_cache", "paraphrases",
                                                                               "group_by_length"}
    assert real["data"]["paraphrases"] is True and real["data"]["group_by_length"] is True
    assert real["data"]["bench"] == "runs/physiclear/bench" and real["data"]["touchcot"] is None


def test_data_settings_default_to_what_the_recommended_recipes_train() -> None:
    """A config that leaves data.stage2_data out trains plain answers, as the quickstart and the PhysiCLeAR recipe
    do (both chosen on val), and needs no TouchCoT file."""
    from tacreasoner.train.config import DataSettings

    defaults = DataSettings()
    assert defaults.stage2_data == "plain" and defaults.touchcot is None
    for name in ("quickstart-smollm2-cpu", "physiclear-smollm2-cpu"):
        assert load_train_config(config_file(name)).data.stage2_data == defaults.stage2_data



def test_a_shipped_config_loads_by_name_from_any_directory(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    config = load_train_config("physiclear-smollm2-cpu")
    assert config.model.appearance == "runs/effnet" and config.data.stage2_data == "plain"
    with pytest.raises(FileNotFoundError, match="shipped one by name: quickstart-smollm2-cpu, physiclear-smollm2-cpu"):
        load_train_config("physiclear-smollm2-gpu")


def test_the_global_batch_gives_each_process_its_micro_batch() -> None:
    from tacreasoner.train.config import StageSettings

    settings = StageSettings(batch_size=16, grad_accum=2, global_batch=32)
    assert [settings.micro_batch("stage2", n) for n in (1, 2, 4, 8, 16)] == [16, 8, 4, 2, 1]
    with pytest.raises(ValueError, match=r"stage2.global_batch 32 does not split into 3 process\(es\) × grad_accum 2 "
                                         r"equal micro-batches: make it a multiple of 6"):
        settings.micro_batch("stage2", 3)
    with pytest.raises(ValueError, match="does not split into 32 process"):
        settings.micro_batch("stage2", 32)  # 32 × 2 accumulation steps need 64 examples
    assert {settings.examples_per_step("stage2", n) for n in (1, 2, 4, 8, 16)} == {32}
    assert StageSettings(batch_size=4, grad_accum=3).examples_per_step("stage1", 1) == 12


def test_several_processes_without_a_stated_global_batch_are_refused_with_the_numbers() -> None:
    from tacreasoner.train.config import StageSettings

    settings = StageSettings(batch_size=16, grad_accum=1)
    assert settings.micro_batch("stage1", 1) == 16  # one process: batch_size as before
    with pytest.raises(ValueError, match=r"stage1.global_batch is not set and 8 processes train: batch_size 16 × "
                                         r"grad_accum 1 × 8 processes would make the global batch 128, not the 16 of "
                                         r"one process; state it \(--set stage1.global_batch=16\)"):
        settings.micro_batch("stage1", 8)

