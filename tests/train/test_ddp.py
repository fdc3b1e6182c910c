"""Two-process CPU DDP (gloo, via torch.distributed.run): the ranks stay identical, and 2 processes ×
batch 2 take the same optimizer steps as 1 process × batch 4, since the loss is normalised by the
global number of answer tokens."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pytest
import torch
from safetensors.torch import load_file

from tacreasoner.train.trainer import train_stage
from tests.train.ddp_worker import capture_trainable_weights
from tests.train.trainsetup import (
    COMPARATOR_FIT_STEPS,
    llm_with_new_rows,
    tiny_config,
    training_inputs,
    training_prompt_logits,
)

WORKER = Path(__file__).with_name("ddp_worker.py")
# torchrun itself (its own argument parsing and elastic agent), started from a fresh interpreter that imports the
# trainer first and then forks its two workers (`--run-path --start-method fork`): each launch then imports torch,
# transformers and the package once instead of three times (torchrun, then each worker: ~11 of a launch's ~17 s on 2
# cores). Every launch is still a new process group of new processes; the resumed one reads only the checkpoint.
PRELOAD_THEN_TORCHRUN = ("import sys\nimport tacreasoner.train.trainer\nfrom torch.distributed.run import main\n"
                         "main(sys.argv[1:])")
TIMEOUT_S = 600  # a bound for hangs; a launch takes ~12–17 s alone, 300+ on 2 cores shared with other jobs
STEPS = 3


@pytest.fixture(scope="module")
def inputs(small_sim_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return training_inputs(small_sim_dataset, tmp_path_factory)


def _launch_two_processes(config_json: Path, weights_dir: Path, port: int, stage: int = 2, *, poison: str = "",
                          **env_more: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "OMP_NUM_THREADS": "1", "TOKENIZERS_PARALLELISM": "false", "POISON": poison, **env_more}
    # a poisoned run shows that each process stops by itself, so it starts its workers as plain torchrun does: forked
    # from the preloaded interpreter, the healthy worker was ended before it printed its own stop (tried 2026-12-01)
    launcher = (["-m", "torch.distributed.run"] if poison else
                ["-c", PRELOAD_THEN_TORCHRUN, "--run-path", "--start-method", "fork"])
    cmd = [sys.executable, *launcher, "--nproc_per_node", "2", "--master_addr", "127.0.0.1", "--master_port",
           str(port), str(WORKER), str(config_json), str(weights_dir), str(stage)]
    try:
        done = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired as exc:
        stderr = exc.stderr.decode(errors="replace") if isinstance(exc.stderr, bytes) else exc.stderr or ""
        pytest.fail(f"torch.distributed.run did not finish in {TIMEOUT_S} s; stderr tail:\n{stderr[-4000:]}")
    if not poison:
        assert done.returncode == 0, f"torch.distributed.run exited {done.returncode}; stderr:\n{done.stderr[-4000:]}"
    return done


def test_the_defaults_prompt_dependent_parts_train_under_ddp_in_both_stages(inputs, tmp_path, free_port) -> None:
    """The tiny default's cross-video layer (its name matcher and assignment vectors speak only in OSC prompts
    once fitted) and clip reader (one-video prompts only) leave parameters without a gradient in some batches,
    which plain DDP refuses ("Expected to have finished reduction in the prior iteration")."""
    from tests.train.trainsetup import ENCODER

    encoder = {**ENCODER, "cross_video": 3, "cross_video_names": True, "clip_reader": True}
    batch = {"steps": STEPS, "global_batch": 4}
    config = tiny_config(inputs, tmp_path / "run", model={"encoder": encoder}, stage1=batch,
                         data={"video_cache": str(tmp_path / "video_cache")},  # decoded once, not per process
                         stage2=batch, lora={"r": 8, "alpha": 16, "dropout": 0.0},
                         runtime={"threads": 1, "log_with": "none", "progress": False, "mixed_precision": "no"})
    (tmp_path / "run").mkdir()
    config_json = tmp_path / "run" / "config.json"
    config_json.write_text(json.dumps(config.to_dict()))
    for stage in (1, 2):  # one launch per stage, as `accelerate launch tacreasoner train --stage N` runs them
        _launch_two_processes(config_json, tmp_path / f"weights{stage}", free_port(), stage,
                              COMPARATOR_FIT_STEPS=str(COMPARATOR_FIT_STEPS))  # where it is fitted, not how well

    for stage in (1, 2):
        info = json.loads((tmp_path / "run" / f"stage{stage}" / "run.json").read_text())
        assert info["processes"] == 2, info
        assert (tmp_path / "run" / f"stage{stage}" / "model").is_dir(), f"Stage {stage} saved no model"
        infos = [json.loads((tmp_path / f"weights{stage}" / f"rank{r}.json").read_text()) for r in (0, 1)]
        assert [i["steps"] for i in infos] == [STEPS, STEPS]
        rank0 = load_file(str(tmp_path / f"weights{stage}" / "rank0.safetensors"))
        rank1 = load_file(str(tmp_path / f"weights{stage}" / "rank1.safetensors"))
        assert any("cross_video" in n for n in rank0)
        for name in rank0:
            assert torch.equal(rank0[name], rank1[name]), f"Stage {stage}: {name} differs between the ranks"
    assert json.loads((tmp_path / "run" / "stage2" / "run.json").read_text())["clip_reader"]
    # the heads were fitted once, on the main process, and sent to the other (whose weights equal it above)
    assert [i["fit_heads_calls"] for i in infos] == [1, 0]
    assert any("clip_reader" in n for n in rank0)  # Stage II trains the reader's level vectors


def _final_trainable(run: Path, stage: int) -> dict[str, torch.Tensor]:
    """The trainable weights the trainer checkpointed at the last step (gathered whole by every engine)."""
    return load_file(str(sorted((run / f"stage{stage}" / "checkpoints").glob("step-*"))[-1] / "model.safetensors"))


def _saved_logits(model_dir: Path, inputs: dict[str, Path]) -> torch.Tensor:
    from tacreasoner.model.build import load_model

    return training_prompt_logits(*load_model(model_dir), inputs)


@contextmanager
def _in_memory_logits(inputs: dict[str, Path]) -> Iterator[list[torch.Tensor]]:
    """The logits of the trained model as the trainer holds it, just before it saves it."""
    from tacreasoner.train import trainer

    found: list[torch.Tensor] = []
    save = trainer._save

    def logits_then_save(trained: Any, processor: Any, *args: Any) -> None:
        found.append(training_prompt_logits(trained, processor, inputs))
        save(trained, processor, *args)

    trainer._save = logits_then_save
    try:
        yield found
    finally:
        trainer._save = save


def _check_the_ranks_stayed_identical(weights: Path, stage: int, single: dict[str, torch.Tensor],
                                      single_loss: float) -> None:
    """The resumed DDP processes' final trainable weights (``weights``: the worker's OUT_DIR) equal each other and
    those of one process with the same global batch (``single``, its final loss ``single_loss``)."""
    rank0 = load_file(str(weights / "rank0.safetensors"))
    rank1 = load_file(str(weights / "rank1.safetensors"))
    infos = [json.loads((weights / f"rank{r}.json").read_text()) for r in (0, 1)]
    assert [i["world_size"] for i in infos] == [2, 2] and infos[0]["final_loss"] == infos[1]["final_loss"]
    assert infos[0]["torch_seed"] != infos[1]["torch_seed"], "both processes drew from one seed (dropout alike)"
    assert rank0.keys() == rank1.keys() == single.keys()
    if stage == 2:
        assert any("lora_A" in n for n in rank0) and any("projector" in n for n in rank0)
        assert any(rank0[n].abs().sum() > 0 for n in rank0 if "lora_B" in n), "LoRA B is still zero: nothing trained"
    for name in rank0:
        assert torch.equal(rank0[name], rank1[name]), f"{name} differs between the ranks"
        torch.testing.assert_close(rank0[name], single[name], rtol=1e-4, atol=1e-5, msg=name)
    assert infos[0]["final_loss"] == pytest.approx(single_loss, abs=1e-5)


@pytest.mark.parametrize(("engine", "stage"), [("ddp", 2), ("ddp", 1), ("fsdp", 2), ("fsdp", 1), ("deepspeed", 2)])
def test_a_killed_two_process_run_resumes_to_the_one_process_result_and_saves_a_model_that_answers_alike(
        engine: str, stage: int, inputs, tmp_path, free_port) -> None:
    """2 processes stop after 2 of 4 steps (no final save; under DDP in Stage II because one process's loss is not
    finite at step 3, which stops both promptly), resume from the checkpoint under the same engine and end where 1
    uninterrupted process with the same global batch ends: the checkpointed trainable weights (FSDP gathers its
    shards into them) and the loss log; both saved models, reloaded, answer as the one-process model did in memory
    before its save. Under DDP the two processes also stay identical: same gradients (all-reduced), same updates,
    though each draws from its own seed; 2 processes × batch 2 take the optimizer steps of 1 process × batch 4, since
    the loss is normalised by the global number of answer tokens."""
    steps = 4
    # FSDP: Stage I untied (as Qwen2.5-7B), Stage II tied (as SmolLM2; refused until its rows were PEFT's, 2026-11-28)
    llm = llm_with_new_rows(inputs, tmp_path / "llm", untie=(engine, stage) == ("fsdp", 1))
    other = 2 if stage == 1 else 1
    runs = {}
    for name, batch in (("two", {"global_batch": 4}), ("one", {"batch_size": 4})):
        settings = {"steps": steps, "lr": 3e-3, "projector_lr": 3e-3, **batch}
        runs[name] = tiny_config(inputs, tmp_path / name, model={"llm": str(llm)}, **{f"stage{stage}": settings},
                                 # one disk cache of decoded clips for all 3 runs: the 2-process runs' main process
                                 # fills it first and the other reads it, as on GPUs; the weights compared below
                                 # then also show that cached clips train as freshly decoded ones
                                 data={"video_cache": str(tmp_path / "video_cache")},
                                 **{f"stage{other}": {"skip": True}}, lora={"r": 8, "alpha": 16, "dropout": 0.0},
                                 runtime={"threads": 1, "log_with": "none", "progress": False, "log_every": 1,
                                          "checkpoint_every": 1, "mixed_precision": "no",
                                          # padded batches, as these engines train on GPUs: packed rows group 2
                                          # samples per process here but 4 in the one-process run, another float
                                          # summation (under FSDP one projector weight ended 1.7e-5 apart, over
                                          # the 1e-5 tolerance; every other trained tensor within 2e-7)
                                          "pack_sequences": False})
    (tmp_path / "two").mkdir()
    config_json = tmp_path / "two" / "config.json"
    config_json.write_text(json.dumps(runs["two"].to_dict()))
    if (engine, stage) == ("ddp", 2):  # the stop: rank 1's loss turns NaN at step 3, and both ranks raise at that
        # step (rank 0 would otherwise wait in the gradients' all-reduce until the launcher's timeout)
        started = time.perf_counter()
        done = _launch_two_processes(config_json, tmp_path / "w_killed", free_port(), stage, poison="1:3",
                                     ENGINE=engine)
        assert done.returncode != 0 and time.perf_counter() - started < TIMEOUT_S / 2
        assert "not finite at step 3 (micro-batch 1 of 1) on process(es) [1]; here nan" in done.stderr
        assert "on process(es) [1]; this process stops too" in done.stderr, done.stderr[-3000:]
        assert not (tmp_path / "w_killed").exists()
    else:
        _launch_two_processes(config_json, tmp_path / "w_killed", free_port(), stage, ENGINE=engine, STOP_AFTER="2")
    ckpts = sorted(p.name for p in (tmp_path / "two" / f"stage{stage}" / "checkpoints").glob("step-*"))
    assert ckpts == ["step-00000001", "step-00000002"] and not (tmp_path / "two" / f"stage{stage}" / "model").exists()
    _launch_two_processes(config_json, tmp_path / "w_resumed", free_port(), stage, ENGINE=engine, RESUME="1")
    info = json.loads((tmp_path / "two" / f"stage{stage}" / "run.json").read_text())
    assert info["processes"] == 2 and info["global_batch"] == 4, (
        f"the trainer ran {info['processes']} process(es) under torch.distributed.run --nproc_per_node 2: "
        f"each process trained alone (Accelerate sets up gloo DDP on CPU only when told it runs on CPU)")
    assert info["resumed_from_step"] == 2 and info["steps_done"] == steps
    assert info["engine"] == {"ddp": "multi_cpu", "fsdp": "fsdp2", "deepspeed": "deepspeed-zero2"}[engine]
    if engine == "deepspeed":  # its partitioned optimizer state, written by both processes through Accelerate
        assert list((tmp_path / "two" / f"stage{stage}" / "checkpoints" / "step-00000004" / "engine").iterdir())

    with capture_trainable_weights() as in_memory, _in_memory_logits(inputs) as answered:
        result = train_stage(runs["one"], stage)
    if engine == "ddp":
        _check_the_ranks_stayed_identical(tmp_path / "w_resumed", stage, in_memory, result.final_loss)
        if stage == 2:
            assert (tmp_path / "two" / "stage2" / "adapter" / "adapter_config.json").is_file()
    two, one = _final_trainable(tmp_path / "two", stage), _final_trainable(tmp_path / "one", stage)
    assert two.keys() == one.keys() and set(in_memory) <= set(one)  # a tied row table appears under both names
    assert any(".rows" in n or "trainable_tokens" in n for n in two), "the new token rows were not checkpointed"
    for name in in_memory:
        torch.testing.assert_close(one[name], in_memory[name], rtol=0, atol=0, msg=name)
    for name in one:
        torch.testing.assert_close(two[name], one[name], rtol=1e-4, atol=1e-5, msg=name)
    log = [json.loads(line)["loss"] for line in
           (tmp_path / "two" / f"stage{stage}" / "train_log.jsonl").read_text().splitlines()]
    single = [json.loads(line)["loss"] for line in
              (tmp_path / "one" / f"stage{stage}" / "train_log.jsonl").read_text().splitlines()]
    assert len(log) == steps and log == pytest.approx(single, abs=1e-4)
    # the saved model, reloaded, answers as the trained one did in memory; the 2-process run's saved model too
    torch.testing.assert_close(_saved_logits(tmp_path / "one" / f"stage{stage}" / "model", inputs), answered[0],
                               rtol=1e-4, atol=1e-4)
    torch.testing.assert_close(_saved_logits(tmp_path / "two" / f"stage{stage}" / "model", inputs), answered[0],
                               rtol=1e-4, atol=1e-4)
