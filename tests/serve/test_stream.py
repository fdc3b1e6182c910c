"""The reasoning/answer splitter and stop strings: any way a reply arrives in pieces gives the same result."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from tacreasoner.serve.stream import ReasoningSplitter, StopMatcher, split_channels
from tacreasoner.tasks.extract import split_reasoning

REPLIES = ["<think>The imprint is deep, so it is soft.</think><answer>soft</answer>",
           "  <think>\n a < b and <thin ice </think>\n<answer> (A) </answer> trailing",
           "no tags at all",
           "<think>only reasoning, never answered",
           "<THINK>caps</THINK><Answer>B</Answer>"]


def _joined(pieces: list[str]) -> tuple[str, str]:
    splitter = ReasoningSplitter()
    parts = {"reasoning": "", "content": ""}
    for piece in pieces:
        for d in splitter.feed(piece):
            parts[d.channel] += d.text
    for d in splitter.finish():
        parts[d.channel] += d.text
    return parts["reasoning"].rstrip(), parts["content"].rstrip()


@given(st.sampled_from(REPLIES), st.lists(st.integers(0, 80), max_size=12))
def test_any_chunking_gives_the_whole_replys_channels(reply: str, cuts: list[int]) -> None:
    points = sorted({c % (len(reply) + 1) for c in cuts})
    pieces = [reply[a:b] for a, b in zip([0, *points], [*points, len(reply)], strict=True)]
    assert _joined(pieces) == split_channels(reply)


def test_channels_agree_with_the_scorers_split_on_well_formed_replies() -> None:
    reply = REPLIES[0]
    think, answer = split_reasoning(reply)
    assert split_channels(reply) == (think, answer)
    assert split_channels(REPLIES[1]) == ("a < b and <thin ice", "(A)")
    assert split_channels("no tags at all") == ("", "no tags at all")
    assert split_channels(REPLIES[3]) == ("only reasoning, never answered", "")


def test_a_tag_split_across_pieces_is_never_shown_as_text() -> None:
    splitter = ReasoningSplitter()
    shown = [d.text for piece in ["<thi", "nk>soft", " gel</th", "ink><ans", "wer>B</answer>"]
             for d in splitter.feed(piece)]
    assert "".join(shown) == "soft gelB" and all("<" not in s for s in shown)


def test_stop_strings_cut_the_reply_and_hold_back_what_may_become_one() -> None:
    stop = StopMatcher(["</answer>", "STOP"])
    assert stop.push("<answer>soft</ans") == ("<answer>soft", False)
    assert stop.push("<answer>soft</answer> more") == ("<answer>soft", True)
    assert stop.push("all ST") == ("all ", False)
    assert StopMatcher([]).push("anything") == ("anything", False)
