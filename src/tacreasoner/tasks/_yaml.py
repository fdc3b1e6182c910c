"""YAML loading that remembers line numbers, so data-file errors can point at ``file:line``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

LINE_KEY = "__line__"
"""Added to every mapping read by :func:`load_yaml`: the 1-based line where the mapping starts."""


class _LineLoader(yaml.SafeLoader):
    """Safe loader whose mappings carry their source line under ``LINE_KEY``."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict:
        mapping = super().construct_mapping(node, deep=deep)
        mapping[LINE_KEY] = node.start_mark.line + 1
        return mapping


def load_yaml(path: Path) -> Any:
    """Parse ``path`` (safe YAML); syntax errors become ValueError naming the file and line."""
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as e:
        raise ValueError(f"{path}: cannot read: {e}") from None
    try:
        return yaml.load(text, Loader=_LineLoader)  # _LineLoader is a SafeLoader
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f"{path}:{mark.line + 1}" if mark is not None else str(path)
        problem = getattr(e, "problem", None) or str(e)
        raise ValueError(f"{where}: invalid YAML: {problem}") from None


def where(path: Path, entry: Any) -> str:
    """``file:line`` for a mapping read by :func:`load_yaml` (``file`` alone when unknown)."""
    line = entry.get(LINE_KEY) if isinstance(entry, dict) else None
    return f"{path}:{line}" if line else str(path)


def fields(entry: dict) -> dict:
    """The mapping without the bookkeeping line key."""
    return {k: v for k, v in entry.items() if k != LINE_KEY}
