"""One process of the 2-process CPU DDP test (``test_ddp.py``), started by ``torch.distributed.run``.

    python -m torch.distributed.run --nproc_per_node 2 tests/train/ddp_worker.py CONFIG.json OUT_DIR [STAGE]

Reads a ``TrainConfig.to_dict()`` JSON, runs ``train_stage(config, STAGE)`` (default 2) and writes this process's final
trainable parameters to ``OUT_DIR/rank{RANK}.safetensors`` (and its last torch seed to ``rank{RANK}.json``);
``POISON=RANK:STEP`` makes that process's loss NaN at that step; ``COMPARATOR_FIT_STEPS=N`` fits the comparator
with N AdamW steps (``trainsetup.fewer_comparator_fit_steps``); ``STOP_AFTER=N`` ends the run after N steps without
the final save (a killed run), ``RESUME=1`` resumes it; ``ENGINE=fsdp`` trains under FSDP2 (see
:func:`fsdp_on_the_cpu`), ``ENGINE=deepspeed`` under DeepSpeed ZeRO-2 (see :func:`deepspeed_on_the_cpu`). The
trainer saves on the main process only, so the weights are caught with :func:`capture_trainable_weights` (also used
by the test for its 1-process reference run, so both sides are captured the same way).
"""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager, nullcontext
from pathlib import Path
from typing import Any

import torch


def _snapshot(module: torch.nn.Module) -> dict[str, torch.Tensor]:
    return {name: p.detach().clone().contiguous() for name, p in module.named_parameters() if p.requires_grad}


@contextmanager
def capture_trainable_weights() -> Iterator[dict[str, torch.Tensor]]:
    """Yield a dict that holds this process's final trainable parameters once the ``with`` block ends.

    ``model.stages.configure_stage`` is wrapped to keep the module it returns (the very parameters that
    the optimizer and DDP update). On the main process the trainer's ``_save`` merges the LoRA weights
    into the base model in place, so the weights are copied just before it runs; on the other
    processes, after training returns.
    """
    from tacreasoner.model import stages
    from tacreasoner.train import trainer

    weights: dict[str, torch.Tensor] = {}
    modules: list[torch.nn.Module] = []
    configure, save = stages.configure_stage, trainer._save

    def configure_and_keep(*args: Any, **kwargs: Any) -> torch.nn.Module:
        module = configure(*args, **kwargs)
        modules.append(module)
        return module

    def snapshot_then_save(trained: torch.nn.Module, *args: Any, **kwargs: Any) -> None:
        weights.update(_snapshot(trained))
        save(trained, *args, **kwargs)

    stages.configure_stage, trainer._save = configure_and_keep, snapshot_then_save
    try:
        yield weights
    finally:
        stages.configure_stage, trainer._save = configure, save
    if not weights:
        if len(modules) != 1:
            raise RuntimeError(f"expected one configure_stage call during training, saw {len(modules)}")
        weights.update(_snapshot(modules[0]))


@contextmanager
def fsdp_on_the_cpu() -> Iterator[None]:
    """Make the trainer's Accelerator shard with FSDP2 over gloo.

    Accelerate 1.15 sets up FSDP only on accelerators (a CPU launch becomes MULTI_CPU DDP), although FSDP2 itself
    shards, all-gathers and reduce-scatters over gloo; so the engine is switched after the Accelerator is made,
    as ``accelerate launch --use_fsdp`` would have set it on GPUs: one FSDP unit per decoder layer."""
    from accelerate import PartialState
    from accelerate.utils import DistributedType, FullyShardedDataParallelPlugin

    from tacreasoner.train import trainer

    make = trainer.make_accelerator

    def make_fsdp(*args: Any, **kwargs: Any) -> Any:
        accelerator = make(*args, **kwargs)
        plugin = FullyShardedDataParallelPlugin(fsdp_version=2, auto_wrap_policy="transformer_based_wrap",
                                                transformer_cls_names_to_wrap=["Qwen2DecoderLayer"])
        accelerator.state.distributed_type = DistributedType.FSDP
        accelerator.state.fsdp_plugin = plugin
        PartialState._shared_state["distributed_type"] = DistributedType.FSDP  # as AcceleratorState does on GPUs
        return accelerator

    trainer.make_accelerator = make_fsdp
    try:
        yield
    finally:
        trainer.make_accelerator = make


def deepspeed_on_the_cpu() -> None:
    """DeepSpeed ZeRO-2 as ``accelerate launch --use_deepspeed --zero_stage 2`` sets it up, on DeepSpeed's CPU
    accelerator over gloo (the trainer asks for gloo itself when there is no GPU). DeepSpeed would first compile a
    shared-memory all-reduce (~100 s on 2 cores) that gloo does not need: skipped."""
    import importlib

    os.environ.update({"ACCELERATE_USE_DEEPSPEED": "true", "ACCELERATE_DEEPSPEED_ZERO_STAGE": "2",
                       "DS_ACCELERATOR": "cpu"})
    importlib.import_module("deepspeed.comm.torch")
    sys.modules["deepspeed.comm.torch"].build_shm_op = lambda: None  # `deepspeed.comm` re-exports torch as .torch


def main(config_json: str, out_dir: str, stage: str = "2") -> None:
    from safetensors.torch import save_file

    from tacreasoner.train.config import TrainConfig
    from tacreasoner.train.trainer import train_stage

    config = TrainConfig.from_dict(json.loads(Path(config_json).read_text(encoding="utf-8")))
    rank = int(os.environ.get("RANK", "0"))
    hook = None
    if os.environ.get("POISON"):  # "RANK:STEP": that process's loss becomes NaN at that (1-based) step
        bad_rank, bad_step = (int(x) for x in os.environ["POISON"].split(":"))

        def hook(step: int, _micro: int, loss: torch.Tensor) -> torch.Tensor:
            return loss * float("nan") if (rank, step + 1) == (bad_rank, bad_step) else loss

    from tacreasoner.train import heads

    fits, fit = [], heads.fit_heads  # which processes fit the read-out heads (the main one only)
    heads.fit_heads = lambda *args, **kwargs: fits.append(1) or fit(*args, **kwargs)
    if os.environ.get("COMPARATOR_FIT_STEPS"):
        sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the checkout: tests.train is importable
        from tests.train.trainsetup import fewer_comparator_fit_steps

        fewer_comparator_fit_steps(int(os.environ["COMPARATOR_FIT_STEPS"]))
    stop_after = int(os.environ["STOP_AFTER"]) if os.environ.get("STOP_AFTER") else None
    if os.environ.get("ENGINE") == "deepspeed":
        deepspeed_on_the_cpu()
    engine = fsdp_on_the_cpu() if os.environ.get("ENGINE") == "fsdp" else nullcontext()
    with engine, capture_trainable_weights() as weights:
        result = train_stage(config, int(stage), loss_hook=hook, stop_after=stop_after,
                             resume=os.environ.get("RESUME") == "1")
    if stop_after is not None:  # stopped before the final gather: under FSDP each process holds only shards
        weights = {}
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    save_file(weights, str(out / f"rank{rank}.safetensors"))
    (out / f"rank{rank}.json").write_text(json.dumps({"final_loss": result.final_loss, "steps": result.steps,
                                                      "world_size": int(os.environ.get("WORLD_SIZE", "1")),
                                                      "torch_seed": torch.initial_seed(),
                                                      "fit_heads_calls": len(fits)}))


if __name__ == "__main__":
    if len(sys.argv) not in (3, 4):
        raise SystemExit(f"usage: {sys.argv[0]} CONFIG.json OUT_DIR [STAGE]")
    main(*sys.argv[1:])
