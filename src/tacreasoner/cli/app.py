"""The ``tacreasoner`` Typer app and what every command module shares: the console, one-line errors, option types.

Argument mistakes end as one ``error: …`` line on stderr with exit code 2 (no traceback), because a user who typed
``--objects -3`` needs the message, not the stack. Set ``TACREASONER_DEBUG=1`` to get the traceback instead.
"""

from __future__ import annotations

import functools
import os
import re
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, ParamSpec, TypeVar

import typer
from rich.console import Console

from tacreasoner import __version__

__all__ = ["USAGE_EXIT", "app", "at_least_one", "cli_errors", "console", "needs_train_extra", "parse_overrides"]

app = typer.Typer(
    name="tacreasoner",
    help="TacReasoner: tactile-language reasoning. Simulate tactile video, build benchmarks, train, score, serve.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
console = Console(highlight=False, soft_wrap=True)

P = ParamSpec("P")
R = TypeVar("R")
USAGE_EXIT = 2


def one_line(exc: BaseException) -> str:
    """The library's message without Python's decorations (KeyError quotes, errno prefixes)."""
    if isinstance(exc, OSError) and exc.strerror:
        text = f"{exc.filename}: {exc.strerror}" if exc.filename else exc.strerror
    elif isinstance(exc, KeyError) and exc.args:
        text = str(exc.args[0])
    else:
        text = str(exc) or type(exc).__name__
    return " ".join(text.splitlines())


def cli_errors(func: Callable[P, R]) -> Callable[P, R]:
    """Turn the library's ValueError/KeyError/OSError into one stderr line and exit code 2."""

    @functools.wraps(func)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        try:
            return func(*args, **kwargs)
        except (ValueError, KeyError, OSError) as exc:
            if os.environ.get("TACREASONER_DEBUG"):
                raise
            typer.echo(f"error: {one_line(exc)}", err=True)
            raise typer.Exit(USAGE_EXIT) from None

    return wrapper


def at_least_one(option: str, value: int | None) -> None:
    if value is not None and value < 1:
        raise ValueError(f"{option} must be at least 1, got {value}")


def comma_list(text: str) -> list[str]:
    return [s.strip() for s in text.split(",") if s.strip()]


def needs_train_extra(command: str) -> None:
    """The model commands need torch + transformers; say how to get them instead of a traceback."""
    try:
        import torch  # noqa: F401
        import transformers  # noqa: F401
    except ImportError:
        raise ValueError(f'{command} needs torch and transformers: pip install -e ".[train]"') from None


_EXPONENT_FLOAT = re.compile(r"[+-]?\d+(\.\d*)?[eE][+-]?\d+")


def parse_overrides(pairs: list[str] | None) -> dict[str, object]:
    """``--set stage2.steps=50`` pairs → {"stage2.steps": 50} (values parsed as YAML scalars)."""
    import yaml

    out: dict[str, object] = {}
    for pair in pairs or []:
        key, sep, value = pair.partition("=")
        if not sep or not key.strip():
            raise ValueError(f"--set {pair!r}: expected KEY=VALUE, e.g. --set stage2.steps=50")
        parsed = yaml.safe_load(value)
        if isinstance(parsed, str) and _EXPONENT_FLOAT.fullmatch(parsed.strip()):
            parsed = float(parsed)  # YAML 1.1 reads "1e-4" (no dot) as a string; a user means the number
        out[key.strip()] = parsed
    return out


# Option types shared by several commands.
Seed = Annotated[int, typer.Option("--seed", help="Master seed; a clip depends only on it and its position.")]
Workers = Annotated[int | None, typer.Option("--workers", help="Worker processes (default: CPU count).",
                                             show_default=False)]
Bench = Annotated[Path, typer.Option("--bench", help="Benchmark directory (from `tacreasoner build-bench`).")]
Split = Annotated[str, typer.Option("--split", help="train, val, test, or a held-out sensor's "
                                                    "val_heldout_sensor / test_heldout_sensor (choose on val; read "
                                                    "test once, when the choice is made).")]
Mode = Annotated[str, typer.Option("--mode", help="Answer extraction: strict or lenient.")]
VideoCache = Annotated[Path | None, typer.Option(
    "--video-cache", help="Preprocessed-video folder to reuse and fill (e.g. a training run's data.video_cache): "
                          "commands reading the same clips decode them once.", show_default=False)]
Dtype = Annotated[str, typer.Option("--dtype", help="Weights' type when answering: float32 (as trained), bfloat16 "
                                                    "(faster on a CPU with native bf16; replies differ by "
                                                    "rounding) or auto (bfloat16 where native).")]
Overrides = Annotated[list[str] | None, typer.Option(
    "--set", help="Override a config value: --set stage2.steps=50 (repeatable; dotted keys).")]


def _print_version(value: bool) -> None:
    if value:
        typer.echo(f"tacreasoner {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[bool, typer.Option("--version", callback=_print_version, is_eager=True,
                                          help="Print the version and exit.")] = False,
) -> None:
    """TacReasoner: tactile-language reasoning. Simulate tactile video (DynTAC-Sim) and preview it."""
    quiet_library_bars()


def quiet_library_bars() -> None:
    """Without a terminal (a log file, CI), no tqdm bars from Hugging Face libraries ("Loading weights: 18%|█▊…"
    repeated with carriage returns): our own progress prints plain lines there. Set before transformers is
    imported, which reads it once; a user's own setting wins."""
    if sys.stderr is None or not sys.stderr.isatty():
        os.environ.setdefault("HF_HUB_DISABLE_PROGRESS_BARS", "1")
