"""YAML data files with a line number for every key and list entry, so errors can say ``file:line``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

Path_ = tuple[str | int, ...]


def read_yaml(path: Path, error: type[ValueError] = ValueError) -> tuple[Any, dict[Path_, int]]:
    """The parsed file and the 1-based line of every node, keyed by its path (keys and list indices)."""
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as e:
        raise error(f"{path}: cannot read: {e}") from None
    try:
        node = yaml.compose(text, Loader=yaml.SafeLoader)
        data = yaml.load(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f"{path}:{mark.line + 1}" if mark is not None else str(path)
        raise error(f"{where}: invalid YAML: {getattr(e, 'problem', None) or e}") from None
    lines: dict[Path_, int] = {}

    def walk(n: yaml.Node | None, at: Path_) -> None:
        if n is None:
            return
        lines[at] = n.start_mark.line + 1
        if isinstance(n, yaml.MappingNode):
            loader = yaml.SafeLoader("")
            for k, v in n.value:
                key = loader.construct_object(k)
                lines[(*at, key)] = k.start_mark.line + 1
                walk(v, (*at, key))
                lines[(*at, key)] = k.start_mark.line + 1
        elif isinstance(n, yaml.SequenceNode):
            for i, v in enumerate(n.value):
                walk(v, (*at, i))

    walk(node, ())
    return data, lines


def line_of(lines: dict[Path_, int], at: Path_) -> int:
    """Line of ``at``, or of its nearest ancestor that has one."""
    while at and at not in lines:
        at = at[:-1]
    return lines.get(at, 1)
