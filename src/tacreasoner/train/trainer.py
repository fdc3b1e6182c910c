"""One trainer for Stage I (alignment) and Stage II (LoRA SFT), on Hugging Face Accelerate.

Read top to bottom: check the config and inputs → build the model (Stage I from the LLM + appearance
encoder; Stage II from Stage I's model) → choose what trains (``model.stages.configure_stage``) →
tokenise the examples and preprocess every video once → AdamW with a separate projector LR and a
warmup + cosine schedule → ``accelerator.prepare`` (CPU, one GPU, DDP, FSDP or DeepSpeed, decided by
``accelerate launch`` / ``torchrun``) → the loop → the model.

The loop's loss is a sum over answer tokens divided by the number of answer tokens in the *global*
batch (all processes and micro-batches), so 2 processes × batch 4, 1 process × batch 8 and 1 process
× batch 4 × 2 accumulation steps all take the same optimizer step. The batch of step ``s`` is a pure
function of (seed, s) (:func:`tacreasoner.train.data.batch_plan`) and checkpoints hold trainable
weights, optimizer, scheduler and RNG state, so a killed run resumed with ``resume=True`` ends where
an uninterrupted run would.

Files under ``<output_dir>/stage<N>/``: ``checkpoints/step-*`` (atomic), ``train_log.jsonl``,
``logs/`` (TensorBoard), ``run.json`` (config, data counts, timing), then ``model/`` (model + processor;
Stage II: merged) and, for Stage II, ``adapter/`` (LoRA + projector, PEFT format).
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
import time
from collections.abc import Callable
from contextlib import nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch

from tacreasoner.progress import ProgressBar
from tacreasoner.train.config import TrainConfig
from tacreasoner.train.data import (
    VideoBank,
    batch_plan,
    collate,
    left_out_by_task,
    load_examples,
    repeat_tasks,
    tokenize_examples,
)
from tacreasoner.train.engine_state import (
    engine_saves_optimizer,
    gather_trainable,
    materialize_sharded,
    restore_trainable,
    save_engine_state,
)
from tacreasoner.train.head_settings import with_head_settings
from tacreasoner.train.heads import fit_heads_once, model_heads
from tacreasoner.train.loop import StepLoop, StepStats
from tacreasoner.train.precision import resolve_mixed_precision
from tacreasoner.train.state import (
    cosine_with_warmup,
    fresh_staging_dir,
    latest_checkpoint,
    load_checkpoint,
    load_optimizer_state,
    save_checkpoint,
    seed_everything,
    staging_dir,
    write_json,
)
from tacreasoner.train.threads import training_threads

__all__ = ["NonFiniteLossError", "StageResult", "check_inputs", "master_weights_in_fp32", "step_seed", "train_stage"]

CHECKPOINTS = "checkpoints"
LOG_FILE = "train_log.jsonl"
RUN_FILE = "run.json"
MODEL_DIR = "model"
ADAPTER_DIR = "adapter"


class NonFiniteLossError(RuntimeError):
    """The loss became NaN or infinite; the message names the step, micro-batch and examples."""


@dataclass
class StageResult:
    stage: int
    model_dir: Path
    steps: int
    final_loss: float | None
    train_seconds: float
    examples: int
    resumed_from: int


# ------------------------------------------------------------------------------------------ checks


def _looks_local(name: str) -> bool:
    """A path rather than a hub id ("org/name"): it exists, starts like a path, or its first part is a local folder."""
    parts = Path(name).parts
    return (Path(name).exists() or name.startswith((".", "/", "~")) or len(parts) != 2
            or Path(parts[0]).is_dir())


def check_inputs(config: TrainConfig, stage: int) -> None:
    """Every file a stage needs exists, before a model is loaded (a typo should cost seconds, not a load)."""
    config.stage(stage)
    config.check()
    bench = Path(config.data.bench)
    if not (bench / "bench.json").is_file():
        raise FileNotFoundError(f"data.bench: {bench} is not a benchmark directory (no bench.json; run "
                                f"`tacreasoner build-bench`)")
    vocabulary = json.loads((bench / "bench.json").read_text()).get("vocabulary")
    for extra in config.data.extra_benches:
        info_path = Path(extra) / "bench.json"
        if not info_path.is_file():
            raise FileNotFoundError(f"data.extra_benches: {extra} is not a benchmark directory (no bench.json)")
        theirs = json.loads(info_path.read_text()).get("vocabulary")
        if theirs != vocabulary:
            raise ValueError(f"data.extra_benches: {extra} answers in the {theirs} vocabulary, data.bench in "
                             f"{vocabulary}: build it with --vocabulary {vocabulary}")
    touchcot = config.data.touchcot
    if stage == 2 and config.data.stage2_data == "touchcot" and not (touchcot and Path(touchcot).is_file()):
        raise FileNotFoundError(f"data.touchcot: {touchcot} does not exist (run `tacreasoner build-cot`, or set "
                                f"data.stage2_data: plain)")
    if stage == 2 and not config.stage1.skip:
        model_dir = config.stage_dir(1) / MODEL_DIR
        if not (model_dir / "config.json").is_file():
            raise FileNotFoundError(f"{model_dir}: no Stage I model; run `tacreasoner train --stage 1` with this "
                                    f"config first (or set stage1.skip: true)")
    else:
        llm = config.model.llm
        if _looks_local(llm) and not (Path(llm) / "config.json").is_file():
            raise FileNotFoundError(f"model.llm: {llm} has no config.json (run `tacreasoner llm get smollm2 --out "
                                    f"{llm}`, or give a hub id such as Qwen/Qwen2.5-7B-Instruct)")
    app = config.model.appearance
    if app is not None and not (Path(app) / "config.json").is_file():
        raise FileNotFoundError(f"model.appearance: {app} has no config.json (run `tacreasoner pretrain-encoder`)")


# ------------------------------------------------------------------------------------------ building


def _build(config: TrainConfig, stage: int) -> tuple[Any, Any]:
    """The model a stage starts from and its processor."""
    from tacreasoner.model.build import build_model, load_model

    dtype = {"float32": torch.float32, "bfloat16": torch.bfloat16, "float16": torch.float16,
             "auto": "auto"}[config.model.dtype]
    kwargs: dict[str, Any] = {"dtype": dtype}
    if config.model.attn_implementation:
        kwargs["attn_implementation"] = config.model.attn_implementation
    encoder = with_head_settings(config.model.encoder)
    if stage == 2 and not config.stage1.skip:
        model, processor = load_model(config.stage_dir(1) / MODEL_DIR, **kwargs)
        if "clip_reader" in encoder:  # fitted in Stage II only: Stage II's config decides
            model.set_clip_reader(encoder.get("clip_reader_traits", ()), encoder.get("clip_reader_levels", 0))
        return model, processor
    return build_model(config.model.llm, appearance=config.model.appearance, encoder=encoder,
                       system_prompt=config.model.system_prompt, **kwargs)



def _to_device(batch: dict[str, Any], device: Any) -> dict[str, Any]:
    return {k: v.to(device) if torch.is_tensor(v) else _to_device(v, device) if isinstance(v, dict) else v
            for k, v in batch.items()}


def _param_groups(model: torch.nn.Module, lr: float, projector_lr: float, weight_decay: float) -> list[dict]:
    from tacreasoner.model.stages import no_decay_parameter_names

    no_decay = no_decay_parameter_names(model)
    groups: dict[tuple[bool, bool], list[torch.nn.Parameter]] = {}
    for name, p in model.named_parameters():
        if p.requires_grad:
            groups.setdefault(("projector" in name, name in no_decay), []).append(p)
    return [{"params": params, "lr": projector_lr if is_proj else lr, "weight_decay": 0.0 if nd else weight_decay}
            for (is_proj, nd), params in sorted(groups.items())]


# ------------------------------------------------------------------------------------------ the run


def train_stage(config: TrainConfig, stage: int, *, resume: bool = False, stop_after: int | None = None,
                on_log: Callable[[dict[str, Any]], None] | None = None,
                loss_hook: Callable[[int, int, torch.Tensor], torch.Tensor] | None = None) -> StageResult:
    """Run Stage ``stage`` of ``config``; returns where the model was written.

    ``resume``: continue from the newest checkpoint (a fresh start when there is none). Without it, a
    stage directory holding checkpoints is refused rather than overwritten. ``stop_after``: stop after
    that many steps without the final save (tests of interrupted runs). ``loss_hook(step, micro, loss)``
    may replace a micro-batch's loss (tests of the non-finite-loss guard).
    """
    settings = config.stage(stage)
    if settings.skip:
        raise ValueError(f"stage{stage}.skip is true in this config: nothing to train")
    check_inputs(config, stage)
    out = config.stage_dir(stage)
    ckpt_dir = out / CHECKPOINTS
    latest = latest_checkpoint(ckpt_dir) if ckpt_dir.is_dir() else None
    if latest is not None and not resume:
        raise ValueError(f"{out} already holds a Stage {stage} run ({latest.name}): resume it (--resume) or choose "
                         f"another output_dir")

    threads_before = torch.get_num_threads()
    if not torch.cuda.is_available():
        torch.set_num_threads(training_threads(config.runtime.threads, int(os.environ.get("LOCAL_WORLD_SIZE", "1"))))
    log_with = None if config.runtime.log_with == "none" else config.runtime.log_with
    if log_with == "tensorboard":
        try:
            import tensorboard  # noqa: F401
        except ImportError:
            raise ValueError('runtime.log_with: tensorboard needs the tensorboard package (pip install -e ".[train]")'
                             ', or set runtime.log_with: none') from None
    world = int(os.environ.get("WORLD_SIZE", "1"))
    settings.micro_batch(f"stage{stage}", world)  # a launch that would change the global batch fails here
    accelerator = make_accelerator(config, world, log_with, out / "logs")
    main = accelerator.is_main_process
    bar = ProgressBar(config.runtime.progress and main)
    try:
        return _run(config, stage, accelerator, bar, latest, stop_after, on_log, loss_hook)
    finally:
        bar.close()
        accelerator.end_training()
        if world == 1:  # Accelerate keeps one state per process: let the next run here choose another precision
            from accelerate.state import AcceleratorState

            AcceleratorState._reset_state(reset_partial_state=True)
        torch.set_num_threads(threads_before)


def make_accelerator(config: TrainConfig, world: int, log_with: str | None, logging_dir: Path) -> Any:
    """The run's Accelerator: engine from ``accelerate launch`` / ``torchrun``, precision from the config."""
    from accelerate import Accelerator, DistributedDataParallelKwargs, InitProcessGroupKwargs

    # Parts of the model speak only in some prompts (the comparator's name matcher in OSC prompts, the clip
    # reader in one-video prompts), so a batch can leave trainable parameters without a gradient, which plain
    # DDP refuses; finding them costs one walk of the autograd graph per step.
    handlers: list[Any] = [DistributedDataParallelKwargs(find_unused_parameters=True)]
    cpu_processes = world > 1 and not torch.cuda.is_available()
    deepspeed = os.environ.get("ACCELERATE_USE_DEEPSPEED", "false").lower() == "true"
    if cpu_processes and deepspeed:  # DeepSpeed's CPU accelerator; Accelerate picks no backend without a GPU
        handlers.append(InitProcessGroupKwargs(backend="gloo"))
    # Under torchrun on a machine without CUDA, Accelerate sets up (gloo) DDP only when told it runs on the CPU;
    # otherwise every process would train alone and all of them would write the same output_dir. (DeepSpeed is
    # set up only when not told so.)
    accelerator = Accelerator(cpu=cpu_processes and not deepspeed,
                              mixed_precision=resolve_mixed_precision(config.runtime.mixed_precision),
                              log_with=log_with, project_dir=str(logging_dir), kwargs_handlers=handlers)
    if world > 1 and accelerator.num_processes == 1:
        raise RuntimeError(f"WORLD_SIZE is {world} but Accelerate set up no distributed training "
                           f"({accelerator.distributed_type}): the processes would each train alone")
    return accelerator


def _run(config: TrainConfig, stage: int, accelerator: Any, bar: ProgressBar, latest: Path | None,
         stop_after: int | None, on_log: Callable[[dict[str, Any]], None] | None,
         loss_hook: Callable[[int, int, torch.Tensor], torch.Tensor] | None) -> StageResult:
    from transformers.utils import logging as hf_logging

    from tacreasoner.model.stages import configure_stage

    settings = config.stage(stage)
    out = config.stage_dir(stage)
    started = time.perf_counter()
    hf_logging.disable_progress_bar()
    seed_everything(config.seed)
    model, processor = _build(config, stage)
    if config.model.gradient_checkpointing:
        enable_activation_checkpointing(model.language_model)
    trained = configure_stage(model, stage, config.lora)
    master_weights_in_fp32(trained, accelerator.mixed_precision)
    base = model  # the TacReasonerForCausalLM inside (PEFT wraps it in Stage II)

    examples = load_examples(stage, config.data.bench, touchcot=config.data.touchcot,
                             stage2_data=config.data.stage2_data, tasks=config.data.tasks,
                             max_items=config.data.max_items, video_readings=config.data.stage1_video_readings,
                             comparisons=config.data.stage1_comparisons, paraphrases=config.data.paraphrases,
                             knowledge=config.data.knowledge, scenario_knowledge=config.data.scenario_knowledge)
    for extra in config.data.extra_benches:  # plain or compact (checked), videos under each benchmark's own root
        examples += load_examples(stage, extra, stage2_data=config.data.stage2_data, tasks=config.data.tasks,
                                  video_readings=config.data.stage1_video_readings,
                                  comparisons=config.data.stage1_comparisons, paraphrases=config.data.paraphrases)
    tokenized, dropped = tokenize_examples(processor, examples, config.data.max_length)
    left_out = left_out_by_task(examples, dropped, config.data.max_length)  # stops when a whole task (or all) is out
    if left_out and accelerator.is_main_process:
        print(f"stage {stage}: {len(dropped)} of {len(examples)} examples are longer than data.max_length="
              f"{config.data.max_length} and left out ({', '.join(f'{t} {n}' for t, n in left_out.items())}; the "
              f"longest is {max(d.length for d in dropped)} tokens)", file=sys.stderr, flush=True)
    bank = VideoBank(processor.video_config, processor.sensor_types)
    video_keys = [k for e in tokenized for k in e.videos]
    bar.stage("preprocessing videos", len(set(video_keys)), unit="clips")
    # with a disk cache the main process decodes every clip (and runs the frozen ViT) first; the others then read
    # its files instead of decoding the same clips at once
    shared_cache = accelerator.main_process_first() if config.data.video_cache else nullcontext()
    encoder = base.tactile_encoder
    with shared_cache:
        bank.build(video_keys, progress=lambda done, _total: bar.update(done), cache_dir=config.data.video_cache)
        raw = None
        if config.data.cache_appearance:
            bar.stage("frozen appearance branch", len(bank.index), unit="clips")
            raw = bank.cache_appearance(encoder, cache_dir=config.data.video_cache,
                                        progress=lambda done, _total: bar.update(done))
    if base.encoder_config.standardize_appearance and not encoder.appearance_measured:
        # the training clips' own statistics, before any step (no labels read); kept in the saved model
        raw = raw if raw is not None else bank.appearance_tokens(encoder, standardized=False)
        encoder.set_appearance_statistics(raw)
        if bank.appearance is not None:
            bank.appearance = encoder.standardize(raw)
    fitted: dict[str, Any] = {}
    if stage == 2 and model_heads(base):  # encoder frozen from here: fit the read-out heads, then freeze them
        bar.stage("fitting read-out heads", len(tokenized))
        tokenized, fitted = fit_heads_once(accelerator, base, processor, tokenized, bank, config.data.bench,
                                           config.seed, config.data.head_folds,
                                           progress=lambda done, _total: bar.update(done))
    tokenized = repeat_tasks(tokenized, config.data.repeat)
    # the comparator trains with the LLM's loss only in Stage I and only when asked (encoder.cross_video_loss):
    # only then do the batches carry its targets
    attributes = (base.encoder_config.cross_video_attributes
                  if stage == 1 and base.encoder_config.cross_video_loss > 0 else None)

    world = accelerator.num_processes
    pack = config.runtime.pack_sequences
    if pack is None:
        pack = accelerator.device.type == "cpu"
    micro_batch = settings.micro_batch(f"stage{stage}", world)
    global_batch = settings.examples_per_step(f"stage{stage}", world)
    lengths = [len(e.input_ids) for e in tokenized]
    optimizer = torch.optim.AdamW(_param_groups(trained, settings.lr, settings.projector_lr or settings.lr,
                                                settings.weight_decay), betas=(0.9, 0.999))
    scheduler = cosine_with_warmup(optimizer, round(settings.warmup_ratio * settings.steps), settings.steps,
                                   settings.min_lr_ratio)
    _configure_deepspeed(accelerator, settings, micro_batch)
    trained, optimizer = accelerator.prepare(trained, optimizer)
    start, elapsed_before = 0, 0.0
    if latest is not None:  # after prepare: the engine's own (sharded, partitioned) state is what gets restored
        start, elapsed_before = _resume(accelerator, config, stage, trained, optimizer, scheduler, latest)
    trained.train()

    run_info = {"stage": stage, "config": config.to_dict(), "examples": len(tokenized),
                "dropped_too_long": len(dropped), "dropped_by_task": left_out,
                "dropped_examples": [d.key for d in dropped[:20]], "videos": len(bank.index),
                "processes": world, "global_batch": global_batch, "engine": _engine_name(accelerator),
                "mixed_precision": accelerator.mixed_precision, "device": str(accelerator.device), "packed": pack,
                "threads": torch.get_num_threads(),
                "trainable_parameters": sum(p.numel() for p in base.parameters() if p.requires_grad),
                "total_parameters": sum(p.numel() for p in base.parameters())}
    run_info.update(fitted)
    if accelerator.is_main_process:
        out.mkdir(parents=True, exist_ok=True)
        write_json(out / RUN_FILE, run_info)
        if config.runtime.log_with != "none":
            accelerator.init_trackers(f"stage{stage}", config={k: v for k, v in _flat(config.to_dict()).items()
                                                              if isinstance(v, int | float | str | bool)})

    bar.stage(f"stage {stage} training", settings.steps, start, unit="steps")
    rank = accelerator.process_index

    def step(index: int) -> StepStats:
        indices = batch_plan(lengths, global_batch, index, config.seed, config.data.group_by_length,
                             config.data.length_group_batches)
        mine = indices[rank * micro_batch * settings.grad_accum:(rank + 1) * micro_batch * settings.grad_accum]
        micro = [mine[i:i + micro_batch] for i in range(0, len(mine), micro_batch)]
        # dropout and any other draw: a pure function of (seed, process, step), so ranks differ and a resumed run
        # draws what the uninterrupted one would
        torch.manual_seed(step_seed(config.seed, rank, index))
        global_tokens = sum(tokenized[i].n_labels for i in indices)
        step_loss = torch.zeros((), device=accelerator.device)
        for m, chunk in enumerate(micro):
            batch = _to_device(collate(processor, [tokenized[i] for i in chunk], bank, attributes), accelerator.device)
            sync = m == len(micro) - 1
            ctx = accelerator.no_sync(trained) if not sync and world > 1 else nullcontext()
            with ctx, accelerator.autocast():
                # the LM's loss is sum / num_items_in_batch; DDP then averages over processes, hence × world
                loss = trained(**batch, num_items_in_batch=global_tokens / world, loss_only=True, pack=pack).loss
                if loss_hook is not None:
                    loss = loss_hook(index, m, loss)
                _refuse_non_finite(accelerator, loss, stage, index, m, len(micro), [tokenized[i].key for i in chunk])
                accelerator.backward(loss)
            step_loss += loss.detach()
        accelerator.clip_grad_norm_(trained.parameters(), settings.max_grad_norm)
        optimizer.step()
        scheduler.step()
        optimizer.zero_grad(set_to_none=True)
        # mean token loss of the global batch: per-process partial sums added up
        return StepStats(float(accelerator.reduce(step_loss, reduction="sum")) / world,
                         tokens=sum(len(tokenized[i].input_ids) for i in indices), examples=len(indices))

    def record(entry: dict[str, Any]) -> None:
        if config.runtime.log_with != "none":
            accelerator.log({f"train/{k}": v for k, v in entry.items() if k != "step"}, step=entry["step"])
        if on_log is not None:
            on_log(entry)

    main = accelerator.is_main_process
    loop = StepLoop(settings.steps, start, config.runtime.log_every, config.runtime.checkpoint_every,
                    log=out / LOG_FILE if main else None, bar=bar, elapsed_before=elapsed_before,
                    describe=lambda: {"lr": scheduler.get_last_lr()[0], "projector_lr": scheduler.get_last_lr()[-1]})
    result = loop.run(step, on_record=record if main else None, stop_after=stop_after,
                      checkpoint=lambda done, loss, elapsed: _checkpoint(accelerator, config, stage, trained,
                                                                          optimizer, scheduler, done, loss, elapsed))
    if result.stopped:
        accelerator.wait_for_everyone()
        return StageResult(stage, out, result.done, result.last_loss, 0.0, len(tokenized), start)
    last_loss, train_seconds = result.last_loss, result.seconds
    accelerator.wait_for_everyone()
    materialize_sharded(accelerator.unwrap_model(trained))  # FSDP: every process gathers; the main one saves
    model_dir = out / MODEL_DIR
    if accelerator.is_main_process:
        processor.vocabulary = json.loads((Path(config.data.bench) / "bench.json").read_text()).get("vocabulary")
        _save(accelerator.unwrap_model(trained), processor, stage, out)
        run_info.update({"steps_done": settings.steps, "final_loss": last_loss,
                         "train_seconds": round(train_seconds, 1),
                         "total_seconds_this_call": round(time.perf_counter() - started, 1),
                         "resumed_from_step": start})
        write_json(out / RUN_FILE, run_info)
    accelerator.wait_for_everyone()
    return StageResult(stage, model_dir, settings.steps, last_loss, train_seconds, len(tokenized), start)


def _engine_name(accelerator: Any) -> str:
    """"fsdp2", "deepspeed-zero2", "multi_cpu", … : what the run trained under, for run.json."""
    kind = str(getattr(accelerator.distributed_type, "value", accelerator.distributed_type)).lower()
    if kind == "fsdp":
        return f"fsdp{accelerator.state.fsdp_plugin.fsdp_version}"
    if kind == "deepspeed":
        return f"deepspeed-zero{accelerator.state.deepspeed_plugin.zero_stage}"
    return kind


def _checkpoint(accelerator: Any, config: TrainConfig, stage: int, trained: Any, optimizer: Any, scheduler: Any,
                done: int, loss: float | None, train_seconds: float) -> None:
    """Every process: gather the trainable weights and optimizer state (or let DeepSpeed write its partitions); the
    main process writes them into one atomic checkpoint directory."""
    ckpt_dir = config.stage_dir(stage) / CHECKPOINTS
    staged = engine_saves_optimizer(accelerator)
    if staged:
        if accelerator.is_main_process:
            fresh_staging_dir(ckpt_dir, done)
        accelerator.wait_for_everyone()
        save_engine_state(accelerator, staging_dir(ckpt_dir, done))
        # every process has written its files (Accelerate's random_states_<rank>.pkl last) before the main one
        # renames the directory: a slower process otherwise finds it gone
        accelerator.wait_for_everyone()
    weights, optim_state = gather_trainable(accelerator, trained, optimizer)
    if accelerator.is_main_process:
        save_checkpoint(ckpt_dir, done, weights, optim_state, scheduler, keep=config.runtime.keep_checkpoints,
                        staged=staged, extra={"fingerprint": _fingerprint(config, stage, accelerator.num_processes),
                                              "loss": loss, "train_seconds": train_seconds})
    accelerator.wait_for_everyone()


def _resume(accelerator: Any, config: TrainConfig, stage: int, trained: Any, optimizer: Any, scheduler: Any,
            latest: Path) -> tuple[int, float]:
    """Restore a checkpoint into the prepared model and optimizer; returns its step and training seconds so far."""
    weights, state = load_checkpoint(latest, None, scheduler)
    saved = state.extra.get("fingerprint")
    now = _fingerprint(config, stage, accelerator.num_processes)
    if saved is not None and saved != now:
        changed = sorted(k for k in now if saved.get(k) != now[k])
        raise ValueError(f"{latest}: was made with different settings ({', '.join(changed)}); resume with the "
                         f"original config or choose another output_dir")
    optim_state = None if engine_saves_optimizer(accelerator) else load_optimizer_state(latest)
    restore_trainable(accelerator, trained, optimizer, weights, optim_state, latest)
    return state.step, float(state.extra.get("train_seconds", 0.0))


def master_weights_in_fp32(trained: torch.nn.Module, mixed_precision: str) -> int:
    """Every trainable parameter in fp32, whatever the frozen LLM's dtype: a bf16 weight (8 mantissa bits) drops
    an update smaller than 1/256 of itself, so at lr 2e-4 the temporal branch, fusion and projector would barely
    move. Compute stays 16-bit under Accelerate's autocast, which a 16-bit LLM therefore needs. Returns how many
    parameters were converted."""
    low = [p for p in trained.parameters() if p.requires_grad and p.dtype in (torch.bfloat16, torch.float16)]
    if low and mixed_precision == "no":
        raise ValueError(f"model.dtype is {low[0].dtype}, and its trainable parts keep fp32 master weights that "
                         f"need autocast: set runtime.mixed_precision: bf16 (or fp16), or model.dtype: float32")
    for p in low:
        p.data = p.data.float()
    return sum(p.numel() for p in low)


def _configure_deepspeed(accelerator: Any, settings: Any, micro_batch: int) -> None:
    """DeepSpeed reads the micro-batch size from a DataLoader, which this loop does not use: set it here.

    ``accelerator.backward`` steps a DeepSpeed engine after every micro-batch, so accumulation is refused, and the
    engine clips the gradients itself at ``max_grad_norm``; ZeRO-3
    partitions the parameters themselves, which the final save (merging LoRA into whole weights) does not gather.
    """
    plugin = getattr(accelerator.state, "deepspeed_plugin", None)
    if plugin is None:
        return
    if getattr(plugin, "zero_stage", 2) == 3:
        raise ValueError("DeepSpeed ZeRO-3 is not supported: the final save would merge partitioned weights. Use "
                         "ZeRO-2 (configs/accelerate/deepspeed-zero2-2gpu.yaml) or FSDP (fsdp-2gpu.yaml), which "
                         "also shards the frozen LLM")
    if settings.grad_accum != 1:
        raise ValueError("under DeepSpeed set grad_accum: 1 (raise batch_size or the number of processes instead)")
    plugin.deepspeed_config["train_micro_batch_size_per_gpu"] = micro_batch
    plugin.deepspeed_config["gradient_accumulation_steps"] = 1
    # the engine clips inside its step (Accelerate's clip_grad_norm_ does nothing under DeepSpeed)
    plugin.deepspeed_config["gradient_clipping"] = settings.max_grad_norm


def _save(trained: Any, processor: Any, stage: int, out: Path) -> None:
    from tacreasoner.model.build import save_model
    from tacreasoner.model.token_rows import merge_token_rows

    trained.eval()
    if stage == 1:
        merge_token_rows(trained.language_model)  # the new rows back into the matrices: a plain LLM on disk
        save_model(trained, processor, out / MODEL_DIR)
        return
    save_model(trained, processor, out / ADAPTER_DIR)  # the adapter (LoRA + projector) + the new tokens' rows
    merge_token_rows(trained.get_base_model().language_model)
    merged = trained.merge_and_unload()
    save_model(merged, processor, out / MODEL_DIR)


def _fingerprint(config: TrainConfig, stage: int, world: int) -> dict[str, Any]:
    """Settings that must not change between a checkpoint and its resumption."""
    d = config.to_dict()
    return {"stage": stage, "seed": config.seed, "model": d["model"], "data": d["data"],
            "stage_settings": d[f"stage{stage}"], "lora": d["lora"] if stage == 2 else None,
            "global_batch": config.stage(stage).examples_per_step(f"stage{stage}", world)}


def step_seed(seed: int, rank: int, step: int) -> int:
    """The torch seed of one process's step: distinct per process and per step, and reproducible on resume."""
    digest = hashlib.blake2b(f"{seed}/{rank}/{step}".encode(), digest_size=8).digest()
    return int.from_bytes(digest, "little") & (2**63 - 1)


def _non_finite_processes(accelerator: Any, loss: torch.Tensor) -> list[int]:
    """The processes whose loss is NaN or infinite, known to every process (one tiny all-gather with several)."""
    finite = bool(torch.isfinite(loss.detach()).all())
    if accelerator.num_processes == 1:
        return [] if finite else [0]
    flags = accelerator.gather(torch.tensor([0.0 if finite else 1.0], device=accelerator.device))
    return [i for i, flag in enumerate(flags.tolist()) if flag]


def _refuse_non_finite(accelerator: Any, loss: torch.Tensor, stage: int, step: int, micro: int, micros: int,
                       keys: list[str]) -> None:
    """Every process raises together when any loss is not finite: none is left waiting in the all-reduce."""
    bad = _non_finite_processes(accelerator, loss)
    if not bad:
        return
    mine_bad = accelerator.process_index in bad
    raise NonFiniteLossError(
        f"stage {stage}: the loss is not finite at step {step + 1} (micro-batch {micro + 1} of {micros}) on "
        f"process(es) {bad}"
        + (f"; here {loss.item()} on examples {keys[:8]}" if mine_bad else "; this process stops too")
        + f". Lower stage{stage}.lr, check the data of these examples, or use runtime.mixed_precision: no")


def _flat(d: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(_flat(v, f"{prefix}{k}."))
        else:
            out[f"{prefix}{k}"] = v
    return out


def enable_activation_checkpointing(language_model: torch.nn.Module) -> None:
    """Non-reentrant checkpointing under transformers' new name where it has one (5.24 deprecates the old)."""
    enable = getattr(language_model, "activation_checkpointing_enable", None)
    if enable is not None:
        enable(activation_checkpointing_kwargs={"use_reentrant": False})
    else:
        language_model.gradient_checkpointing_enable(gradient_checkpointing_kwargs={"use_reentrant": False})
