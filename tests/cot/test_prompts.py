"""Teacher prompts: question, cue tables, stages and answer rule filled from data files; broken files fail loudly."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from tacreasoner.cot import cuetext
from tacreasoner.cot.prompts import (
    PROMPT_DIR,
    PROMPT_VERSION,
    PromptTemplateError,
    build_prompt,
    load_prompts,
    prompt_version,
)
from tacreasoner.cot.schema import CoTJob
from tacreasoner.tasks.vocab import get_vocabulary
from tests.cot.touchcot_bench import prepared


@pytest.fixture(scope="module")
def jobs(small_sim_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> list[CoTJob]:
    return prepared(small_sim_dataset, tmp_path_factory.mktemp("touchcot"))[1]


def _first(jobs: list[CoTJob], task: str, **gold) -> CoTJob:
    return next(j for j in jobs if j.item.task == task and all(j.item.gold.get(k) == v for k, v in gold.items()))


def test_every_job_gets_a_complete_prompt(jobs: list[CoTJob]) -> None:
    for job in jobs:
        prompt = build_prompt(job)
        assert prompt.version == PROMPT_VERSION and prompt.task == job.item.task
        for text in (prompt.system, prompt.user):
            assert "{" not in text and "}" not in text, f"{job.item.id}: unfilled slot"
            assert cuetext.MISSING not in text, f"{job.item.id}: a cue line cites a missing value"
        assert "<think>" in prompt.system and "<answer>" in prompt.system
        assert "<tactile>" not in prompt.user
        for k in range(1, len(job.videos) + 1):
            assert f"[Video {k}]" in prompt.user and f"Video {k} (" in prompt.user


def test_prompt_holds_question_cue_lines_stages_and_answer_rule(jobs: list[CoTJob]) -> None:
    job = _first(jobs, "SFD", kind="which")
    prompt = build_prompt(job)
    question_text = job.item.question.split("<tactile>")[-1].strip()
    assert question_text in prompt.user
    for n, video in enumerate(job.videos, start=1):
        block = prompt.user.split(f"Video {n} (")[1]
        assert cuetext.format_cue("press_area", video.cues["press_area"]) in block
        assert cuetext.format_cue("creep", video.cues["creep"]) in block
        assert cuetext.format_cue("residual", video.cues["residual"]) in block
        assert f"press {cuetext.cue_slots(video)['press_span']}" in block
    assert "Stages your reasoning must cover, in this order: " + ", ".join(job.stages) in prompt.user
    assert 'Answer rule: answer with exactly "the first object" or "the second object".' in prompt.system
    assert f"The correct answer is: {job.item.answer}" in prompt.user
    assert f"<answer>{job.item.answer}</answer>" in prompt.user


def test_answer_rules_follow_the_gold_conventions(jobs: list[CoTJob]) -> None:
    tfa = _first(jobs, "TFA-hardness")
    levels = get_vocabulary(tfa.item.vocabulary)["hardness"].levels
    assert f'"{levels[0]}", "{levels[1]}" or "{levels[2]}"' in build_prompt(tfa).system
    yesno = _first(jobs, "SFD", kind="yesno")
    assert 'exactly "yes" or "no"' in build_prompt(yesno).system
    combined = build_prompt(_first(jobs, "TFA-combined")).system
    assert "hardness: <hardness level>; protrusion: <protrusion level>" in combined
    osc = _first(jobs, "OSC")
    assert "(A) " + osc.item.options[0] in build_prompt(osc).system
    assert '"real" or "fake"' in build_prompt(_first(jobs, "RFOR")).system
    assert '"pressing", "holding", "sliding", "rotating" or "releasing"' in build_prompt(_first(jobs, "OCSE")).system
    assert '"the first object", "the second object" or "the third object"' in build_prompt(_first(jobs, "SOI")).system


def test_blind_prompts_do_not_reveal_the_answer(jobs: list[CoTJob]) -> None:
    job = _first(jobs, "RFOR")
    blind = build_prompt(job, reveal_answer=False)
    assert "The correct answer is" not in blind.user and "<answer>" not in blind.user
    assert blind.version == prompt_version(False) == PROMPT_VERSION + "+blind"
    ocse = _first(jobs, "OCSE")
    state = ocse.item.answer
    cue_table = build_prompt(ocse, reveal_answer=False).user.split("Measured cues")[1]
    assert state not in cue_table and ocse.stages[0] not in cue_table.split("\n\n")[0].lower()
    assert "segment" in cue_table


def test_tsa_has_no_prompt(jobs: list[CoTJob]) -> None:
    import dataclasses

    job = _first(jobs, "SFD")
    tsa = dataclasses.replace(job.item, task="TSA", answer="A",
                              gold={"letter": "A", "scenario": "scrape_ice", "needs": {"hardness": "high"}})
    with pytest.raises(ValueError, match="zero-shot"):
        build_prompt(CoTJob(tsa, job.stages, job.videos))


# ------------------------------------------------------------------------------------------- validation


@pytest.fixture
def prompt_copy(tmp_path: Path) -> Path:
    out = tmp_path / "prompts"
    shutil.copytree(PROMPT_DIR, out)
    return out


def _edit(path: Path, old: str, new: str) -> int:
    """Replace ``old`` once; returns the 1-based line where it was."""
    text = path.read_text()
    assert old in text, f"{old!r} not in {path.name}"
    line = text[: text.index(old)].count("\n") + 1
    path.write_text(text.replace(old, new, 1))
    return line


def test_packaged_prompts_load() -> None:
    prompts = load_prompts()
    assert prompts.version == PROMPT_VERSION
    assert "TSA" not in prompts.families and "OCSE" in prompts.families


def test_unknown_slot_names_file_line_and_field(prompt_copy: Path) -> None:
    line = _edit(prompt_copy / "tfa.yaml", 'guidance: "the question asks', 'guidance: "{colour} the question asks')
    with pytest.raises(PromptTemplateError) as err:
        load_prompts(prompt_copy)
    assert f"tfa.yaml:{line}: field 'guidance'" in str(err.value) and "{colour}" in str(err.value)


def test_unknown_cue_slot_in_a_cue_line(prompt_copy: Path) -> None:
    line = _edit(prompt_copy / "_common.yaml", "residual imprint {residual}", "residual imprint {residue}")
    with pytest.raises(PromptTemplateError, match=rf"_common.yaml:{line}: field 'cue_table.release'.*residue"):
        load_prompts(prompt_copy)


def test_missing_required_slot(prompt_copy: Path) -> None:
    _edit(prompt_copy / "_common.yaml", "  {question}\n", "  (question left out)\n")
    pattern = r"_common.yaml:\d+: field 'user': must contain slot\(s\) \{question\}"
    with pytest.raises(PromptTemplateError, match=pattern):
        load_prompts(prompt_copy)


def test_unknown_field_and_bad_yaml(prompt_copy: Path) -> None:
    line = _edit(prompt_copy / "rfor.yaml", "family: RFOR", "family: RFOR\nanswer_rules: typo")
    with pytest.raises(PromptTemplateError, match=rf"rfor.yaml:{line + 1}: unknown field\(s\) \['answer_rules'\]"):
        load_prompts(prompt_copy)
    (prompt_copy / "rfor.yaml").write_text("family: RFOR\ntasks: [RFOR\n")
    with pytest.raises(PromptTemplateError, match=r"rfor.yaml:\d+: invalid YAML"):
        load_prompts(prompt_copy)


def test_task_coverage_is_checked(prompt_copy: Path) -> None:
    (prompt_copy / "ocse.yaml").unlink()
    with pytest.raises(PromptTemplateError, match=r"no prompt family covers task\(s\) OCSE"):
        load_prompts(prompt_copy)
    shutil.copy(PROMPT_DIR / "ocse.yaml", prompt_copy / "ocse.yaml")
    shutil.copy(PROMPT_DIR / "rfor.yaml", prompt_copy / "rfor2.yaml")
    with pytest.raises(PromptTemplateError, match=r"rfor2.yaml:\d+: field 'tasks': task 'RFOR' is already covered"):
        load_prompts(prompt_copy)
    (prompt_copy / "rfor2.yaml").write_text((PROMPT_DIR / "rfor.yaml").read_text().replace("[RFOR]", "[TSA]"))
    with pytest.raises(PromptTemplateError, match="TSA is zero-shot"):
        load_prompts(prompt_copy)


def test_sfd_rule_variants_are_checked(prompt_copy: Path) -> None:
    _edit(prompt_copy / "sfd.yaml", "  yesno:", "  yes_no:")
    with pytest.raises(PromptTemplateError, match=r"sfd.yaml:\d+: field 'answer_rule': variants must be exactly"):
        load_prompts(prompt_copy)


def test_a_custom_prompt_set_is_used_and_versioned(prompt_copy: Path, jobs: list[CoTJob]) -> None:
    _edit(prompt_copy / "_common.yaml", "version: touchcot-v1", "version: my-lab-v2")
    _edit(prompt_copy / "rfor.yaml", "answer with exactly", "reply with exactly")
    custom = load_prompts(prompt_copy)
    prompt = build_prompt(_first(jobs, "RFOR"), prompts=custom)
    assert prompt.version == "my-lab-v2" and 'reply with exactly "real" or "fake"' in prompt.system
