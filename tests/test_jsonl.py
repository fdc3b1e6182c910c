"""The shared JSON config reader names the file and what was expected."""

from __future__ import annotations

import pytest

from tacreasoner.jsonl import read_json_object


def test_read_json_object_errors_name_the_file(tmp_path) -> None:
    path = tmp_path / "config.json"
    with pytest.raises(FileNotFoundError, match=r"config\.json: no such file \(expected a thing\)"):
        read_json_object(path, "a thing")
    path.write_text("{bad")
    with pytest.raises(ValueError, match=r"config\.json: not valid JSON .* at line 1"):
        read_json_object(path, "a thing")
    path.write_text("[1, 2]")
    with pytest.raises(ValueError, match=r"expected a JSON object \(a thing\), got list"):
        read_json_object(path, "a thing")
    path.write_text('{"a": 1}')
    assert read_json_object(path, "a thing") == {"a": 1}
