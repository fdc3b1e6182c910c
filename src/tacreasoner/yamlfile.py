"""YAML data files with a line number for every key and list entry, so errors can say ``file:line``.

:func:`read_yaml` returns the parsed data unchanged (plain dicts, lists and scalars) together with a
table of 1-based source lines keyed by each node's path: a tuple of mapping keys and list indices
from the top, ``()`` being the document itself. A mapping key's path maps to the line of the key;
a list entry's path to the line where the entry starts. :func:`line_of` looks a path up, falling back
to the nearest ancestor that has a line.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

__all__ = ["KeyPath", "line_of", "read_yaml"]

KeyPath = tuple[str | int, ...]
"""Where a node sits in the document: mapping keys and list indices from the top."""

_MERGE_TAG = "tag:yaml.org,2002:merge"


def read_yaml(path: Path, error: type[ValueError] = ValueError) -> tuple[Any, dict[KeyPath, int]]:
    """The parsed file (safe YAML) and the 1-based line of every node, keyed by its path.

    A file that cannot be read or is not valid YAML raises ``error`` naming the file (and, for syntax
    errors, the line).
    """
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
    lines: dict[KeyPath, int] = {}
    loader = yaml.SafeLoader("")
    ancestors: set[int] = set()  # nodes being walked: an alias back to one of them is a cycle, not a subtree

    def walk(n: yaml.Node | None, at: KeyPath) -> None:
        if n is None or id(n) in ancestors:
            return
        lines[at] = n.start_mark.line + 1
        ancestors.add(id(n))
        if isinstance(n, yaml.MappingNode):
            for k, v in n.value:
                if k.tag == _MERGE_TAG:  # ``<<: *anchor``: merged keys keep the mapping's line
                    continue
                key = loader.construct_object(k)
                walk(v, (*at, key))
                lines[(*at, key)] = k.start_mark.line + 1
        elif isinstance(n, yaml.SequenceNode):
            for i, v in enumerate(n.value):
                walk(v, (*at, i))
        ancestors.discard(id(n))

    walk(node, ())
    return data, lines


def line_of(lines: Mapping[KeyPath, int], at: KeyPath) -> int:
    """Line of ``at``, or of its nearest ancestor that has one (1 when none has)."""
    while at and at not in lines:
        at = at[:-1]
    return lines.get(at, 1)
