"""Question templates and the TSA scenario bank: the shipped data is valid; bad edits fail loudly."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from tacreasoner.tasks.scenarios import SCENARIO_FILE, load_scenarios, scenarios_for
from tacreasoner.tasks.schema import PLACEHOLDER
from tacreasoner.tasks.templating import KINDS, TEMPLATE_DIR, TemplateError, load_templates, slot_names
from tacreasoner.tasks.vocab import PHYSICLEAR, VTV150K

# ------------------------------------------------------------------------------------------ templates


def test_shipped_templates_cover_every_kind_with_three_phrasings() -> None:
    bank = load_templates()
    assert set(bank) == set(KINDS)
    ids = [t.id for ts in bank.values() for t in ts]
    assert len(ids) == len(set(ids))
    for kind, templates in bank.items():
        assert len(templates) >= 3, kind
        for t in templates:
            assert t.text.count(PLACEHOLDER) == KINDS[kind].videos
            assert KINDS[kind].required <= slot_names(t.text) <= KINDS[kind].slots
            assert Path(t.file).parent == TEMPLATE_DIR and t.line > 0


def test_render_fills_slots_and_complains_about_missing_values() -> None:
    t = load_templates()["rfor"][0]
    assert "apple" in t.render(fruit="apple")
    with pytest.raises(ValueError, match=t.id):
        t.render()


def _bank_with(tmp_path: Path, text: str) -> Path:
    """A copy of the shipped bank plus one extra file ``extra.yaml``."""
    bank = tmp_path / "templates"
    shutil.copytree(TEMPLATE_DIR, bank)
    (bank / "extra.yaml").write_text(text)
    return bank


@pytest.mark.parametrize(("text", "needles"), [
    ('rfor:\n  - id: bad_slot\n    text: "<tactile> Is this {fruits} real?"\n',
     ["extra.yaml:2", "bad_slot", "unknown slot", "fruits"]),
    ('rfor:\n  - id: two_videos\n    text: "<tactile> <tactile> Is this {fruit} real?"\n',
     ["extra.yaml:2", "two_videos", "2 <tactile>", "needs 1"]),
    ('sfd_which:\n  - id: no_video\n    text: "Which is {comparative}?"\n',
     ["extra.yaml:2", "no_video", "0 <tactile>", "needs 2"]),
    ('soi:\n  - id: no_superlative\n    text: "<tactile><tactile><tactile> Which one?"\n',
     ["extra.yaml:2", "no_superlative", "missing required slot", "superlative"]),
    ('rfor:\n  - id: brace\n    text: "<tactile> Is this {fruit real?"\n', ["extra.yaml:2", "brace", "malformed"]),
    ('rfor:\n  - id: spec\n    text: "<tactile> Is this {fruit!r} real?"\n', ["extra.yaml:2", "spec", "bare name"]),
    ('rfor:\n  - id: extra_field\n    text: "<tactile> {fruit}"\n    weight: 2\n',
     ["extra.yaml:2", "unknown field", "weight"]),
    ('rfor:\n  - id: rfor_plain\n    text: "<tactile> Real {fruit}?"\n', ["extra.yaml:2", "duplicate template id"]),
    ('riddles:\n  - id: r\n    text: "<tactile>"\n', ["extra.yaml", "unknown template kind", "riddles"]),
    ('rfor: [\n', ["extra.yaml", "invalid YAML"]),
])
def test_bad_templates_name_file_line_and_template(tmp_path: Path, text: str, needles: list[str]) -> None:
    bank = _bank_with(tmp_path, text)
    with pytest.raises(ValueError) as info:  # TemplateError is a ValueError
        load_templates(bank)
    for needle in needles:
        assert needle in str(info.value), str(info.value)


def test_every_kind_needs_a_template(tmp_path: Path) -> None:
    bank = tmp_path / "templates"
    bank.mkdir()
    shutil.copy(TEMPLATE_DIR / "rfor.yaml", bank)
    with pytest.raises(TemplateError, match="no templates for kind"):
        load_templates(bank)


# ------------------------------------------------------------------------------------------ scenarios


def test_scenario_bank_covers_both_vocabularies() -> None:
    bank = load_scenarios()
    assert len(bank) >= 24
    assert len({s.id for s in bank}) == len(bank)
    vtv, phys = scenarios_for("vtv150k"), scenarios_for("physiclear")
    assert len(vtv) >= 12 and len(phys) >= 12
    for s in bank:
        assert s.applies_to("vtv150k") or s.applies_to("physiclear"), s.id
        assert s.text and s.needs
    assert {a for s in vtv for a in s.needs} == set(VTV150K)
    assert {a for s in phys for a in s.needs} == set(PHYSICLEAR)
    assert {lvl for s in bank for lvl in s.needs.values()} == {"high", "low"}
    scrape = next(s for s in bank if s.id == "scrape_ice")
    assert scrape.score({"hardness": 2}) > scrape.score({"hardness": 0})


@pytest.mark.parametrize(("entry", "needle"), [
    ('{id: x, text: "y", needs: {softness: high}}', "unknown attribute 'softness'"),
    ('{id: x, text: "y", needs: {hardness: medium}}', "must be 'high' or 'low'"),
    ('{id: x, text: "", needs: {hardness: high}}', "'text' must be a non-empty string"),
    ('{id: x, text: "y", needs: {hardness: high}, weight: 1}', "unknown field"),
    ('{id: scrape_ice, text: "y", needs: {hardness: high}}', "duplicate scenario id"),
])
def test_bad_scenarios_name_file_and_line(tmp_path: Path, entry: str, needle: str) -> None:
    path = tmp_path / "scenarios.yaml"
    lines = SCENARIO_FILE.read_text().rstrip("\n").splitlines()
    path.write_text("\n".join([*lines, f"  - {entry}"]) + "\n")
    with pytest.raises(ValueError) as info:
        load_scenarios(path)
    assert f"scenarios.yaml:{len(lines) + 1}" in str(info.value)
    assert needle in str(info.value)
