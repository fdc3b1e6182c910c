"""The examples run as documented (they are the first code a user copies)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def test_model_tour_runs_and_reloads_identically(tmp_path) -> None:
    scratch = tmp_path / "tmp"  # the tour's temporary folder: its simulated clips must not be left behind
    scratch.mkdir()
    done = subprocess.run([sys.executable, str(EXAMPLES / "model_tour.py"), "--out", str(tmp_path / "model")],
                          capture_output=True, text=True, timeout=300, env={**os.environ, "TMPDIR": str(scratch)})
    assert done.returncode == 0, done.stderr[-3000:]
    assert "identical logits = True" in done.stdout
    assert (tmp_path / "model" / "processor_config.json").is_file()
    left = sorted(p.name for p in scratch.iterdir() if p.name.startswith("tour-"))  # (torch keeps caches there too)
    assert not left, f"left in the temporary folder: {left}"
