"""Shared bits of the benchmark scripts: machine/command/date stamps and result writing."""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
import platform
import re
import shlex
import shutil
import sys
from pathlib import Path
from typing import Any

import numpy as np

RESULTS = Path(__file__).resolve().parent / "results"
REPO = RESULTS.parents[1]
"""The checkout these scripts run from: paths under it are written repository-relative."""


def portable(text: str, repo: Path = REPO) -> str:
    """``text`` with this machine's absolute paths of the checkout (and of ``../shared`` beside it) written relative
    to the repository root, so a result file reads the same on any machine."""
    for path, short in ((repo.parent / "shared", "../shared"), (repo, ".")):
        whole = re.escape(str(path)) + r"(?![\w.-])"  # a whole path component: /a/main, never /a/main2
        text = re.sub(whole + "/", "" if short == "." else f"{short}/", text)
        text = re.sub(whole, short, text)
    return text


def machine() -> dict:
    """What the numbers were measured on (they are meaningless without it)."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "platform": platform.platform(),
    }


def stamp() -> dict:
    return {
        "date": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "command": "python " + " ".join(shlex.quote(a) for a in sys.argv),
        "machine": machine(),
    }


def header_md(title: str, info: dict) -> str:
    m = info["machine"]
    return (f"# {title}\n\n- Date: {info['date']}\n- Command: `{info['command']}`\n"
            f"- Machine: {m['cpu']}, {m['cores']} cores, Python {m['python']}, NumPy {m['numpy']}\n\n")


def write_results(name: str, payload: dict, markdown: str, directory: Path | None = None) -> tuple[Path, Path]:
    directory = RESULTS if directory is None else Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    json_path, md_path = directory / f"{name}.json", directory / f"{name}.md"
    json_path.write_text(portable(json.dumps(payload, indent=2)) + "\n")
    md_path.write_text(portable(markdown))
    return json_path, md_path


def md_table(headers: list[str], rows: list[list]) -> str:
    def fmt(v: object) -> str:
        if isinstance(v, float):
            return f"{v:.1f}" if abs(v) >= 10 else f"{v:.3f}"
        return str(v)

    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    lines += ["| " + " | ".join(fmt(v) for v in row) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def publish(name: str, payload: dict, markdown: str, directory: Path | None = None) -> None:
    """Write the results (under benchmarks/results/ unless ``directory``) and show them: what every benchmark
    script ends with."""
    paths = write_results(name, payload, markdown, directory)
    print(markdown)
    print("wrote", *paths)


def pct(x: float | None) -> str:
    """A fraction as a percentage with one decimal; "–" where there is none (None or NaN)."""
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{100 * x:.1f}"


def pm(mean: float, std: float | None) -> str:
    """mean ± std in %, the mean alone where one seed leaves no spread."""
    return pct(mean) if std is None or math.isnan(std) else f"{pct(mean)} ± {pct(std)}"


def matmul_seconds(n: int, dtype_name: str, reps: int, warmup: int, device: str = "cpu") -> list[float]:
    """Seconds of each of ``reps`` n×n×n matmuls in ``dtype_name`` on ``device``, after ``warmup`` untimed ones (a
    GPU synchronised around each): the peak that achieved FLOP/s are read against."""
    import time

    import torch

    dtype = getattr(torch, dtype_name)
    a, b = torch.randn(n, n).to(device, dtype), torch.randn(n, n).to(device, dtype)

    def sync() -> None:
        if device == "cuda":
            torch.cuda.synchronize()

    for _ in range(warmup):
        torch.mm(a, b)
    times = []
    for _ in range(reps):
        sync()
        start = time.perf_counter()
        torch.mm(a, b)
        sync()
        times.append(time.perf_counter() - start)
    return times


def quickstart_stage_config(run: Path, stage: int, steps: int, output_dir: Path):
    """The quickstart's seed-0 training config for ``steps`` steps of ``stage`` into ``output_dir``, quiet (no logger,
    bar or checkpoints; a log record every step); Stage II starts from ``run``'s own Stage I model, copied in. For
    the scripts that time training steps of a finished quickstart run folder."""
    from tacreasoner.recipes.quickstart import QuickstartPaths, quickstart_config

    paths = QuickstartPaths(run)
    config = quickstart_config(paths, 0, overrides={"output_dir": str(output_dir)})
    config.runtime.log_with, config.runtime.progress = "none", False
    config.runtime.log_every, config.runtime.checkpoint_every = 1, 10**9
    config.stage(stage).steps = steps
    if stage == 2:
        stage1, target = paths.train(0) / "stage1", config.stage_dir(1)
        target.mkdir(parents=True, exist_ok=True)
        shutil.copytree(stage1 / "model", target / "model")
        for name in ("run.json", "train_log.jsonl"):
            shutil.copy(stage1 / name, target / name)
    return config


def clip_cls_tokens(encoder: Any, clips: list, video: Any, batch: int = 16) -> Any:
    """Each clip's first appearance token (the CLS the LLM receives) from a frozen ``encoder``, its frames prepared
    as ``video`` says, in batches without gradients: the feature the encoder probes read."""
    import torch

    from tacreasoner.model.video_processing import preprocess_video

    out = []
    with torch.no_grad():
        for start in range(0, len(clips), batch):
            x = torch.from_numpy(np.stack([preprocess_video(c, video) for c in clips[start:start + batch]]))
            out.append(encoder(x)[:, 0].double().numpy())
    return np.concatenate(out)
