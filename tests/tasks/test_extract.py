"""Tests for answer extraction: strict format checking, lenient fallbacks, and strict ⊆ lenient."""

from __future__ import annotations

import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from tacreasoner.tasks.extract import extract_answer, has_tags, split_reasoning

FRAGMENTS = ["<think>", "</think>", "<answer>", "</answer>", "<ANSWER>", "</Think>", "<answer", "answer>", " ", "\n",
             "A", "the first object", "Answer: B", "the answer is C", "reasoning", ".", ""]
tag_rich = st.lists(st.one_of(st.sampled_from(FRAGMENTS), st.text(max_size=8)), max_size=12).map("".join)
any_text = st.one_of(st.text(), tag_rich)
tag_free = st.text().filter(lambda s: not has_tags(s))


# ------------------------------------------------------------------------------------------------ properties


@given(any_text)
def test_never_raises(text: str) -> None:
    for mode in ("strict", "lenient"):
        out = extract_answer(text, mode)
        assert out is None or (isinstance(out, str) and out == out.strip() and out)


@given(any_text)
def test_strict_is_subset_of_lenient(text: str) -> None:
    strict = extract_answer(text, "strict")
    if strict is not None:
        assert extract_answer(text, "lenient") == strict


@given(tag_free, tag_free)
def test_strict_reads_the_canonical_format(think: str, answer: str) -> None:
    assume(answer.strip())
    assert extract_answer(f"<think>{think}</think><answer>{answer}</answer>", "strict") == answer.strip()
    assert extract_answer(f"<answer>{answer}</answer>", "strict") == answer.strip()


@given(tag_free)
def test_lenient_returns_none_only_for_empty(text: str) -> None:
    assert (extract_answer(text, "lenient") is None) == (not text.strip())


# ------------------------------------------------------------------------------------------------ examples


@pytest.mark.parametrize("text", [
    "the first object",                                             # no tags
    "<think>x</think>",                                             # no answer
    "<answer>A</answer><answer>B</answer>",                         # two answers
    "<think>x</think><answer>A",                                    # unclosed answer
    "<think>x<answer>A</answer>",                                   # unclosed think
    "<think>x</think>so: <answer>A</answer>",                       # text between blocks
    "Sure! <answer>A</answer>",                                     # text before
    "<answer>A</answer> hope this helps",                           # text after
    "<answer>A</answer><think>x</think>",                           # wrong order
    "<think>a</think><think>b</think><answer>A</answer>",           # two think blocks
    "<answer>   </answer>",                                         # empty answer
    "</answer>A<answer>",                                           # reversed tags
])
def test_strict_rejects(text: str) -> None:
    assert extract_answer(text, "strict") is None


def test_strict_accepts_whitespace_and_tag_case() -> None:
    assert extract_answer("\n<think>\nsteps\n</think>\n\n<answer> the first object \n</answer>\n", "strict") == \
        "the first object"
    assert extract_answer("<THINK>x</THINK><Answer>B</Answer>", "strict") == "B"


@pytest.mark.parametrize(("text", "expected"), [
    ("<answer>A</answer><answer> B </answer>", "B"),                  # last closed block
    ("<think>I could say <answer>A</answer></think><answer>B</answer>", "B"),
    ("<think>reasoning</think><answer>real fruit", "real fruit"),     # unclosed answer tail
    ("<think>long reasoning. Answer: sliding", "sliding"),            # unclosed think, answer cue
    ("pressing felt firm. The answer is: extremely hard.", "extremely hard."),
    ("answer: A ... final answer: B", "B"),                           # the final cue
    ("reasoning here</think>\nthe second object", "the second object"),  # template-opened think
    ("  just the answer  ", "just the answer"),
    ("<think>only reasoning</think>", None),                          # nothing after the think block
    ("<think>pressing felt firm, so it is hard", None),               # unclosed think, no cue: reasoning only
    ("<think>it felt firm", None),
    ("<answer></answer>", None),
    ("", None),
    ("   ", None),
])
def test_lenient_forms(text: str, expected: str | None) -> None:
    assert extract_answer(text, "lenient") == expected


def test_unknown_mode() -> None:
    with pytest.raises(ValueError, match="strict"):
        extract_answer("x", "fuzzy")


@pytest.mark.parametrize(("text", "expected"), [
    ("<think> a </think><answer> b </answer>", ("a", "b")),
    ("<answer>b</answer>", (None, "b")),
    ("<think>a", ("a", None)),
    ("<think>a<answer>b</answer>", ("a", "b")),
    ("a</think><answer>b</answer>", ("a", "b")),
    ("plain", (None, None)),
])
def test_split_reasoning(text: str, expected: tuple[str | None, str | None]) -> None:
    assert split_reasoning(text) == expected
