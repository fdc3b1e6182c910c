"""Which mixed precision a run uses when its config says ``auto``: bf16 only where the hardware computes it natively."""

from __future__ import annotations

from pathlib import Path

import torch

__all__ = ["PRECISION_NAMES", "bf16_supported", "describe_precision", "resolve_mixed_precision"]

# A resolved ``runtime.mixed_precision`` (Accelerate's value) in words, for messages and reports
PRECISION_NAMES = {"bf16": "bf16 autocast", "fp16": "fp16 autocast", "no": "float32"}


def resolve_mixed_precision(setting: str) -> str:
    """``runtime.mixed_precision`` as Accelerate takes it: ``auto`` becomes bf16 or no."""
    if setting != "auto":
        return setting
    if torch.cuda.is_available():
        return "bf16" if torch.cuda.is_bf16_supported() else "no"
    return "bf16" if bf16_supported() else "no"


def describe_precision(setting: str) -> str:
    """How a run with ``runtime.mixed_precision: setting`` computes, in words for the person waiting on it: a CPU
    without native bf16 trains in float32, well behind the timings the docs give for one with it."""
    resolved = resolve_mixed_precision(setting)
    gpu = torch.cuda.is_available()
    where = "the GPU" if gpu else "this CPU"
    if resolved == "no" and setting == "auto" and not gpu:
        return ("float32: this CPU lists no native bf16 (avx512_bf16, amx_bf16), so training takes longer than "
                "the documented timings (about 2x on the 2-core CPUs measured, docs/training.md)")
    native = " (native bf16)" if resolved == "bf16" and setting == "auto" else ""
    return f"{PRECISION_NAMES.get(resolved, resolved)} on {where}{native}"


def bf16_supported(cpuinfo: str | None = None) -> bool:
    """Native bf16 matmuls on this CPU (autocast then roughly doubles training speed; otherwise it slows it).

    oneDNN reports bf16 "supported" on any AVX-512 CPU, where it is emulated: on an AVX-512 Xeon without AVX512_BF16
    a bf16 matmul ran at 24 GFLOP/s against 83 in float32 (2026-11-26), and "auto" mixed precision made Stage I
    several times slower. So the CPU's own flags decide where Linux lists them (``avx512_bf16``/``amx_bf16`` on x86,
    ``bf16`` on ARM); elsewhere oneDNN's answer stands."""
    if cpuinfo is None:
        try:
            cpuinfo = Path("/proc/cpuinfo").read_text(encoding="utf-8", errors="replace")
        except OSError:
            cpuinfo = ""
    flags = {flag for line in cpuinfo.splitlines() if line.lower().startswith(("flags", "features"))
             for flag in line.split(":", 1)[-1].split()}
    if flags:
        return bool(flags & {"avx512_bf16", "amx_bf16", "bf16"})
    try:
        return bool(torch.ops.mkldnn._is_mkldnn_bf16_supported())
    except (AttributeError, RuntimeError):
        return False
