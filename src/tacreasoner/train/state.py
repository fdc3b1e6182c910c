"""What every training loop shares: seeding, a warmup + cosine schedule and atomic, resumable checkpoints.

Checkpoints are a directory ``step-<n>/`` with ``model.safetensors`` (trainable weights), ``optimizer.pt``
and ``scheduler.pt`` (tensors and plain containers, read back with ``weights_only=True``: nothing is
unpickled) and ``state.json``. A directory is written under a temporary name and renamed, so a crash
never leaves a half-written checkpoint that ``--resume`` would pick up.
"""

from __future__ import annotations

import json
import math
import os
import random
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from safetensors.torch import load_file, save_file

__all__ = ["TrainingState", "cosine_with_warmup", "fresh_staging_dir", "latest_checkpoint", "load_checkpoint",
           "load_optimizer_state", "save_checkpoint", "seed_everything", "staging_dir", "truncate_log", "write_json"]

CHECKPOINT_PREFIX = "step-"


def seed_everything(seed: int) -> None:
    random.seed(seed)
    np.random.seed(seed % 2**32)
    torch.manual_seed(seed)


def cosine_with_warmup(optimizer: torch.optim.Optimizer, warmup_steps: int, total_steps: int,
                       min_ratio: float = 0.1) -> torch.optim.lr_scheduler.LambdaLR:
    """Linear warmup to each group's LR, then cosine decay to ``min_ratio`` of it at ``total_steps``."""
    warmup_steps, total_steps = max(0, int(warmup_steps)), max(1, int(total_steps))

    def factor(step: int) -> float:
        if step < warmup_steps:
            return (step + 1) / warmup_steps
        progress = min(1.0, (step - warmup_steps) / max(1, total_steps - warmup_steps))
        return min_ratio + (1 - min_ratio) * 0.5 * (1 + math.cos(math.pi * progress))

    return torch.optim.lr_scheduler.LambdaLR(optimizer, factor)


@dataclass
class TrainingState:
    step: int
    extra: dict[str, Any]


def _rng_state() -> dict[str, Any]:
    return {"torch": torch.get_rng_state(), "numpy": np.random.get_state(), "python": random.getstate()}


def staging_dir(run_dir: str | os.PathLike[str], step: int) -> Path:
    """Where checkpoint ``step`` is written before its rename: one name every process of a run can compute, so an
    engine that writes from every process (DeepSpeed) can fill it first."""
    return Path(run_dir) / f".tmp-{CHECKPOINT_PREFIX}{step:08d}"


def fresh_staging_dir(run_dir: str | os.PathLike[str], step: int) -> Path:
    """:func:`staging_dir`, emptied of any earlier attempt and created."""
    tmp = staging_dir(run_dir, step)
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True)
    return tmp


def save_checkpoint(run_dir: str | os.PathLike[str], step: int, weights: dict[str, torch.Tensor],
                    optimizer: torch.optim.Optimizer | dict[str, Any] | None, scheduler: Any | None = None, *,
                    extra: dict[str, Any] | None = None, keep: int = 2, staged: bool = False) -> Path:
    """Write ``run_dir/step-<step>`` atomically and keep only the newest ``keep`` checkpoints.

    ``optimizer``: the optimizer or its (gathered) state dict; None where an engine saved its own. ``staged``: files
    already written into :func:`staging_dir` by every process are kept (else it starts empty)."""
    run_dir = Path(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    final = run_dir / f"{CHECKPOINT_PREFIX}{step:08d}"
    tmp = staging_dir(run_dir, step) if staged else fresh_staging_dir(run_dir, step)
    save_file({k: v.detach().contiguous().cpu() for k, v in weights.items()}, str(tmp / "model.safetensors"))
    if optimizer is not None:
        state = optimizer if isinstance(optimizer, dict) else optimizer.state_dict()
        torch.save(state, tmp / "optimizer.pt")
    if scheduler is not None:
        torch.save(scheduler.state_dict(), tmp / "scheduler.pt")
    rng = _rng_state()
    torch.save({"torch": rng["torch"], "numpy": [rng["numpy"][0], torch.from_numpy(rng["numpy"][1].copy()),
                                                  *rng["numpy"][2:]], "python": rng["python"]}, tmp / "rng.pt")
    (tmp / "state.json").write_text(json.dumps({"step": step, "extra": extra or {}}, indent=2), encoding="utf-8")
    if final.exists():
        shutil.rmtree(final)
    os.replace(tmp, final)
    for old in sorted(run_dir.glob(f"{CHECKPOINT_PREFIX}*"))[:-keep] if keep > 0 else []:
        shutil.rmtree(old, ignore_errors=True)
    return final


def latest_checkpoint(run_dir: str | os.PathLike[str]) -> Path | None:
    """The newest complete checkpoint in ``run_dir`` (None when there is none)."""
    found = sorted(p for p in Path(run_dir).glob(f"{CHECKPOINT_PREFIX}*") if (p / "state.json").is_file())
    return found[-1] if found else None


def load_checkpoint(path: str | os.PathLike[str], optimizer: torch.optim.Optimizer | None = None,
                    scheduler: Any | None = None) -> tuple[dict[str, torch.Tensor], TrainingState]:
    """Weights of a checkpoint plus its step; restores optimizer, scheduler and RNG state in place."""
    path = Path(path)
    try:
        meta = json.loads((path / "state.json").read_text(encoding="utf-8"))
        weights = load_file(str(path / "model.safetensors"))
    except Exception as exc:  # safetensors raises its own error type for a corrupt file
        raise ValueError(f"checkpoint {path}: cannot be read ({exc})") from exc
    if optimizer is not None:
        optimizer.load_state_dict(load_optimizer_state(path))
    if scheduler is not None and (path / "scheduler.pt").is_file():
        scheduler.load_state_dict(torch.load(path / "scheduler.pt", weights_only=True))
    if (path / "rng.pt").is_file():
        rng = torch.load(path / "rng.pt", weights_only=True)
        torch.set_rng_state(rng["torch"])
        np_state = rng["numpy"]
        np.random.set_state((np_state[0], np_state[1].numpy(), *np_state[2:]))
        random.setstate(_as_tuple(rng["python"]))
    return weights, TrainingState(step=int(meta["step"]), extra=meta.get("extra", {}))


def load_optimizer_state(path: str | os.PathLike[str]) -> dict[str, Any]:
    """A checkpoint's optimizer state dict (tensors and plain containers only: nothing is unpickled)."""
    file = Path(path) / "optimizer.pt"
    if not file.is_file():
        raise ValueError(f"checkpoint {path}: no optimizer.pt (written by another engine, or incomplete)")
    return torch.load(file, weights_only=True)


def _as_tuple(state: Any) -> Any:
    """``random.setstate`` wants tuples; torch's safe loader may hand lists back."""
    if isinstance(state, list):
        return tuple(_as_tuple(s) for s in state)
    return state


def write_json(path: Path, data: dict[str, Any]) -> None:
    """Write a JSON file atomically (a reader never sees half of it)."""
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, indent=2, default=str) + "\n", encoding="utf-8")
    tmp.replace(path)


def truncate_log(path: Path, step: int) -> None:
    """Drop JSONL log records after the checkpoint being resumed (they are about to be redone)."""
    if not path.is_file():
        return
    kept = [line for line in path.read_text(encoding="utf-8").splitlines()
            if line.strip() and json.loads(line).get("step", 0) <= step]
    path.write_text("".join(line + "\n" for line in kept), encoding="utf-8")
