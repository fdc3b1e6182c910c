"""benchmarks/stage2_step.py, the script a GPU lease runs for the 7B step: on the CPU with one decoder layer, it
writes one result per micro-batch (two runs must not overwrite each other), the measured matmul peak and the MFU
against it, a profile of one step, and the memory plan's prediction beside the measured peak memory."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"
CONFIG = BENCHMARKS.parent / "configs" / "qwen2.5-7b.yaml"


@pytest.fixture(scope="module")
def stage2_step():
    sys.path.insert(0, str(BENCHMARKS))
    try:
        import stage2_step as module
        yield module
    finally:
        sys.path.remove(str(BENCHMARKS))


def test_one_layer_step_on_the_cpu_writes_profile_peak_and_a_file_per_micro_batch(tmp_path: Path) -> None:
    out = tmp_path / "results"
    done = subprocess.run([sys.executable, str(BENCHMARKS / "stage2_step.py"), "--config", str(CONFIG), "--layers",
                           "1", "--seq-len", "16", "--micro-batch", "2", "--steps", "1", "--warmup", "0",
                           "--vocab-size", "4096", "--measure-peak", "--profile", "--dtype", "float32",
                           "--out", str(out)],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    files = sorted(p.name for p in out.glob("*.json"))
    assert files == ["stage2_step_qwen25-7b_1_layers_mb2.json"]  # named by micro-batch: mb 4 and 8 both kept
    result = json.loads((out / files[0]).read_text())
    assert result["micro_batch"] == 2 and result["tokens_per_s"] > 0 and result["dtype"] == "float32"
    assert result["parameters"] < 0.3e9  # one 7B layer (0.23 B) and 4096 rows, not 152k (1.1 B)
    assert result["measured_peak_tflops"] > 0
    assert result["mfu_of_measured_peak"] == pytest.approx(
        result["achieved_tflops"] / result["measured_peak_tflops"], rel=0.05)
    ops = [row["op"] for row in result["profile_top"]]
    assert any("mm" in op for op in ops), ops  # the matmuls are where a step's time goes
    assert sum(row["share"] for row in result["profile_top"]) <= 1.0 + 1e-6
    assert result["memory_plan_gb"] is None  # a cut-down model has no plan to compare with
    page = (out / files[0]).with_suffix(".md").read_text()
    assert "One step profiled" in page and "1024³ float32 matmul" in page


def test_memory_plan_prediction_is_the_cli_plan_at_that_micro_batch(stage2_step) -> None:
    from tacreasoner.train.config import load_train_config
    from tacreasoner.train.memory_plan import GB, plan_for_config

    config = load_train_config(CONFIG, {"stage2.grad_accum": 4})  # global batch 32 on one GPU: micro-batch 8
    (plan,) = plan_for_config(config, stage=2, gpu_gb=1000.0, answer_fraction=0.3)
    assert plan.batch_size == 8
    eight = stage2_step.planned_memory_gb(str(CONFIG), 8, config.data.max_length, 0.3, None)
    four = stage2_step.planned_memory_gb(str(CONFIG), 4, config.data.max_length, 0.3, None)
    assert eight == pytest.approx(plan.total / GB)
    assert 15 < four < eight  # the frozen 7B weights alone are ~15 GB; activations grow with the micro-batch
    assert stage2_step.planned_memory_gb(str(CONFIG), 5, 1024, 0.3, None) is None  # 32 examples do not split in 5s
