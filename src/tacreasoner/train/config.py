"""The training configuration: one YAML file, one schema, checked before any work starts.

A file has five sections (every key optional except where noted)::

    output_dir: runs/train          # stage1/ and stage2/ are written under it
    seed: 0
    model:    {llm, appearance, encoder: {...ablation switches...}, dtype, gradient_checkpointing}
    data:     {bench, touchcot, stage2_data, tasks, max_length, group_by_length, length_group_batches, ...}
    stage1:   {steps, batch_size, grad_accum, lr, projector_lr, weight_decay, warmup_ratio, ...}
    stage2:   {... same fields ...}
    lora:     {r, alpha, dropout, target_modules}
    runtime:  {mixed_precision, log_with, log_every, checkpoint_every, keep_checkpoints, threads}

Unknown keys and bad values are errors naming ``file:line`` and the key, so a typo never runs a
10k-step job with a default in its place. Relative paths are taken relative to the working directory
(as on the command line).
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tacreasoner.cot.knowledge import KNOWLEDGE
from tacreasoner.fields import reject_unknown_fields
from tacreasoner.model.stages import STAGES, LoraSettings
from tacreasoner.yamlfile import KeyPath, line_of, read_yaml

__all__ = ["DataSettings", "ModelSettings", "RuntimeSettings", "StageSettings", "TrainConfig", "load_train_config"]

STAGE2_DATA = ("touchcot", "plain", "compact")
"""Stage II targets: TouchCoT reasoning, the plain gold answer (the paper's "w/o CoT" ablation), or the compact
describe-then-conclude reasoning written from the benchmark's train labels (``cot.compact``)."""
MIXED_PRECISION = ("auto", "no", "bf16", "fp16")
LOGGERS = ("none", "tensorboard")
DTYPES = ("float32", "bfloat16", "float16", "auto")


@dataclass
class ModelSettings:
    llm: str = "runs/llm"
    """Causal LM directory or hub id: ``llm get smollm2`` output, or e.g. Qwen/Qwen2.5-7B-Instruct."""
    appearance: str | None = None
    """``pretrain-encoder`` / ``encoder get`` output directory, or a Hugging Face VideoMAE directory as it is (or null:
    a randomly initialised appearance ViT)."""
    encoder: dict[str, Any] = field(default_factory=dict)
    """``TactileEncoderConfig`` fields: ablation switches (use_temporal, question_conditioning, tokens_per_video)."""
    dtype: str = "float32"
    """Weights' dtype when loading the LLM (bfloat16 for 7B+ on GPU)."""
    gradient_checkpointing: bool = False
    attn_implementation: str | None = None
    system_prompt: str | None = None

    def check(self) -> None:
        if not self.llm:
            raise ValueError("model.llm: give a causal LM directory or hub id")
        if self.dtype not in DTYPES:
            raise ValueError(f"model.dtype: {self.dtype!r} is not one of {', '.join(DTYPES)}")
        from tacreasoner.model.encoder_config import TactileEncoderConfig
        from tacreasoner.train.head_settings import with_head_settings

        try:
            TactileEncoderConfig.from_dict(with_head_settings(self.encoder))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"model.encoder: {exc}") from None


@dataclass
class DataSettings:
    bench: str = "runs/quickstart/bench"
    """Benchmark directory (``build-bench``): Stage I description data comes from its train split."""
    extra_benches: list[str] = field(default_factory=list)
    """More benchmark directories whose train splits join ``bench``'s, with plain answers in both stages (e.g.
    simulated clips asked in PhysiCLeAR's words beside PhysiCLeAR: ``build-bench --source sim --vocabulary
    physiclear``). Each must use ``bench``'s vocabulary; not with TouchCoT or the read-out heads."""
    touchcot: str | None = None
    """TouchCoT training JSONL (``build-cot``) for Stage II; needed only with ``stage2_data: touchcot``."""
    stage2_data: str = "plain"
    """plain (gold answers without reasoning, from the benchmark's train split: what the recommended recipes train,
    chosen on val) | touchcot (the paper's reasoning, from ``touchcot``) | compact (each
    multi-object item's videos described in level words, then the step that concludes: ``cot.compact``; no
    TouchCoT file needed)."""
    knowledge: str = "none"
    """Stage II also trains on text-only examples of what everyday objects feel like (``cot.knowledge``, from
    ``tasks/everyday_objects.yaml``; what matching videos to named objects needs): none | all | without_eval_names
    (every entry sharing a word with a val or test object's name left out, to measure what carries over)."""
    scenario_knowledge: bool = False
    """Stage II also trains on text-only examples of what everyday scenarios need and of choices between two objects
    described in words (``cot.knowledge.scenario_examples``), over training scenarios disjoint from TSA's
    evaluation bank (``tasks/scenarios_train.yaml``; TSA itself stays zero-shot)."""
    stage1_video_readings: bool = False
    """Stage I also asks how one video of a comparison's two or three feels ("How does Video 2 feel in hardness?"),
    so the projector learns tokens the LLM finds by their label (``encoder.video_labels``; docs/training.md)."""
    stage1_comparisons: bool = False
    """Stage I also answers the train split's comparisons (SFD, SOI) with their plain verdicts, so the encoder and
    projector learn to present two or three videos in a way the frozen LLM can compare (docs/training.md)."""
    paraphrases: bool = False
    """Each train item with a training wording of its kind (``tasks/paraphrases/train.yaml``) is also asked in it,
    so the model learns questions, not the benchmark's templates; lettered SFD/SOI wordings teach answering a listed
    option by its letter (TSA's form). Held-out wordings (``heldout.yaml``) are never trained on."""
    tasks: list[str] | None = None
    """Restrict training items to these tasks (default: all in the files; TSA is never trained on)."""
    repeat: dict[str, int] | None = None
    """Task → how many times each of its examples is seen per epoch (after the comparator's fit, which sees each
    once), e.g. ``{OSC: 4}``: OSC's answer is one of six assignments learnt from ~200 examples."""
    max_length: int = 768
    """Longer examples are dropped and counted (never silently truncated mid-answer)."""
    group_by_length: bool = False
    """Sort chunks of ``length_group_batches`` global batches by length: less padding, but length follows task
    and answer, so batches hold fewer tasks and answers (benchmarks/results/batch_mix.md; it cost the tiny
    model accuracy, docs/training.md)."""
    length_group_batches: int = 32
    cache_appearance: bool = True
    """Run the frozen appearance ViT once per clip instead of every step (identical output, faster)."""
    max_items: int | None = None
    """Use only the first N training examples (trial runs)."""
    video_cache: str | None = None
    """Directory keeping preprocessed videos between runs (stages, seeds, ablations, evaluation); null = none. With
    several processes the main one fills it first and the others read it: set it for multi-GPU runs."""
    head_folds: int = 5
    """Stage II writes into each training prompt the verdict of a read-out head (``encoder.clip_reader``,
    ``encoder.cross_video``) fitted without that prompt's objects: the objects are split into this many folds
    (cross-fitting; ``train.heads``). 1: in-sample verdicts (near gold on the prompts the head was fitted on)."""

    def check(self) -> None:
        if self.knowledge not in KNOWLEDGE:
            raise ValueError(f"data.knowledge: {self.knowledge!r} is not one of {', '.join(KNOWLEDGE)}")
        if self.stage2_data not in STAGE2_DATA:
            raise ValueError(f"data.stage2_data: {self.stage2_data!r} is not one of {', '.join(STAGE2_DATA)}")
        if self.max_length < 16:
            raise ValueError(f"data.max_length must be at least 16, got {self.max_length}")
        if self.length_group_batches < 1:
            raise ValueError(f"data.length_group_batches must be at least 1, got {self.length_group_batches}")
        if not isinstance(self.head_folds, int) or isinstance(self.head_folds, bool) or self.head_folds < 1:
            raise ValueError(f"data.head_folds must be a whole number ≥ 1 (1: no cross-fitting), got "
                             f"{self.head_folds!r}")
        if self.max_items is not None and self.max_items < 1:
            raise ValueError(f"data.max_items must be at least 1, got {self.max_items}")
        if self.repeat is not None:
            if not isinstance(self.repeat, dict):
                raise ValueError(f"data.repeat must map task names to whole numbers ≥ 1, got {self.repeat!r}")
            _check_task_names(self.repeat, "data.repeat")
            for task, times in self.repeat.items():
                if not isinstance(times, int) or isinstance(times, bool) or times < 1:
                    raise ValueError(f"data.repeat.{task} must be a whole number ≥ 1, got {times!r}")
        if not isinstance(self.extra_benches, list) or not all(isinstance(b, str) and b for b in self.extra_benches):
            raise ValueError(f"data.extra_benches must be a list of benchmark directories, got {self.extra_benches!r}")
        if self.extra_benches and self.stage2_data == "touchcot":
            raise ValueError("data.extra_benches give plain or compact answers only: set data.stage2_data: plain or "
                             "compact (their items have no TouchCoT reasoning)")
        if self.tasks is not None:
            _check_task_names(self.tasks, "data.tasks")
            if "TSA" in self.tasks:
                raise ValueError("data.tasks: TSA is the zero-shot task and is never trained on")


def _check_task_names(names: Iterable[str], key: str) -> None:
    from tacreasoner.tasks.schema import TASKS

    unknown = [t for t in names if t not in TASKS]
    if unknown:
        raise ValueError(f"{key}: unknown task(s) {unknown}; known: {', '.join(TASKS)}")


@dataclass
class StageSettings:
    steps: int = 200
    batch_size: int = 8
    """Examples per micro-batch of one process (when ``global_batch`` is not set)."""
    grad_accum: int = 1
    global_batch: int | None = None
    """Examples per optimizer step over all processes. When set, each process's micro-batch is derived from it
    (global_batch / (processes × grad_accum)), so a launch on more or fewer GPUs keeps the recipe's batch; more than
    one process needs it (a per-process batch_size would silently grow the global batch with the process count)."""
    lr: float = 2e-4
    """Learning rate of every trained part except the projector (LoRA in Stage II, temporal branch in Stage I)."""
    projector_lr: float | None = None
    """Projector learning rate (default: lr)."""
    weight_decay: float = 0.0
    warmup_ratio: float = 0.05
    min_lr_ratio: float = 0.1
    max_grad_norm: float = 1.0
    skip: bool = False
    """Ablations: skip the stage (w/o Stage I / w/o Stage II)."""

    def check(self, name: str) -> None:
        for key in ("steps", "batch_size", "grad_accum"):
            if int(getattr(self, key)) < 1:
                raise ValueError(f"{name}.{key} must be at least 1, got {getattr(self, key)}")
        if self.global_batch is not None and self.global_batch < 1:
            raise ValueError(f"{name}.global_batch must be at least 1, got {self.global_batch}")
        for key in ("lr", "projector_lr"):
            value = getattr(self, key)
            if value is not None and not (isinstance(value, int | float) and value > 0 and math.isfinite(value)):
                raise ValueError(f"{name}.{key} must be a positive number, got {value!r}")
        if not 0 <= self.warmup_ratio < 1:
            raise ValueError(f"{name}.warmup_ratio must be in [0, 1), got {self.warmup_ratio}")
        if not 0 <= self.min_lr_ratio <= 1:
            raise ValueError(f"{name}.min_lr_ratio must be in [0, 1], got {self.min_lr_ratio}")
        if self.weight_decay < 0 or self.max_grad_norm <= 0:
            raise ValueError(f"{name}: weight_decay must be ≥ 0 and max_grad_norm > 0")

    def micro_batch(self, name: str, processes: int) -> int:
        """Examples per process per micro-batch for ``processes`` processes; refuses, with the numbers, a launch
        that would change the global batch or cannot split it evenly."""
        if self.global_batch is None:
            if processes > 1:
                one = self.batch_size * self.grad_accum
                raise ValueError(f"{name}.global_batch is not set and {processes} processes train: batch_size "
                                 f"{self.batch_size} × grad_accum {self.grad_accum} × {processes} processes would make "
                                 f"the global batch {one * processes}, not the {one} of one process; state it "
                                 f"(--set {name}.global_batch={one})")
            return self.batch_size
        per, rest = divmod(self.global_batch, processes * self.grad_accum)
        if rest or per < 1:
            raise ValueError(f"{name}.global_batch {self.global_batch} does not split into {processes} process(es) × "
                             f"grad_accum {self.grad_accum} equal micro-batches: make it a multiple of "
                             f"{processes * self.grad_accum}")
        return per

    def examples_per_step(self, name: str, processes: int) -> int:
        """Examples per optimizer step over all ``processes`` (``global_batch`` where stated)."""
        return self.micro_batch(name, processes) * self.grad_accum * processes


@dataclass
class RuntimeSettings:
    mixed_precision: str = "auto"
    """auto = bf16 where the hardware has it (CUDA bf16, or a CPU with native bf16), else fp32."""
    log_with: str = "tensorboard"
    log_every: int = 10
    checkpoint_every: int = 100
    keep_checkpoints: int = 2
    threads: int | None = None
    """CPU threads per process (default: alone, the cores not busy with other work; with several processes on one
    machine, an equal share of its cores)."""
    progress: bool = True
    pack_sequences: bool | None = None
    """Run the LM on packed rows: no padding, the prefix every sample of a batch shares computed once
    (model/packing.py; the same loss and gradients up to float rounding). Default (null): on the CPU, where a step
    costs what its positions cost (benchmarks/results/train_speed.md); off on GPUs, where it is unmeasured."""

    def check(self) -> None:
        if self.mixed_precision not in MIXED_PRECISION:
            raise ValueError(f"runtime.mixed_precision: {self.mixed_precision!r} is not one of "
                             f"{', '.join(MIXED_PRECISION)}")
        if self.log_with not in LOGGERS:
            raise ValueError(f"runtime.log_with: {self.log_with!r} is not one of {', '.join(LOGGERS)}")
        for key in ("log_every", "checkpoint_every"):
            if getattr(self, key) < 1:
                raise ValueError(f"runtime.{key} must be at least 1, got {getattr(self, key)}")
        if self.keep_checkpoints < 1:
            raise ValueError(f"runtime.keep_checkpoints must be at least 1, got {self.keep_checkpoints}")
        if self.threads is not None and self.threads < 1:
            raise ValueError(f"runtime.threads must be at least 1, got {self.threads}")


_TYPES: dict[str, tuple[type, ...]] = {"int": (int,), "float": (int, float), "bool": (bool,), "str": (str,),
                                       "list[str]": (list,), "dict[str, Any]": (dict,), "dict[str, int]": (dict,)}


def _check_types(kind: type, raw: dict[str, Any], section: str) -> None:
    """Every value has its field's type: a typo'd number is a string in YAML, and a bool is no number."""
    for f in dataclasses.fields(kind):
        if f.name not in raw:
            continue
        value, options = raw[f.name], [t.strip() for t in str(f.type).split("|")]
        if value is None and "None" in options:
            continue
        allowed = tuple(t for o in options if o != "None" for t in _TYPES[o])
        ok = isinstance(value, allowed) and (bool in allowed or not isinstance(value, bool))
        if ok and isinstance(value, list):
            ok = all(isinstance(v, str) for v in value)
        if not ok:
            expected = " or ".join("a list of strings" if o == "list[str]" else "a mapping" if o.startswith("dict")
                                   else o for o in options if o != "None")
            raise ValueError(f"{section}.{f.name} must be {expected}, got {value!r}")


def _default_stage1() -> StageSettings:
    return StageSettings(steps=150, lr=1e-3, batch_size=16)


def _default_stage2() -> StageSettings:
    return StageSettings(steps=300, lr=2e-4, projector_lr=1e-3, batch_size=8)


@dataclass
class TrainConfig:
    output_dir: str = "runs/train"
    seed: int = 0
    model: ModelSettings = field(default_factory=ModelSettings)
    data: DataSettings = field(default_factory=DataSettings)
    stage1: StageSettings = field(default_factory=_default_stage1)
    stage2: StageSettings = field(default_factory=_default_stage2)
    lora: LoraSettings = field(default_factory=LoraSettings)
    runtime: RuntimeSettings = field(default_factory=RuntimeSettings)

    def check(self) -> None:
        self.model.check()
        self.data.check()
        encoder = self.model.encoder
        if self.data.extra_benches and (encoder.get("cross_video") or encoder.get("clip_reader")):
            raise ValueError("data.extra_benches: the read-out heads (model.encoder.cross_video, clip_reader) are "
                             "fitted on data.bench's train split only; switch them off to mix benchmarks")
        self.stage1.check("stage1")
        self.stage2.check("stage2")
        self.runtime.check()

    def stage(self, number: int) -> StageSettings:
        if number not in STAGES:
            raise ValueError(f"stage must be one of {STAGES}, got {number!r}")
        return self.stage1 if number == 1 else self.stage2

    def stage_dir(self, number: int) -> Path:
        return Path(self.output_dir) / f"stage{number}"

    def to_dict(self) -> dict[str, Any]:
        data = dataclasses.asdict(self)
        data["lora"]["target_modules"] = list(self.lora.target_modules)
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any] | None, *, source: str = "config",
                  lines: dict[KeyPath, int] | None = None) -> TrainConfig:
        """Build and check a config; errors name ``source:line`` and the key."""
        data = dict(data or {})
        lines = lines or {}

        def where(*path: str | int) -> str:
            return f"{source}:{line_of(lines, tuple(path))}" if lines else source

        def first_unknown(kind: type, raw: dict[str, Any]) -> tuple[str, ...]:
            unknown = sorted(map(str, set(raw) - {f.name for f in dataclasses.fields(kind)}))
            return tuple(unknown[:1])

        try:
            reject_unknown_fields(cls, data, "unknown top-level keys", known="declared")
        except ValueError as exc:
            raise ValueError(f"{where(*first_unknown(cls, data))}: {exc}") from None
        sections = {"model": ModelSettings, "data": DataSettings, "stage1": StageSettings, "stage2": StageSettings,
                    "runtime": RuntimeSettings}
        built: dict[str, Any] = {}
        defaults = cls()
        for name, kind in sections.items():
            raw = data.get(name)
            if raw is None:
                continue
            if not isinstance(raw, dict):
                raise ValueError(f"{where(name)}: {name} must be a mapping of settings, got {type(raw).__name__}")
            try:
                reject_unknown_fields(kind, raw, f"{name}: unknown keys", known="declared")
            except ValueError as exc:
                raise ValueError(f"{where(name, *first_unknown(kind, raw))}: {exc}") from None
            if name == "runtime" and raw.get("mixed_precision") is False:
                raw = {**raw, "mixed_precision": "no"}  # YAML 1.1 (and --set runtime.mixed_precision=no) read false
            try:
                _check_types(kind, raw, name)
                base = dataclasses.asdict(getattr(defaults, name))
                built[name] = kind(**{**base, **raw})
            except (TypeError, ValueError) as exc:
                key = re.match(rf"{name}\.(\w+)", str(exc))
                raise ValueError(f"{where(name, *key.groups()) if key else where(name)}: {exc}") from None
        if data.get("lora") is not None:
            try:
                built["lora"] = LoraSettings.from_dict(data["lora"])
            except (TypeError, ValueError) as exc:
                raise ValueError(f"{where('lora')}: {exc}") from None
        for key in ("output_dir", "seed"):
            if key in data:
                built[key] = data[key]
        if not isinstance(built.get("seed", 0), int):
            raise ValueError(f"{where('seed')}: seed must be an integer, got {built['seed']!r}")
        config = cls(**built)
        try:
            config.check()
        except ValueError as exc:
            key = re.match(r"(\w+)(?:\.(\w+))?", str(exc))
            raise ValueError(f"{where(*(k for k in key.groups() if k)) if key else where()}: {exc}") from None
        return config


SHIPPED_CONFIGS = ("quickstart-smollm2-cpu", "physiclear-smollm2-cpu")
"""Training configs inside the package (``--config NAME`` works from any directory)."""


def shipped_config(name: str) -> Path | None:
    """The path of a shipped config, by name (``physiclear-smollm2-cpu``); None if there is none."""
    if name not in SHIPPED_CONFIGS:
        return None
    return Path(__file__).resolve().parents[1] / "recipes" / f"{name}.yaml"


def load_train_config(path: str | Path, overrides: dict[str, Any] | None = None) -> TrainConfig:
    """Read a YAML training config; ``overrides`` are dotted keys (``{"stage2.steps": 10}``) applied on top."""
    path = Path(path)
    if not path.is_file() and path.parent == Path(".") and shipped_config(path.stem) is not None:
        path = shipped_config(path.stem)  # a config that ships with the package, by name
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such training config (a YAML file, or a shipped one by "
                                f"name: {', '.join(SHIPPED_CONFIGS)})")
    data, lines = read_yaml(path)
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ValueError(f"{path}: a training config must be a mapping of sections, got {type(data).__name__}")
    for dotted, value in (overrides or {}).items():
        apply_override(data, dotted, value)
    return TrainConfig.from_dict(data, source=str(path), lines=lines)


def apply_override(data: dict[str, Any], dotted: str, value: Any) -> None:
    """Set ``data["a"]["b"] = value`` for ``"a.b"`` (creating sections as needed)."""
    *parents, last = dotted.split(".")
    node = data
    for key in parents:
        child = node.setdefault(key, {})
        if not isinstance(child, dict):
            raise ValueError(f"override {dotted}: {key} is not a section")
        node = child
    node[last] = value
