"""The README and docs link to files that exist (results move, docs get renamed: a dead link is a silent lie)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
LINK = re.compile(r"\]\(([^)#\s]+)(?:#[^)]*)?\)")
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_relative_links_point_to_existing_files(page: Path) -> None:
    text = page.read_text(encoding="utf-8")
    targets = [m.group(1) for m in LINK.finditer(text) if not re.match(r"[a-z]+:", m.group(1))]
    missing = [t for t in targets if not (page.parent / t).exists()]
    assert not missing, f"{page.relative_to(ROOT)} links to missing files: {missing}"


def test_the_readme_opens_with_the_two_set_up_commands() -> None:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = text[text.index("```bash\n") + 8:]
    commands = block[: block.index("```")].strip().splitlines()
    assert len(commands) == 2
    assert commands[0].endswith("tacreasoner quickstart") and "pytest" in commands[1]
    ci = (ROOT / ".ci" / "run").read_text()
    assert ci.count('pip install -q -e ".[dev]"') == 1
    # CI runs the tests as the README says (in parallel processes: issue 39's 15 minutes)
    test_command = commands[1][commands[1].index(".venv/bin/python -m pytest"):]
    assert "-n 2" in test_command and f"{test_command} || status=$?" in ci
