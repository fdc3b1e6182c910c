"""The OpenAI-compatible server, started on loopback and spoken to with the official ``openai`` client."""

from __future__ import annotations

import base64
import io
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import httpx
import openai
import pytest

from tacreasoner.serve import TactileEngine
from tacreasoner.serve.engine import MIN_CLIP_FRAMES
from tacreasoner.serve.http import ServerThread
from tacreasoner.serve.media import MediaLimits, video_data_url
from tacreasoner.serve.openai_api import ServerSettings, create_app
from tacreasoner.tasks.extract import split_reasoning
from tests.serve.served import ONE, REPLIES, TWO, free_port, press_clip

KEY = "test-key"


@pytest.fixture(scope="module")
def engine(served_model: Path) -> TactileEngine:
    return TactileEngine.load(served_model, device="cpu")


def _server(engine: TactileEngine, port: int, **settings: Any) -> ServerThread:
    return ServerThread(create_app(engine, ServerSettings(**settings)), port=port)


@pytest.fixture(scope="module")
def url(engine: TactileEngine, clip_files: list[Path]) -> Iterator[str]:
    limits = MediaLimits(max_videos=3, allowed_dirs=(clip_files[0].parent.resolve(),))
    with _server(engine, free_port(), api_key=KEY, max_request_bytes=2 * 2**20, limits=limits) as base:
        yield base


def _client(url: str, key: str = KEY) -> openai.OpenAI:
    return openai.OpenAI(base_url=f"{url}/v1", api_key=key, max_retries=0, timeout=60)


def _video(path: Path) -> dict[str, Any]:
    return {"type": "video_url", "video_url": {"url": video_data_url(path)}}


def _ask(text: str, *videos: dict[str, Any]) -> list[dict[str, Any]]:
    return [{"role": "user", "content": [*videos, {"type": "text", "text": text}]}]


def test_a_request_gets_the_answer_in_content_and_the_reasoning_beside_it(url: str, clip_files: list[Path]) -> None:
    client = _client(url)
    assert [m.id for m in client.models.list()] == ["tacreasoner"]
    reply = client.chat.completions.create(model="tacreasoner", messages=_ask(ONE, _video(clip_files[0])),
                                           max_tokens=40)
    think, answer = split_reasoning(REPLIES[ONE])
    message = reply.choices[0].message
    assert (message.content, message.reasoning_content) == (answer, think)
    assert reply.choices[0].finish_reason == "stop" and reply.object == "chat.completion"
    assert reply.usage.completion_tokens > 5 and reply.usage.total_tokens == \
        reply.usage.prompt_tokens + reply.usage.completion_tokens


def test_a_streamed_request_arrives_token_by_token(url: str, clip_files: list[Path]) -> None:
    stream = _client(url).chat.completions.create(model="tacreasoner", messages=_ask(ONE, _video(clip_files[0])),
                                                  max_tokens=40, stream=True, stream_options={"include_usage": True})
    chunks = list(stream)
    deltas = [c.choices[0].delta for c in chunks if c.choices]
    reasoning = "".join(getattr(d, "reasoning_content", None) or "" for d in deltas)
    content = "".join(d.content or "" for d in deltas)
    assert (reasoning.strip(), content.strip()) == split_reasoning(REPLIES[ONE])
    assert sum(bool(getattr(d, "reasoning_content", None)) for d in deltas) > 5
    assert [c.choices[0].finish_reason for c in chunks if c.choices][-1] == "stop"
    assert chunks[-1].usage is not None and chunks[-1].usage.completion_tokens > 5


def test_two_videos_in_one_message_placed_by_placeholders_or_by_their_parts(url: str,
                                                                            clip_files: list[Path]) -> None:
    client = _client(url)
    placed = client.chat.completions.create(
        model="tacreasoner", messages=_ask(TWO, _video(clip_files[0]), _video(clip_files[1])), max_tokens=40)
    assert placed.choices[0].message.content == "A"
    by_parts = [{"role": "user", "content": [{"type": "text", "text": "Which of"}, _video(clip_files[0]),
                                             {"type": "text", "text": "and"}, _video(clip_files[1]),
                                             {"type": "text", "text": "is rougher? (A) first (B) second"}]}]
    reply = client.chat.completions.create(model="tacreasoner", messages=by_parts, max_tokens=40)
    assert reply.choices[0].message.content == "A", "the parts give the same prompt as the placeholders"
    on_disk = [{"role": "user", "content": [
        {"type": "video_url", "video_url": {"url": clip_files[0].resolve().as_uri()}},
        {"type": "text", "text": ONE}]}]
    assert client.chat.completions.create(model="tacreasoner", messages=on_disk, max_tokens=40) \
        .choices[0].message.content == "soft"


def _truncated(path: Path) -> dict[str, Any]:
    data = path.read_bytes()
    return {"type": "video_url", "video_url": {"url": "data:video/mp4;base64," +
                                               base64.b64encode(data[: len(data) // 2]).decode()}}


def _raw(data: bytes, mime: str = "video/mp4") -> dict[str, Any]:
    return {"type": "video_url", "video_url": {"url": f"data:{mime};base64,{base64.b64encode(data).decode()}"}}


BAD: dict[str, tuple[Callable[[list[Path]], dict[str, Any]], type[openai.APIStatusError], str]] = {
    "bad base64": (lambda c: _ask(ONE, {"type": "video_url", "video_url": {"url": "data:video/mp4;base64,@@@"}}),
                   openai.BadRequestError, "invalid_base64"),
    "not a video": (lambda c: _ask(ONE, _raw(b"GIF89a" + bytes(500))), openai.BadRequestError, "invalid_video"),
    "an image type": (lambda c: _ask(ONE, _raw(b"\x89PNG", "image/png")), openai.BadRequestError, "invalid_video"),
    "a truncated video": (lambda c: _ask(ONE, _truncated(c[0])), openai.BadRequestError, "invalid_video"),
    "too many videos": (lambda c: _ask("<tactile>" * 4, *[_video(c[0])] * 4), openai.BadRequestError,
                        "too_many_videos"),
    "placeholders unlike the videos": (lambda c: _ask(TWO, _video(c[0])), openai.BadRequestError,
                                       "placeholder_mismatch"),
    "a file outside the allowed directory": (
        lambda c: _ask(ONE, {"type": "video_url", "video_url": {"url": "file:///etc/hostname"}}),
        openai.BadRequestError, "file_url_not_allowed"),
    "a remote URL": (lambda c: _ask(ONE, {"type": "video_url", "video_url": {"url": "https://x.org/a.mp4"}}),
                     openai.BadRequestError, "invalid_video_url"),
    "too large": (lambda c: _ask(ONE, _raw(bytes(3 * 2**20))), openai.APIStatusError, "request_too_large"),
}


@pytest.mark.parametrize("case", list(BAD))
def test_each_client_fault_is_a_4xx_error_and_the_server_keeps_serving(url: str, clip_files: list[Path],
                                                                       case: str) -> None:
    make, error, code = BAD[case]
    client = _client(url)
    with pytest.raises(error) as caught:
        client.chat.completions.create(model="tacreasoner", messages=make(clip_files), max_tokens=8)
    assert 400 <= caught.value.status_code < 500 and caught.value.code == code
    assert "Traceback" not in str(caught.value.body)
    assert client.chat.completions.create(model="tacreasoner", messages=_ask(ONE, _video(clip_files[0])),
                                          max_tokens=40).choices[0].message.content == "soft"


def test_unknown_models_keys_and_parameters_are_refused(url: str, clip_files: list[Path]) -> None:
    messages = _ask(ONE, _video(clip_files[0]))
    with pytest.raises(openai.NotFoundError, match="not served here"):
        _client(url).chat.completions.create(model="gpt-4o", messages=messages)
    with pytest.raises(openai.AuthenticationError):
        _client(url, key="wrong").chat.completions.create(model="tacreasoner", messages=messages)
    with pytest.raises(openai.BadRequestError, match="temperature"):
        _client(url).chat.completions.create(model="tacreasoner", messages=messages, temperature=5)
    with pytest.raises(openai.BadRequestError, match="n: this server returns one choice"):
        _client(url).chat.completions.create(model="tacreasoner", messages=messages, n=2)
    health = httpx.get(f"{url}/health").json()
    assert health["status"] == "ok"


def test_sampling_parameters_are_honoured(url: str, clip_files: list[Path]) -> None:
    client = _client(url)
    messages = _ask("What does <tactile> feel like?", _video(clip_files[2]))
    seeded = [client.chat.completions.create(model="tacreasoner", messages=messages, max_tokens=10, temperature=1.5,
                                             top_p=0.9, seed=3).choices[0].message for _ in range(2)]
    assert seeded[0].content == seeded[1].content and seeded[0].reasoning_content == seeded[1].reasoning_content
    short = client.chat.completions.create(model="tacreasoner", messages=_ask(ONE, _video(clip_files[0])),
                                           max_tokens=3)
    assert short.choices[0].finish_reason == "length" and short.usage.completion_tokens == 3
    stopped = client.chat.completions.create(model="tacreasoner", messages=_ask(ONE, _video(clip_files[0])),
                                             max_tokens=40, stop=["wide"])
    assert stopped.choices[0].message.reasoning_content == "The imprint is deep and"


def test_server_faults_are_5xx_without_a_traceback(engine: TactileEngine, clip_files: list[Path],
                                                   free_port: Callable[[], int],
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    messages = _ask(ONE, _video(clip_files[0]))
    with _server(engine, free_port(), decode_timeout_s=1e-6) as base:
        with pytest.raises(openai.InternalServerError) as caught:
            _client(base).chat.completions.create(model="tacreasoner", messages=messages, max_tokens=40)
        assert caught.value.status_code == 504 and caught.value.code == "decode_timeout"

    def broken(*args: Any, **kwargs: Any) -> Any:
        raise RuntimeError("secret internals")

    with _server(engine, free_port()) as base:
        monkeypatch.setattr(engine, "prepare", broken)
        with pytest.raises(openai.InternalServerError) as caught:
            _client(base).chat.completions.create(model="tacreasoner", messages=messages, max_tokens=40)
        assert caught.value.status_code == 500
        assert "secret" not in str(caught.value.body) and "Traceback" not in str(caught.value.body)
        assert "internal error (id " in caught.value.message


def test_a_full_queue_answers_busy_instead_of_waiting(engine: TactileEngine, clip_files: list[Path],
                                                      free_port: Callable[[], int]) -> None:
    messages = _ask(ONE, _video(clip_files[0]))
    results: list[Any] = []

    def call(base: str) -> None:
        try:
            results.append(_client(base).chat.completions.create(model="tacreasoner", messages=messages,
                                                                  max_tokens=40))
        except openai.APIStatusError as exc:
            results.append(exc)

    with _server(engine, free_port(), max_pending=1, max_batch=1) as base:
        with engine.lock:  # the model is busy: one request runs (blocked), one waits, the third is refused
            threads = [threading.Thread(target=call, args=(base,)) for _ in range(3)]
            for t in threads:
                t.start()
                time.sleep(0.5)
            deadline = time.monotonic() + 10
            while not results and time.monotonic() < deadline:
                time.sleep(0.05)
            assert len(results) == 1 and isinstance(results[0], openai.APIStatusError)
            assert results[0].status_code == 503 and results[0].code == "server_busy"
        for t in threads:
            t.join(timeout=60)
    assert sum(not isinstance(r, Exception) for r in results) == 2


def _png() -> bytes:
    """A real PNG image (FFmpeg reads one as a one-frame video)."""
    from PIL import Image

    buffer = io.BytesIO()
    Image.fromarray(press_clip(0)[6]).save(buffer, format="PNG")
    return buffer.getvalue()


NO_USABLE_CLIP: dict[str, tuple[Callable[[Callable[..., Path]], list[dict[str, Any]]], str, tuple[str, ...]]] = {
    "a tactile question without a clip": (lambda t: _ask("Is this object soft or hard?"), "missing_video",
                                          ("no tactile clip was sent", "video_url")),
    "a placeholder without a clip": (lambda t: [{"role": "user", "content": ONE}], "placeholder_mismatch",
                                     ("1 <tactile> placeholder", "no tactile clip")),
    "a placeholder without a clip, as parts": (lambda t: _ask(ONE), "placeholder_mismatch",
                                               ("1 <tactile> placeholder", "no tactile clip")),
    "a PNG sent as video/mp4": (lambda t: _ask(ONE, _raw(_png())), "video_too_short",
                                ("the clip has 1 frame", "at least 2 are needed")),
    "a one-frame video": (lambda write: _ask(ONE, _video(write("one.mp4", press_clip(0)[5:6]))), "video_too_short",
                          ("the clip has 1 frame", "at least 2 are needed")),
}


@pytest.mark.parametrize("case", list(NO_USABLE_CLIP))
def test_a_question_without_a_usable_clip_is_refused_not_answered(url: str, write_clip: Callable[..., Path],
                                                                  case: str) -> None:
    make, code, said = NO_USABLE_CLIP[case]
    with pytest.raises(openai.BadRequestError) as caught:
        _client(url).chat.completions.create(model="tacreasoner", messages=make(write_clip), max_tokens=8)
    assert caught.value.status_code == 400 and caught.value.code == code
    message = caught.value.body["message"]  # type: ignore[index]
    assert all(s in message for s in said), message
    assert f"at least {MIN_CLIP_FRAMES}" in message or code != "video_too_short"


@pytest.mark.parametrize("case", ["not a video", "a truncated video"])
def test_a_video_error_says_its_reason_once(url: str, clip_files: list[Path], case: str) -> None:
    make, _, _ = BAD[case]
    with pytest.raises(openai.BadRequestError) as caught:
        _client(url).chat.completions.create(model="tacreasoner", messages=make(clip_files), max_tokens=8)
    message = caught.value.body["message"]  # type: ignore[index]
    assert message.startswith("messages[0].content[0]: ") and message.count("not a readable video") <= 1, message
    assert ".video" not in message, "the server's temporary file is not named"


@pytest.mark.parametrize("field", ["max_tokens", "max_completion_tokens"])
@pytest.mark.parametrize("value", [0, -5])
def test_max_tokens_below_one_is_refused_zero_included(url: str, clip_files: list[Path], field: str,
                                                       value: int) -> None:
    with pytest.raises(openai.BadRequestError) as caught:
        _client(url).chat.completions.create(model="tacreasoner", messages=_ask(ONE, _video(clip_files[0])),
                                             **{field: value})
    assert caught.value.body["message"] == f"{field} must be at least 1, got {value}"  # type: ignore[index]
    assert caught.value.param == field


@pytest.mark.parametrize("body", ["[1, 2]", '"hello"', "3", "null"])
def test_a_body_that_is_not_a_json_object_is_a_400_saying_so(url: str, body: str) -> None:
    answer = httpx.post(f"{url}/v1/chat/completions", content=body,
                        headers={"Authorization": f"Bearer {KEY}", "Content-Type": "application/json"})
    assert answer.status_code == 400
    message = answer.json()["error"]["message"]
    assert message.startswith("the body must be a JSON object") and "ChatRequest" not in message, message


def test_timings_count_the_time_spent_preparing_the_clip(url: str, clip_files: list[Path],
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    from tacreasoner.serve import media

    decode = media.decode_video_bytes

    def slow_decode(*args: Any, **kwargs: Any) -> Any:  # decoding this clip takes at least 0.3 s
        time.sleep(0.3)
        return decode(*args, **kwargs)

    monkeypatch.setattr(media, "decode_video_bytes", slow_decode)
    answer = httpx.post(f"{url}/v1/chat/completions", headers={"Authorization": f"Bearer {KEY}"}, timeout=60,
                        json={"model": "tacreasoner", "messages": _ask(ONE, _video(clip_files[0])), "max_tokens": 8})
    timings = answer.json()["timings"]
    assert timings["prepare_s"] >= 0.3, "the clip's decoding is part of preparing it"
    assert timings["total_s"] >= timings["prepare_s"] + timings["decode_s"] - 1e-3


def test_the_api_schema_needs_the_key_too(url: str) -> None:
    assert httpx.get(f"{url}/openapi.json").status_code == 401
    assert httpx.get(f"{url}/openapi.json", headers={"Authorization": "Bearer wrong"}).status_code == 401
    schema = httpx.get(f"{url}/openapi.json", headers={"Authorization": f"Bearer {KEY}"})
    assert schema.status_code == 200 and "/v1/chat/completions" in schema.json()["paths"]
    for page in ("/docs", "/redoc"):  # not served at all
        assert httpx.get(f"{url}{page}", headers={"Authorization": f"Bearer {KEY}"}).status_code == 404
    assert httpx.get(f"{url}/health").status_code == 200, "health stays open"


def test_without_a_key_the_schema_is_open(engine: TactileEngine, free_port: Callable[[], int]) -> None:
    with _server(engine, free_port()) as base:
        assert httpx.get(f"{base}/openapi.json").status_code == 200


COMPARE = "Which of these feels harder: <tactile> or <tactile>?"


def test_a_stepwise_server_reads_each_video_of_a_comparison_and_shows_the_readings(
        engine: TactileEngine, clip_files: list[Path], free_port: Callable[[], int]) -> None:
    two = [_video(clip_files[0]), _video(clip_files[1])]
    with _server(engine, free_port(), answers="stepwise") as base:
        client = _client(base)
        reply = client.chat.completions.create(model="tacreasoner", messages=_ask(COMPARE, *two), max_tokens=40)
        message = reply.choices[0].message
        reasoning = message.reasoning_content  # type: ignore[attr-defined]
        assert reasoning.startswith("Video 1: ") and "Video 2: " in reasoning
        assert message.content in ("the first object", "the second object")
        assert reply.model_extra["timings"]["steps"] == 2 and reply.model_extra["timings"]["prepare_s"] > 0
        pieces = list(client.chat.completions.create(model="tacreasoner", messages=_ask(COMPARE, *two),
                                                     stream=True))
        streamed = "".join(getattr(p.choices[0].delta, "reasoning_content", None) or "" for p in pieces if p.choices)
        assert streamed == reasoning, "the stream carries the same reply"
        # one video's question, and a sampled comparison, are one pass: the model's own words, no readings
        one = client.chat.completions.create(model="tacreasoner", messages=_ask(ONE, _video(clip_files[0])),
                                             max_tokens=40)
        assert one.choices[0].message.content == "soft" and "steps" not in one.model_extra["timings"]
        sampled = client.chat.completions.create(model="tacreasoner", messages=_ask(COMPARE, *two), max_tokens=8,
                                                 temperature=0.7, seed=1)
        assert "steps" not in sampled.model_extra["timings"]
    with _server(engine, free_port()) as base:  # direct by default
        plain = _client(base).chat.completions.create(model="tacreasoner", messages=_ask(COMPARE, *two),
                                                      max_tokens=8)
        assert "steps" not in plain.model_extra["timings"]
    with _server(engine, free_port(), answers="auto") as base:  # a person's comparison asked in trained words
        asked = _client(base).chat.completions.create(model="tacreasoner", messages=_ask(COMPARE, *two),
                                                      max_tokens=8)
        assert asked.model_extra["timings"]["steps"] == 1 and asked.model_extra["timings"]["prepare_s"] > 0
        assert asked.model_extra["asked_as"].endswith("Which of the two objects feels harder?")


@pytest.mark.parametrize(("setting", "value"), [("decode_timeout_s", 0.0), ("max_request_bytes", 0),
                                                ("max_pending", 0), ("max_batch", -1)])
def test_settings_that_would_fail_every_request_are_refused(setting: str, value: float) -> None:
    with pytest.raises(ValueError, match=f"ServerSettings.{setting} must be above 0"):
        ServerSettings(**{setting: value})
    with pytest.raises(ValueError, match="answers must be one of"):
        ServerSettings(answers="twice")


def test_the_python_api_answers_a_comparison_stepwise(engine: TactileEngine, clip_files: list[Path]) -> None:
    from tacreasoner.serve.stepwise import answer_stepwise

    clips = [str(clip_files[0]), str(clip_files[1])]
    reply = answer_stepwise(engine, COMPARE, clips, "physiclear")
    assert reply is not None and reply.timings["steps"] == 2 and reply.reasoning.startswith("Video 1: ")
    assert answer_stepwise(engine, ONE, clips[:1], "physiclear") is None, "one clip: left to one pass"
