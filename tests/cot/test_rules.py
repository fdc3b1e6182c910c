"""The offline rule-based teacher: right answers, every stage covered, real cue values, varied and consistent."""

from __future__ import annotations

import asyncio
import dataclasses
import re
import shutil
from collections import Counter, defaultdict
from pathlib import Path

import pytest

from tacreasoner.cot import cuetext
from tacreasoner.cot.prompts import build_prompt
from tacreasoner.cot.rules import BANK_FILE, RulesBankError, RulesTeacher, load_bank
from tacreasoner.cot.schema import CoTJob
from tacreasoner.tasks.schema import CONTACT_STATES
from tacreasoner.tasks.scoring import score_item
from tacreasoner.tasks.vocab import get_vocabulary
from tests.cot.cot_samples import make_sample
from tests.cot.touchcot_bench import prepared, variants

STAGE_WORDS = {"press": r"press", "hold": r"hold|held", "slide": r"slid", "rotate": r"rotat", "release": r"releas"}


@pytest.fixture(scope="module")
def jobs(small_sim_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> list[CoTJob]:
    return variants(prepared(small_sim_dataset, tmp_path_factory.mktemp("touchcot"))[1], 200)


@pytest.fixture(scope="module")
def teacher() -> RulesTeacher:
    return RulesTeacher(seed=0)


@pytest.fixture(scope="module")
def replies(jobs: list[CoTJob], teacher: RulesTeacher) -> list[str]:
    return [teacher.generate_sync(job, build_prompt(job)).text for job in jobs]


def _think(text: str) -> str:
    m = re.fullmatch(r"<think>(.+)</think><answer>(.+)</answer>", text, re.DOTALL)
    assert m, f"not <think>…</think><answer>…</answer>: {text[:80]!r}"
    return m.group(1)


def test_every_reply_is_well_formed_and_right(jobs: list[CoTJob], replies: list[str]) -> None:
    assert len({j.item.task for j in jobs}) >= 9
    for job, text in zip(jobs, replies, strict=True):
        _think(text)
        assert text.endswith(f"<answer>{job.item.answer}</answer>")
        assert score_item(job.item, text, "strict").correct, f"{job.item.id}: {text[-200:]}"


def test_every_required_stage_is_mentioned(jobs: list[CoTJob], replies: list[str]) -> None:
    for job, text in zip(jobs, replies, strict=True):
        think = _think(text).lower()
        for stage in job.stages:
            assert re.search(STAGE_WORDS[stage], think), f"{job.item.id}: stage {stage!r} missing in {think!r}"


def test_reasoning_quotes_measured_cue_values(jobs: list[CoTJob], replies: list[str]) -> None:
    for job, text in zip(jobs, replies, strict=True):
        think = _think(text)
        quoted = {value for n, video in enumerate(job.videos, 1) for name, value in cuetext.cue_slots(video, n).items()
                  if name in cuetext.CUE_NAMES and any(ch.isdigit() for ch in value)}
        found = [v for v in quoted if v in think]
        assert len(found) >= min(2, len(job.stages)), f"{job.item.id}: no cue value quoted in {think!r}"
        if len(job.videos) > 1:
            assert all(f"Video {k}" in think for k in range(1, len(job.videos) + 1)), f"{job.item.id}: {think!r}"


def test_reasoning_never_contradicts_the_answer(jobs: list[CoTJob], replies: list[str]) -> None:
    for job, text in zip(jobs, replies, strict=True):
        item, think = job.item, _think(text)
        low = think.lower()
        if item.task.startswith("TFA-") and item.task != "TFA-combined":
            attr = get_vocabulary(item.vocabulary)[item.task.removeprefix("TFA-")]
            for phrase in attr.levels:
                if phrase != item.answer:
                    assert not re.search(rf"\b{re.escape(phrase)}\b", low), f"{item.id}: says {phrase!r}"
        if item.task == "RFOR":
            other = "fake" if item.gold["real"] else "real"
            assert not re.search(rf"\b{other}\b", low), f"{item.id}: says {other!r}"
        if item.task == "OCSE":
            for state in CONTACT_STATES:
                if state != item.answer:
                    assert state not in low, f"{item.id}: says {state!r}"
        last = re.split(r"(?<=[.!?])\s+", think.strip())[-1]
        assert score_item(item, f"<answer>{last}</answer>", "lenient").correct, f"{item.id}: conclusion {last!r}"


def test_conclusions_read_by_the_touchcot_filter_agree(jobs: list[CoTJob], replies: list[str]) -> None:
    import tacreasoner.cot.filter as cot_filter
    if not hasattr(cot_filter, "conclusion"):
        pytest.skip("filter has no conclusion reader")
    for job, text in zip(jobs, replies, strict=True):
        think, answer = _think(text), job.item.answer
        read = cot_filter.conclusion(job.item, think)
        assert read is not None, f"{job.item.id}: no readable conclusion in {think[-160:]!r}"
        gold = score_item(job.item, f"<answer>{answer}</answer>", "strict").parsed
        assert read[1] == gold or (isinstance(gold, dict) and all(
            v is None or v == gold[k] for k, v in read[1].items())), f"{job.item.id}: filter read {read}"


def test_think_texts_are_diverse(jobs: list[CoTJob], replies: list[str], teacher: RulesTeacher) -> None:
    thinks = [_think(t) for t in replies]
    assert len(set(thinks)) / len(thinks) >= 0.9
    same_task = variants(jobs, 200, task="TFA-hardness")  # ~16 distinct clips, 200 items
    hardness = [teacher.compose(j).think for j in same_task]
    assert len(set(hardness)) / len(hardness) >= 0.9


def test_no_sentence_template_dominates_a_stage(jobs: list[CoTJob], teacher: RulesTeacher) -> None:
    for task in ("TFA-hardness", "SFD", "RFOR"):
        usage: dict[str, Counter] = defaultdict(Counter)
        for job in variants(jobs, 200, task=task):
            for tag, template in teacher.compose(job).templates:
                if tag in job.stages:  # the sentence that carries the stage
                    usage[tag][template] += 1
        assert usage, task
        for stage, counts in usage.items():
            share = max(counts.values()) / sum(counts.values())
            assert share <= 0.4, f"{task}/{stage}: one template used {share:.0%} of the time ({counts.most_common(2)})"


def test_deterministic_for_seed_and_key(jobs: list[CoTJob], replies: list[str]) -> None:
    again = RulesTeacher(seed=0)
    assert [again.generate_sync(j).text for j in jobs[:20]] == replies[:20]
    other = RulesTeacher(seed=1)
    assert sum(other.generate_sync(j).text != t for j, t in zip(jobs[:20], replies[:20], strict=True)) >= 18
    rekeyed = dataclasses.replace(jobs[0], key="another-key")
    assert again.generate_sync(rekeyed).text != replies[0]


def test_async_generate_and_identity(jobs: list[CoTJob], replies: list[str], teacher: RulesTeacher) -> None:
    reply = asyncio.run(teacher.generate(jobs[3], build_prompt(jobs[3])))
    assert reply.text == replies[3] and reply.model == "rules-v1" and reply.reasoning is None
    assert (teacher.name, teacher.model) == ("rules", "rules-v1")


def test_tsa_is_refused(jobs: list[CoTJob], teacher: RulesTeacher) -> None:
    job = next(j for j in jobs if j.item.task == "SFD")
    tsa = dataclasses.replace(job.item, task="TSA", answer="A",
                              gold={"letter": "A", "scenario": "scrape_ice", "needs": {"hardness": "high"}})
    with pytest.raises(ValueError, match="zero-shot"):
        teacher.generate_sync(CoTJob(tsa, job.stages, job.videos))


# ------------------------------------------------------------------------------------------- brief style


@pytest.fixture(scope="module")
def brief_replies(jobs: list[CoTJob]) -> list[str]:
    return [RulesTeacher(seed=0, style="brief").generate_sync(job).text for job in jobs]


def test_brief_replies_are_right_short_and_name_every_stage(jobs: list[CoTJob], brief_replies: list[str],
                                                            replies: list[str]) -> None:
    for job, text in zip(jobs, brief_replies, strict=True):
        think = _think(text)
        assert score_item(job.item, text, "strict").correct, f"{job.item.id}: {text[-200:]}"
        for stage in job.stages:
            assert re.search(STAGE_WORDS[stage], think.lower()), f"{job.item.id}: stage {stage!r} missing in {think!r}"
        # number-free: the only digits are video numbers and OSC's pairing
        assert not re.search(r"\d", re.sub(r"Video \d|\d-[ABC]", "", think)), f"{job.item.id}: {think!r}"
    brief_words = sum(len(_think(t).split()) for t in brief_replies) / len(brief_replies)
    full_words = sum(len(_think(t).split()) for t in replies) / len(replies)
    assert brief_words < 70 and brief_words < full_words / 2, (brief_words, full_words)


def test_brief_comparisons_describe_each_video_at_its_rank(jobs: list[CoTJob], brief_replies: list[str]) -> None:
    bank, seen = load_bank(), 0
    for job, text in zip(jobs, brief_replies, strict=True):
        if job.item.task not in ("SFD", "SOI"):
            continue
        attribute, think = job.item.gold["attribute"], _think(text)
        for n, rank in enumerate(job.item.meta["ranks"], 1):
            said = re.search(rf"Video {n} (?:feels|comes across as|is) ([a-z -]+?)(?:,| and Video|\.)", think)
            assert said and said.group(1) in bank["descriptors"][attribute][rank], f"{job.item.id}: {think!r}"
            seen += 1
    assert seen >= 20


def test_brief_conclusions_agree_with_the_filter_and_never_contradict(jobs: list[CoTJob],
                                                                      brief_replies: list[str]) -> None:
    from tacreasoner.cot.filter import conclusion

    for job, text in zip(jobs, brief_replies, strict=True):
        item, think = job.item, _think(text)
        read = conclusion(item, think)
        assert read is not None, f"{item.id}: no readable conclusion in {think!r}"
        if item.task == "OCSE":
            assert not any(s in think.lower() for s in CONTACT_STATES if s != item.answer), f"{item.id}: {think!r}"
        if item.task == "RFOR":
            other = "fake" if item.gold["real"] else "real"
            assert not re.search(rf"\b{other}\b", think.lower()), f"{item.id}: says {other!r}"


def test_brief_style_has_its_own_model_id_and_rejects_unknown_styles(jobs: list[CoTJob]) -> None:
    from tacreasoner.cot.backends import TeacherConfig, make_teacher

    brief = make_teacher(TeacherConfig(backend="rules", model="rules-brief-v1", extra={"style": "brief"}))
    assert (brief.style, brief.model) == ("brief", "rules-brief-v1")
    assert brief.generate_sync(jobs[0]).model == "rules-brief-v1"
    assert make_teacher(TeacherConfig(backend="rules", model="rules-v1")).model == "rules-v1"
    with pytest.raises(ValueError, match="style must be one of full, brief, brief-first, brief-levels, got 'short'"):
        RulesTeacher(style="short")


def test_brief_first_opens_with_the_verdict_then_says_the_brief_reasoning(jobs: list[CoTJob],
                                                                          brief_replies: list[str]) -> None:
    from tacreasoner.cot.backends import TeacherConfig, make_teacher
    from tacreasoner.cot.filter import FilterConfig, filter_samples

    first = make_teacher(TeacherConfig(backend="rules", model="rules-brief-first-v1", extra={"style": "brief-first"}))
    assert (first.style, first.model) == ("brief-first", "rules-brief-first-v1")
    texts = [first.generate_sync(job).text for job in jobs]
    for job, brief, text in zip(jobs, brief_replies, texts, strict=True):
        verdict = f"<think>Answer: {job.item.answer}. "
        assert text.startswith(verdict), f"{job.item.id}: {text[:120]!r}"
        # the same seeded choices as the brief style: only the opening sentence is new
        assert text == verdict + brief.removeprefix("<think>"), job.item.id
        assert score_item(job.item, text, "strict").correct
    samples = [make_sample(job.item, "", output=text, stages=list(job.stages), key=f"{i}")
               for i, (job, text) in enumerate(zip(jobs, texts, strict=True))]
    result = filter_samples(samples, FilterConfig(dedup=False))
    assert not result.rejected, [(s.item_id, s.reasons) for s in result.rejected][:3]


def test_brief_levels_reads_each_video_with_its_level_then_decides_comparisons_by_the_number_rule(
        jobs: list[CoTJob], brief_replies: list[str]) -> None:
    from tacreasoner.cot.backends import TeacherConfig, make_teacher
    from tacreasoner.cot.filter import FilterConfig, filter_samples

    levels = make_teacher(TeacherConfig(backend="rules", model="rules-brief-levels-v1",
                                        extra={"style": "brief-levels"}))
    assert (levels.style, levels.model) == ("brief-levels", "rules-brief-levels-v1")
    texts = [levels.generate_sync(job).text for job in jobs]
    compared = 0
    for job, brief, text in zip(jobs, brief_replies, texts, strict=True):
        item = job.item
        assert score_item(item, text, "strict").correct, (item.id, text)
        if item.task not in ("SFD", "SOI"):  # everything else is brief-first
            assert text == f"<think>Answer: {item.answer}. " + brief.removeprefix("<think>"), item.id
            continue
        compared += 1
        think = text.split("</think>")[0]
        assert not think.startswith("<think>Answer:")  # readings come before any verdict
        said = [int(n) for n in re.findall(r"\(level (\d)\)", think)]
        assert said == item.meta["ranks"], (item.id, think)  # every video, in order, with its true level
        rule = think.split("level;")[-1]
        if "index" in item.gold:  # which-of: the rule names the answer's video
            assert f"Video {item.gold['index'] + 1}" in rule, (item.id, think)
        else:
            assert f"so {item.answer}:" in rule, (item.id, think)
        way = "higher" if item.gold["direction"] in ("more", "most") else "lower"
        assert f"a {way} level" in think or f"{'highest' if way == 'higher' else 'lowest'} level" in think
    assert compared > 10
    samples = [make_sample(job.item, "", output=text, stages=list(job.stages), key=f"{i}")
               for i, (job, text) in enumerate(zip(jobs, texts, strict=True))]
    result = filter_samples(samples, FilterConfig(dedup=False))
    assert not result.rejected, [(s.item_id, s.reasons) for s in result.rejected][:3]


# ------------------------------------------------------------------------------------------- the bank


def _bank_copy(tmp_path: Path, old: str, new: str) -> tuple[Path, int]:
    path = tmp_path / "bank.yaml"
    shutil.copy(BANK_FILE, path)
    text = path.read_text()
    assert old in text
    line = text[: text.index(old)].count("\n") + 1
    path.write_text(text.replace(old, new, 1))
    return path, line


def test_packaged_bank_loads() -> None:
    bank = load_bank()
    assert bank.version == "rules-v1"


def test_bank_errors_name_file_and_line(tmp_path: Path) -> None:
    path, line = _bank_copy(tmp_path, "contact area grows to {press_area}", "contact area grows to {press_size}")
    pattern = rf"bank.yaml:{line}: observe.press.0.0: unknown slot\(s\) \{{press_size\}}"
    with pytest.raises(RulesBankError, match=pattern):
        load_bank(path)
    path, line = _bank_copy(tmp_path, "    release: [[residual, -1]", "    release: [[residue, -1]")
    with pytest.raises(RulesBankError, match=rf"bank.yaml:{line}: evidence.hardness.release.0"):
        load_bank(path)
    path, _ = _bank_copy(tmp_path, '  - " — {reading}"\n  - "; {reading}"\n  - ", a sign',
                         '  - " — {reading}"\n  - "; nothing"\n  - ", a sign')
    with pytest.raises(RulesBankError, match=r"connectors.1: .* must contain \{reading\}"):
        load_bank(path)
    path, _ = _bank_copy(tmp_path, "version: rules-v1", "version: rules-v1\nextras: []")
    with pytest.raises(RulesBankError, match=r"unknown section\(s\) \['extras'\]"):
        load_bank(path)


def _pc_jobs(jobs: list[CoTJob], n: int = 60) -> list[CoTJob]:
    """PC jobs on the prepared SFD pairs (PC is built only for PhysiCLeAR benchmarks; the rules teacher reads
    the same cues): each relation in turn, the second video's rank set to match it."""
    out = []
    relations = ("more", "less", "similar")
    for i, job in enumerate(variants(jobs, n, task="SFD")):
        relation, attribute = relations[i % 3], job.item.gold["attribute"]
        first = job.item.meta["ranks"][0]
        second = {"more": first - 1, "less": first + 1, "similar": first}[relation] % 3
        gold = {"attribute": attribute, "relation": relation}
        question = (f"<tactile>\n<tactile>\nCompared with the second object, does the first object have more, less "
                    f"or similar {attribute}? Answer more, less or similar.")
        item = dataclasses.replace(job.item, task="PC", question=question, answer=relation, gold=gold,
                                   meta={**job.item.meta, "ranks": [first, second]})
        out.append(CoTJob(item=item, stages=list(job.stages), videos=list(job.videos)))
    return out


@pytest.mark.parametrize("style", ["full", "brief", "brief-first", "brief-levels"])
def test_pc_reasoning_concludes_the_relation_in_every_style(jobs: list[CoTJob], style: str) -> None:
    from tacreasoner.tasks.consistency import check_reasoning

    teacher = RulesTeacher(seed=0, style=style)
    seen = Counter()
    for job in _pc_jobs(jobs):
        text = teacher.generate_sync(job, build_prompt(job)).text
        think = _think(text)
        assert score_item(job.item, text, "strict").correct, f"{job.item.id}: {text[-160:]}"
        last = re.split(r"(?<=[.!?])\s+", think.strip())[-1]
        assert score_item(job.item, f"<answer>{last}</answer>", "lenient").correct, f"{style}: {last!r}"
        check = check_reasoning(job.item, text)
        assert not check.hallucinated, f"{style}: {check.detail}"
        assert all(f"Video {k}" in think for k in (1, 2)), think
        seen[job.item.answer] += 1
    assert seen == {"more": 20, "less": 20, "similar": 20}
