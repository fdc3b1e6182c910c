"""Stage I then II as the recipes run them: a finished stage is not redone, and over two processes the global batch
stays the one of a single process."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tacreasoner.train.run import distributed_config, stage_done, train_stages
from tests.train.trainsetup import tiny_config, training_inputs


@pytest.fixture(scope="module")
def inputs(small_sim_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> dict:
    return training_inputs(small_sim_dataset, tmp_path_factory)


def test_distributed_config_keeps_the_global_batch_and_refuses_an_uneven_split(inputs: dict, tmp_path: Path) -> None:
    config = tiny_config(inputs, tmp_path / "run", stage2={"batch_size": 4})
    split = distributed_config(config, 2, 2)
    assert split.stage2.global_batch == config.stage2.batch_size * config.stage2.grad_accum
    assert split.stage2.micro_batch("stage2", 2) * 2 == config.stage2.batch_size
    assert split.stage1 == config.stage1 and split.runtime.threads == 1
    with pytest.raises(ValueError, match=r"does not split into 3 process\(es\)"):
        distributed_config(config, 2, 3)


def test_train_stages_over_two_processes_trains_with_the_same_global_batch(inputs: dict, tmp_path: Path) -> None:
    config = tiny_config(inputs, tmp_path / "run", stage1={"skip": True})
    assert not stage_done(config, 2)
    info = train_stages(config, processes=2)
    run = json.loads((tmp_path / "run" / "stage2" / "run.json").read_text())
    assert run["processes"] == 2 and run["global_batch"] == config.stage2.batch_size
    assert run["steps_done"] == config.stage2.steps and stage_done(config, 2)
    assert Path(info["model"]).is_dir() and "stage2" in info["seconds"]
    assert train_stages(config, processes=2)["seconds"] == {}  # done: not redone


def test_train_stages_refuses_zero_processes(inputs: dict, tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="processes must be at least 1"):
        train_stages(tiny_config(inputs, tmp_path / "run"), processes=0)
