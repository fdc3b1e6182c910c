"""Stage I then Stage II of one config, as the recipes run them: each stage skipped when finished, resumed when
interrupted, optionally as CPU DDP over several processes with the same global batch."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from typing import Any

import yaml

from tacreasoner.train.config import TrainConfig

__all__ = ["distributed_config", "stage_done", "train_stages"]


def stage_done(config: TrainConfig, stage: int) -> bool:
    """The stage's run.json records its finished steps (written last)."""
    run = config.stage_dir(stage) / "run.json"
    return run.is_file() and "steps_done" in json.loads(run.read_text(encoding="utf-8"))


def train_stages(config: TrainConfig, processes: int = 1) -> dict[str, Any]:
    """Stage I then Stage II of ``config``; returns the final model's folder and the seconds each stage took now.

    ``processes > 1`` runs each stage under ``torch.distributed.run`` with the same global batch: for CPUs with more
    cores than one process's threads use well (on 2 cores it gains nothing, docs/training.md).
    """
    from tacreasoner.train.trainer import MODEL_DIR, train_stage

    if processes < 1:
        raise ValueError(f"processes must be at least 1, got {processes}")
    seconds: dict[str, float] = {}
    for stage in (1, 2):
        if config.stage(stage).skip or stage_done(config, stage):
            continue
        start = time.perf_counter()
        if processes > 1:
            _train_stage_distributed(config, stage, processes)
        else:
            train_stage(config, stage, resume=True)
        seconds[f"stage{stage}"] = round(time.perf_counter() - start, 1)
    final = 2 if not config.stage2.skip else 1
    return {"model": str(config.stage_dir(final) / MODEL_DIR), "seconds": seconds}


def distributed_config(config: TrainConfig, stage: int, processes: int) -> TrainConfig:
    """``config`` split over ``processes`` ranks: the same global batch, one thread each."""
    settings = config.stage(stage)
    data = config.to_dict()
    data[f"stage{stage}"]["global_batch"] = settings.global_batch or settings.batch_size * settings.grad_accum
    data["runtime"]["threads"] = 1
    split = TrainConfig.from_dict(data, source=f"{config.output_dir} over {processes} processes")
    split.stage(stage).micro_batch(f"stage{stage}", processes)  # refuses a batch that does not split evenly
    return split


def _train_stage_distributed(config: TrainConfig, stage: int, processes: int) -> None:
    split = distributed_config(config, stage, processes)
    launch = config.stage_dir(stage).with_name(f"stage{stage}.launch.yaml")
    launch.parent.mkdir(parents=True, exist_ok=True)
    launch.write_text(yaml.safe_dump(split.to_dict(), sort_keys=False), encoding="utf-8")
    # --standalone: a local rendezvous on a free port, so no port is chosen (or raced for) here
    cmd = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node", str(processes),
           "-m", "tacreasoner", "train", "--stage", str(stage), "--config", str(launch), "--resume"]
    env = {**os.environ, "OMP_NUM_THREADS": "1", "TOKENIZERS_PARALLELISM": "false"}
    done = subprocess.run(cmd, env=env)
    if done.returncode != 0:
        raise RuntimeError(f"stage {stage} over {processes} processes failed (exit code {done.returncode}); "
                           f"its output is above. Re-run to resume, or use --processes 1")
