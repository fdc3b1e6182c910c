"""What a recipe's report says about the machine it ran on: the CPU's model name, not just its architecture."""

from __future__ import annotations

import os
import platform
from pathlib import Path

__all__ = ["cpu_name", "machine_line"]


def cpu_name(cpuinfo: str | None = None) -> str:
    """``model name`` from /proc/cpuinfo on Linux (where ``platform.processor()`` is empty), else platform's answer."""
    if cpuinfo is None:
        try:
            cpuinfo = Path("/proc/cpuinfo").read_text(encoding="utf-8", errors="replace")
        except OSError:
            cpuinfo = ""
    for line in cpuinfo.splitlines():
        key, _, value = line.partition(":")
        if key.strip().lower() == "model name" and value.strip():
            return value.strip()
    return platform.processor() or platform.machine()


def machine_line() -> str:
    return f"{cpu_name()}, {os.cpu_count() or 1} cores, Python {platform.python_version()}"
