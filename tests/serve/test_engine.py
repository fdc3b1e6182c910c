"""The engine behind ask, the server and the demo: streaming, batching, stops, seeds, limits, cancellation."""

from __future__ import annotations

import threading
from collections.abc import Callable
from pathlib import Path

import pytest

from tacreasoner.serve import Delta, Prompt, Reply, RequestError, Sampling, TactileEngine
from tacreasoner.serve.engine import MIN_CLIP_FRAMES, DecodeTimeout
from tacreasoner.tasks.extract import split_reasoning
from tests.serve.served import ONE, REPLIES, TWO, press_clip


@pytest.fixture(scope="module")
def engine(served_model: Path) -> TactileEngine:
    return TactileEngine.load(served_model, device="cpu")


def test_the_stream_is_token_by_token_and_joins_to_the_complete_reply(engine: TactileEngine,
                                                                      clip_files: list[Path]) -> None:
    prompt = Prompt.ask(ONE, [clip_files[0]])
    pieces = list(engine.stream(prompt, Sampling(max_new_tokens=40)))
    deltas, reply = pieces[:-1], pieces[-1]
    assert isinstance(reply, Reply) and all(isinstance(d, Delta) for d in deltas)
    assert len(deltas) > 5, "reasoning arrives in pieces as it is generated"
    assert deltas[0].channel == "reasoning" and deltas[-1].channel == "content"
    assert "".join(d.text for d in deltas if d.channel == "reasoning").rstrip() == reply.reasoning
    assert "".join(d.text for d in deltas if d.channel == "content").rstrip() == reply.content
    think, answer = split_reasoning(REPLIES[ONE])
    assert (reply.reasoning, reply.content, reply.finish_reason) == (think, answer, "stop")
    assert reply.completion_tokens > 5 and reply.prompt_tokens > 10 and reply.timings["first_token_s"] > 0
    assert engine.complete(prompt, Sampling(max_new_tokens=40)).text == reply.text


def test_a_batch_answers_as_each_request_alone(engine: TactileEngine, clip_files: list[Path]) -> None:
    prompts = [Prompt.ask(ONE, [clip_files[0]]), Prompt.ask(TWO, clip_files[:2]), Prompt.ask(ONE, [clip_files[1]])]
    samplings = [Sampling(max_new_tokens=40), Sampling(max_new_tokens=40), Sampling(max_new_tokens=3)]
    batched = engine.complete_batch(prompts, samplings)
    alone = [engine.complete(p, s) for p, s in zip(prompts, samplings, strict=True)]
    assert [r.text for r in batched] == [r.text for r in alone]
    assert batched[1].content == "A" and batched[2].finish_reason == "length" and batched[2].completion_tokens == 3
    with pytest.raises(ValueError, match="batch_key"):
        engine.complete_batch(prompts[:2], [Sampling(), Sampling(temperature=0.7, seed=1)])


def test_stop_strings_end_the_reply_before_them(engine: TactileEngine, clip_files: list[Path]) -> None:
    reply = engine.complete(Prompt.ask(ONE, [clip_files[0]]), Sampling(max_new_tokens=40, stop=("deep",)))
    assert reply.finish_reason == "stop" and "deep" not in reply.text and reply.reasoning == "The imprint is"


def test_a_seed_makes_sampling_reproducible(engine: TactileEngine, clip_files: list[Path]) -> None:
    prompt = Prompt.ask("What does <tactile> feel like?", [clip_files[2]])
    hot = Sampling(max_new_tokens=12, temperature=2.0, top_p=1.0, seed=7)
    assert engine.complete(prompt, hot).text == engine.complete(prompt, hot).text
    texts = {engine.complete(prompt, Sampling(max_new_tokens=12, temperature=2.0, seed=s)).text for s in range(4)}
    assert len(texts) > 1, "different seeds sample different replies"


def test_the_clients_faults_are_request_errors(engine: TactileEngine, clip_files: list[Path], tmp_path: Path) -> None:
    with pytest.raises(RequestError, match=r"1 <tactile> placeholder.*2 video"):
        engine.prepare(Prompt.ask(ONE, clip_files[:2]))
    (tmp_path / "junk.mp4").write_bytes(b"not a video")
    with pytest.raises(RequestError, match=r"junk\.mp4"):
        engine.prepare(Prompt.ask(ONE, [tmp_path / "junk.mp4"]))
    with pytest.raises(RequestError, match="temperature"):
        Sampling(temperature=3.0)
    with pytest.raises(RequestError, match="reads at most"):
        engine.prepare(Prompt.ask(ONE + " very" * 2000, [clip_files[0]]))


def test_cancelling_and_the_deadline_stop_decoding(engine: TactileEngine, clip_files: list[Path]) -> None:
    prompt = Prompt.ask("Describe <tactile> at length.", [clip_files[2]])
    cancelled = threading.Event()
    cancelled.set()
    reply = list(engine.stream(prompt, Sampling(max_new_tokens=200), cancelled=cancelled))[-1]
    assert reply.completion_tokens < 200
    with pytest.raises(DecodeTimeout, match="limit") as caught:
        list(engine.stream(prompt, Sampling(max_new_tokens=200), timeout_s=0.0))
    assert caught.value.partial is not None and caught.value.partial.completion_tokens < 200


def test_a_clip_needs_at_least_two_frames(engine: TactileEngine, write_clip: Callable[..., Path]) -> None:
    one = press_clip(0)[5:6]
    with pytest.raises(RequestError, match=rf"video 1: the clip has 1 frame .*at least {MIN_CLIP_FRAMES} are needed") \
            as caught:
        engine.prepare(Prompt.ask(ONE, [one]))
    assert caught.value.code == "video_too_short"
    with pytest.raises(RequestError, match="the clip has 1 frame"):
        engine.prepare(Prompt.ask(ONE, [write_clip("one.mp4", one)]))
    assert MIN_CLIP_FRAMES == 2
    engine.prepare(Prompt.ask(ONE, [press_clip(0)[5:7]]))  # two frames: a change to read


def test_timings_count_preparing_done_before_the_call(engine: TactileEngine, clip_files: list[Path]) -> None:
    prepared = engine.prepare(Prompt.ask(ONE, [clip_files[0]]))
    assert prepared.prepare_s > 0
    for reply in (engine.complete(prepared, Sampling(max_new_tokens=4)),
                  engine.complete_batch([prepared, prepared], [Sampling(max_new_tokens=4)] * 2)[0]):
        t = reply.timings
        assert t["prepare_s"] >= round(prepared.prepare_s, 4) > 0
        assert t["total_s"] == pytest.approx(t["prepare_s"] + t["decode_s"], abs=2e-4)
    with pytest.raises(RequestError, match="max_tokens must be at least 1, got 0"):
        Sampling(max_new_tokens=0)


def test_a_bfloat16_engine_answers_with_bf16_weights(served_model: Path, clip_files: list[Path]) -> None:
    """`--dtype bfloat16` (ask, serve, demo): the weights are cast, the clip still goes through, a whole reply comes."""
    import torch

    engine = TactileEngine.load(served_model, device="cpu", dtype="bfloat16")
    assert {p.dtype for p in engine.model.parameters()} == {torch.bfloat16}
    reply = engine.complete(Prompt.ask(ONE, [clip_files[0]]), Sampling(max_new_tokens=40))
    assert reply.finish_reason == "stop" and reply.reasoning and reply.content
    with pytest.raises(ValueError, match="dtype must be one of"):
        TactileEngine.load(served_model, device="cpu", dtype="float16")
