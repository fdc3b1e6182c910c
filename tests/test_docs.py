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


ANCHOR_LINK = re.compile(r"\]\(([^)#\s]*)#([^)\s]+)\)")


def heading_anchors(page: Path) -> set[str]:
    """The anchors GitHub gives a page's headings: lower case, punctuation dropped, spaces to hyphens, repeats
    numbered; headings inside code fences are not headings."""
    anchors: set[str] = set()
    seen: dict[str, int] = {}
    in_fence = False
    for line in page.read_text(encoding="utf-8").splitlines():
        if line.startswith("```"):
            in_fence = not in_fence
        heading = None if in_fence else re.match(r"#{1,6}\s+(.*)", line)
        if heading:
            slug = re.sub(r"[^\w\- ]", "", heading.group(1).strip().lower()).replace(" ", "-")
            anchors.add(slug if slug not in seen else f"{slug}-{seen[slug]}")
            seen[slug] = seen.get(slug, 0) + 1
    return anchors


def test_heading_anchors_are_read_as_github_makes_them(tmp_path: Path) -> None:
    page = tmp_path / "p.md"
    page.write_text("# The quickstart on SmolLM2 (2026-11-27 to 28)\n## Notes\n```bash\n# not a heading\n```\n"
                    "## Notes\n", encoding="utf-8")
    assert heading_anchors(page) == {"the-quickstart-on-smollm2-2026-11-27-to-28", "notes", "notes-1"}


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_links_to_a_section_name_one_that_exists(page: Path) -> None:
    """Sections move between pages (docs/training.md's diary went to history.md): a dead anchor lands on the page's
    top, and the reader never finds what the sentence cites."""
    text = page.read_text(encoding="utf-8")
    dead = []
    for match in ANCHOR_LINK.finditer(text):
        target, anchor = match.groups()
        if re.match(r"[a-z]+:", target):
            continue
        linked = page.parent / target if target else page
        if linked.suffix == ".md" and linked.exists() and anchor not in heading_anchors(linked):
            dead.append(f"{target}#{anchor}")
    assert not dead, f"{page.relative_to(ROOT)} links to sections that do not exist: {dead}"


def test_the_readme_opens_with_the_two_set_up_commands() -> None:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = text[text.index("```bash\n") + 8:]
    commands = block[: block.index("```")].strip().splitlines()
    assert len(commands) == 2
    assert commands[0].endswith("tacreasoner quickstart") and "pytest" in commands[1]
    ci = (ROOT / ".ci" / "run").read_text()
    # CI installs what the README's test command installs, without pip byte-compiling every installed module
    assert 'pip install -q -e ".[dev]"' in commands[1] and ci.count('pip install -q --no-compile -e ".[dev]"') == 1
    assert ci.count("pip install") == 1 and "unset PYTHONDONTWRITEBYTECODE" in ci  # imports then compile once
    # CI runs the tests as the README says (in parallel processes: issue 39's 15 minutes)
    test_command = commands[1][commands[1].index(".venv/bin/python -m pytest"):]
    assert "-n 2" in test_command and f"{test_command} || status=$?" in ci


def test_the_example_questions_a_user_sees_are_held_out_wordings() -> None:
    """The README's and the demo's example questions are in a held-out wording set (tasks/paraphrases): never in
    training, so what a newcomer tries first shows how the model answers words it was not taught."""
    import re

    from tacreasoner.serve.demo import question_for
    from tacreasoner.tasks.paraphrase import heldout_wording_of, trained_wording_of

    section = (ROOT / "README.md").read_text(encoding="utf-8").split("## Asking, serving, the demo", 1)[1]
    section = section.split("\n## ", 1)[0]
    asked = re.findall(r'"([^"\n]*<tactile>[^"\n]*)"', section)
    assert len(asked) >= 3, "the README's ask/serve examples were not found"
    for question in asked:
        assert heldout_wording_of(question) is not None and trained_wording_of(question) is None, question
    demo_source = (ROOT / "src" / "tacreasoner" / "serve" / "demo.py").read_text(encoding="utf-8")
    default = re.search(r'gr\.Textbox\(label="Question", value="([^"]+)"', demo_source)
    assert default is not None and heldout_wording_of(question_for(default.group(1), 1)) is not None
