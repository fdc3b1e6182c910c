"""What every benchmark script's result files share: paths of this checkout written repository-relative."""

from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

from _common import REPO, portable, write_results


def test_result_files_name_paths_relative_to_the_repository(tmp_path: Path) -> None:
    model = REPO / "runs" / "quickstart" / "model"
    shared = REPO.parent / "shared" / "data" / "physiclear"
    payload = {"model": str(model), "data": str(shared), "root": str(REPO), "elsewhere": "/opt/clips/a.mp4"}
    json_path, md_path = write_results("x", payload, f"- Command: `evaluate --model {model} --data {shared}`\n",
                                       tmp_path)
    written = json.loads(json_path.read_text())
    assert written == {"model": "runs/quickstart/model", "data": "../shared/data/physiclear", "root": ".",
                       "elsewhere": "/opt/clips/a.mp4"}  # a path outside the checkout is left as it is
    said = md_path.read_text()
    assert said == "- Command: `evaluate --model runs/quickstart/model --data ../shared/data/physiclear`\n"
    assert str(REPO) not in json_path.read_text() + md_path.read_text()
    assert portable("/a/main2/runs", repo=Path("/a/main")) == "/a/main2/runs", "only whole path components"
