"""One process of the 2-process CPU DDP test (``test_ddp.py``), started by ``torch.distributed.run``.

    python -m torch.distributed.run --nproc_per_node 2 tests/train/ddp_worker.py CONFIG.json OUT_DIR [STAGE]

Reads a ``TrainConfig.to_dict()`` JSON, runs ``train_stage(config, STAGE)`` (default 2) and writes this process's final
trainable parameters to ``OUT_DIR/rank{RANK}.safetensors`` (and its last torch seed to ``rank{RANK}.json``);
``POISON=RANK:STEP`` makes that process's loss NaN at that step. The trainer saves on the main process
only, so the weights are caught with :func:`capture_trainable_weights` (also used by the test for its
1-process reference run, so both sides are captured the same way).
"""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
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

    with capture_trainable_weights() as weights:
        result = train_stage(config, int(stage), loss_hook=hook)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    save_file(weights, str(out / f"rank{rank}.safetensors"))
    (out / f"rank{rank}.json").write_text(json.dumps({"final_loss": result.final_loss, "steps": result.steps,
                                                      "world_size": int(os.environ.get("WORLD_SIZE", "1")),
                                                      "torch_seed": torch.initial_seed()}))


if __name__ == "__main__":
    if len(sys.argv) not in (3, 4):
        raise SystemExit(f"usage: {sys.argv[0]} CONFIG.json OUT_DIR [STAGE]")
    main(*sys.argv[1:])
