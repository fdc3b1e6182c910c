"""Trainable weights and optimizer state in and out of a prepared model, whatever engine Accelerate chose.

A checkpoint holds the *trainable* weights (LoRA, projector, encoder parts, new token rows: megabytes, not the frozen
LLM's gigabytes) as one full, unsharded safetensors file, so a run can resume on another number of processes.

- One process, DDP and FSDP (1 and 2): ``torch.distributed.checkpoint.state_dict`` gathers full trainable weights
  and the optimizer state keyed by parameter name (``ignore_frozen_params``), and puts them back after
  ``accelerator.prepare``, re-sharding under FSDP. Accelerate's own ``save_state`` would write FSDP's full state as a
  pickle holding the frozen LLM as well.
- DeepSpeed: the engine owns the (partitioned) optimizer, so its state goes through Accelerate's ``save_state`` /
  ``load_state`` (DeepSpeed's ``save_checkpoint`` with ``exclude_frozen_parameters``), into ``engine/`` of the same
  atomic checkpoint directory.

Every function here is collective: every process calls it, in the same order.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import torch

__all__ = ["ENGINE_DIR", "engine_saves_optimizer", "gather_trainable", "materialize_sharded", "restore_trainable",
           "save_engine_state"]

ENGINE_DIR = "engine"


def _full_options(**more: Any) -> Any:
    from torch.distributed.checkpoint.state_dict import StateDictOptions

    return StateDictOptions(full_state_dict=True, cpu_offload=True, ignore_frozen_params=True, **more)


def engine_saves_optimizer(accelerator: Any) -> bool:
    """DeepSpeed: its engine holds the optimizer state (partitioned over processes under ZeRO)."""
    return getattr(accelerator.state, "deepspeed_plugin", None) is not None


def gather_trainable(accelerator: Any, trained: torch.nn.Module, optimizer: Any,
                     ) -> tuple[dict[str, torch.Tensor], dict[str, Any] | None]:
    """Full trainable weights (by name) and, except under DeepSpeed, the optimizer state keyed by name."""
    # one name per parameter: a tied LLM's row table (input and output) is saved once, as safetensors requires
    trainable = {n: p for n, p in accelerator.unwrap_model(trained).named_parameters() if p.requires_grad}
    if engine_saves_optimizer(accelerator):  # ZeRO-1/2 keep every parameter whole on every process (ZeRO-3 refused)
        return {n: p.detach().cpu().clone() for n, p in trainable.items()}, None
    from torch.distributed.checkpoint.state_dict import get_state_dict

    weights, optim = get_state_dict(_inner(trained), _inner_optimizer(optimizer), options=_full_options())
    return {k: v for k, v in weights.items() if k in trainable}, optim  # not the fitted buffers: the config refits them


def restore_trainable(accelerator: Any, trained: torch.nn.Module, optimizer: Any, weights: dict[str, torch.Tensor],
                      optim_state: dict[str, Any] | None, checkpoint: Path) -> None:
    """Put a checkpoint's trainable weights and optimizer state into the prepared model and optimizer."""
    if engine_saves_optimizer(accelerator):
        engine = checkpoint / ENGINE_DIR
        if not engine.is_dir():
            raise ValueError(f"{checkpoint}: no {ENGINE_DIR}/ (not written under DeepSpeed): resume it with the engine "
                             f"that wrote it")
        accelerator.load_state(str(engine), load_module_strict=False)
        return
    if optim_state is None:
        raise ValueError(f"{checkpoint}: no optimizer state (written under DeepSpeed): resume it under DeepSpeed")
    from torch.distributed.checkpoint.state_dict import set_state_dict

    model = _inner(trained)
    missing = {n for n, p in model.named_parameters() if p.requires_grad} - set(weights)
    if missing:
        raise ValueError(f"{checkpoint}: lacks trainable weights {sorted(missing)[:5]}")
    set_state_dict(model, _inner_optimizer(optimizer), model_state_dict=weights, optim_state_dict=optim_state,
                   options=_full_options(strict=False))


def save_engine_state(accelerator: Any, staging: Path) -> None:
    """DeepSpeed's own files (optimizer partitions, its step), from every process, into the staging directory."""
    if engine_saves_optimizer(accelerator):
        accelerator.save_state(str(staging / ENGINE_DIR), exclude_frozen_parameters=True)


def materialize_sharded(module: torch.nn.Module) -> int:
    """Replace every FSDP2-sharded parameter (a DTensor) by its full tensor, in place, so the main process can merge
    and save the model as a plain one. Collective (one all-gather per sharded parameter, in module order); run it
    once training is over. Returns how many parameters were gathered."""
    from torch.distributed.tensor import DTensor

    gathered = 0
    for sub in module.modules():
        for name, param in list(sub._parameters.items()):
            if isinstance(param, DTensor):
                sub._parameters[name] = torch.nn.Parameter(param.full_tensor(), requires_grad=param.requires_grad)
                gathered += 1
    return gathered


def _inner(trained: torch.nn.Module) -> torch.nn.Module:
    """The model inside DDP's wrapper (FSDP2 shards in place and keeps the module)."""
    return trained.module if isinstance(trained, torch.nn.parallel.DistributedDataParallel) else trained


def _inner_optimizer(optimizer: Any) -> torch.optim.Optimizer:
    """The torch optimizer inside Accelerate's wrapper."""
    return getattr(optimizer, "optimizer", optimizer)
