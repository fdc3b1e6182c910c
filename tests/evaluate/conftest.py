"""Shared by the evaluation tests: a small simulated benchmark and an untrained tiny model saved as `train` saves one
(built once per session)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tacreasoner.tasks.bench import load_bench
from tests.evaluate.evalsetup import save_untrained_model


@pytest.fixture(scope="session")
def bench(small_sim_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    from tacreasoner.tasks.bench import build_bench

    out = tmp_path_factory.mktemp("eval_bench") / "bench"
    build_bench("sim", small_sim_dataset, out, seed=0, heldout_sensor="digit")
    return out


@pytest.fixture(scope="session")
def model_dir(bench: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 2-layer Qwen2 with a BPE tokenizer of the bench's text behind a random tiny encoder: its answers are noise."""
    texts = [f"{i.question} {i.answer}" for i in load_bench(bench, "train")[1]]
    return save_untrained_model(texts, tmp_path_factory.mktemp("eval_model"))
