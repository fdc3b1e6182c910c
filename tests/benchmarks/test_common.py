"""What every benchmark script shares: paths of this checkout written repository-relative in its result files, and
no test split read unless asked."""

from __future__ import annotations

import ast
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


def test_no_benchmark_script_reads_test_unless_asked() -> None:
    """Every ``--split`` option of a script under benchmarks/ defaults to anything but ``test`` (as the scoring
    commands do): a user tuning with the documented commands never sees a test number by default."""
    scripts = sorted((REPO / "benchmarks").glob("*.py"))
    defaults = {}
    for script in scripts:
        for node in ast.walk(ast.parse(script.read_text(encoding="utf-8"))):
            if (isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "add_argument" and node.args
                    and isinstance(node.args[0], ast.Constant) and node.args[0].value == "--split"):
                default = next((k.value for k in node.keywords if k.arg == "default"), None)
                defaults[script.name] = default.value if isinstance(default, ast.Constant) else ast.dump(default)
    assert "touch_control.py" in defaults, "the scan found no --split option: it no longer reads the scripts"
    assert {name: d for name, d in defaults.items() if d == "test"} == {}
