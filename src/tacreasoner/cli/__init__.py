"""The ``tacreasoner`` command: thin sub-commands over the library, one module per area.

Each module registers its commands on the shared Typer ``app`` (:mod:`tacreasoner.cli.app`) when imported; heavy
libraries are imported inside the commands so ``--help`` and ``--version`` stay instant.
"""
# ruff: noqa: I001  (the order below is the registration order)

from __future__ import annotations

# importing a command module registers its commands, in the data flow's order (the order of `--help`)
from tacreasoner.cli import sim  # noqa: F401
from tacreasoner.cli import bench  # noqa: F401
from tacreasoner.cli import cot  # noqa: F401
from tacreasoner.cli import model  # noqa: F401
from tacreasoner.cli import train  # noqa: F401
from tacreasoner.cli import evaluate  # noqa: F401
from tacreasoner.cli import recipes  # noqa: F401
from tacreasoner.cli import serve  # noqa: F401
from tacreasoner.cli.app import app

__all__ = ["app", "main"]


def main() -> None:
    app(prog_name="tacreasoner")
