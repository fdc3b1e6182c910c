"""The everyday objects file: read and checked in the tasks layer, known to the report's hallucination check."""

from __future__ import annotations

from pathlib import Path

import pytest

from tacreasoner.tasks.everyday_objects import RANKED, everyday_object_names, everyday_objects


def test_the_packaged_objects_have_articles_and_every_rank() -> None:
    objects = everyday_objects()
    assert len(objects) >= 10
    assert everyday_object_names() == tuple(o.name for o in objects)
    assert "a tangerine" in everyday_object_names()
    for o in objects:
        assert o.name.split()[0] in ("a", "an", "the") and o.material
        assert set(o.ranks) == set(RANKED) and set(o.ranks.values()) <= {0, 1, 2}


def test_the_report_knows_the_everyday_objects() -> None:
    from tacreasoner.evaluate.report import object_names

    assert any("tangerine" in group for group in object_names())


@pytest.mark.parametrize(("text", "message"), [
    ("objects:\n  - {name: a tangerine, material: peel}\n", r"objects.yaml:2: each object needs exactly"),
    ("objects:\n  - {name: ' ', material: peel, ranks: {}}\n", "field 'name' must be a non-empty string"),
    ("- a tangerine\n", "only an 'objects' list"),
])
def test_a_bad_file_names_file_and_line(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "objects.yaml"
    path.write_text(text)
    with pytest.raises(ValueError, match=message):
        everyday_objects(path)
