"""Everyday objects besides the simulator's catalogue, with their typical property ranks (``everyday_objects.yaml``).

The evaluation's hallucination check counts their names as known objects: a model may bring one into its
reasoning that no clip shows, and naming a real object is not inventing one.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from tacreasoner.yamlfile import line_of, read_yaml

__all__ = ["EVERYDAY_OBJECTS_FILE", "RANKED", "EverydayObject", "everyday_object_names", "everyday_objects"]

EVERYDAY_OBJECTS_FILE = Path(__file__).resolve().parent / "everyday_objects.yaml"
RANKED = ("hardness", "protrusion", "elasticity", "friction", "roughness")
"""The ranks each entry gives (bumpiness is left out: the simulator derives it from the same bump height as
protrusion, so readers that want it copy protrusion)."""
_ARTICLE = re.compile(r"^(a|an|the)\s+", re.IGNORECASE)


@dataclass(frozen=True)
class EverydayObject:
    name: str
    """With its article, as it reads in a sentence: ``a tangerine``."""
    material: str
    ranks: Mapping[str, int]
    """attribute → 0 (low), 1 or 2 (high) for every attribute in :data:`RANKED`."""


def everyday_objects(path: str | Path | None = None) -> tuple[EverydayObject, ...]:
    """The entries of ``everyday_objects.yaml`` (or ``path``), checked; errors name the file and line."""
    path = EVERYDAY_OBJECTS_FILE if path is None else Path(path)
    data, lines = read_yaml(path)
    if not isinstance(data, dict) or not isinstance(data.get("objects"), list) or set(data) != {"objects"}:
        raise ValueError(f"{path}: top level must be a mapping with only an 'objects' list")
    out = []
    for i, entry in enumerate(data["objects"]):
        where = f"{path}:{line_of(lines, ('objects', i))}"
        if not isinstance(entry, dict) or set(entry) != {"name", "material", "ranks"}:
            raise ValueError(f"{where}: each object needs exactly the fields name, material and ranks")
        for field in ("name", "material"):
            if not isinstance(entry[field], str) or not entry[field].strip():
                raise ValueError(f"{where}: field {field!r} must be a non-empty string")
        if not _ARTICLE.match(entry["name"]):
            raise ValueError(f"{where}: name {entry['name']!r} must start with its article (a/an/the)")
        ranks = entry["ranks"]
        if not isinstance(ranks, dict) or set(ranks) != set(RANKED):
            raise ValueError(f"{where}: ranks must give exactly {', '.join(RANKED)}")
        for a, r in ranks.items():
            if isinstance(r, bool) or r not in (0, 1, 2):
                raise ValueError(f"{where}: rank for {a!r} must be 0, 1 or 2, got {r!r}")
        out.append(EverydayObject(entry["name"].strip(), entry["material"].strip(), dict(ranks)))
    return tuple(out)


def everyday_object_names(path: str | Path | None = None) -> tuple[str, ...]:
    """The objects' names with their articles, in file order."""
    return tuple(o.name for o in everyday_objects(path))
