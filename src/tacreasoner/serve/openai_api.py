"""An OpenAI-compatible HTTP API for a saved model (FastAPI; the ``serve`` extra).

``POST /v1/chat/completions`` takes the chat API's request with tactile videos as ``video_url`` content parts (see
:mod:`tacreasoner.serve.media`), streamed as server-sent events with ``stream: true``. The reply's ``content`` is the
answer and ``reasoning_content`` the reasoning (DeepSeek's convention). ``GET /v1/models`` and ``GET /health``
complete it; ``GET /openapi.json`` is the schema (behind the API key, like ``/v1/``, when the server has one).
Every error is the API's JSON error object: 4xx for the client's faults, 5xx for ours, never a traceback (that goes
to the server's log with an id the client sees).
"""

from __future__ import annotations

import asyncio
import hmac
import json
import logging
import time
import uuid
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass, field
from typing import Any, Literal

from fastapi import FastAPI, Request
from fastapi.responses import JSONResponse, StreamingResponse
from pydantic import BaseModel, ConfigDict, ValidationError
from starlette.concurrency import run_in_threadpool
from starlette.exceptions import HTTPException as StarletteHTTPException

from tacreasoner.evaluate.predict import REPLY_TOKENS
from tacreasoner.serve.engine import DecodeTimeout, Reply, RequestError, Sampling, TactileEngine
from tacreasoner.serve.media import MediaLimits, messages_to_prompt
from tacreasoner.serve.scheduler import Busy, Scheduler
from tacreasoner.serve.stepwise import StepwiseAnswerer
from tacreasoner.serve.stream import Delta

__all__ = ["ServerSettings", "create_app"]

log = logging.getLogger("tacreasoner.serve")


@dataclass(frozen=True)
class ServerSettings:
    """What ``tacreasoner serve`` lets one change; the defaults suit a robot on the same machine or network."""

    api_key: str | None = None
    max_request_bytes: int = 64 * 2**20
    decode_timeout_s: float = 120.0
    max_pending: int = 64
    max_batch: int = 8
    """Non-streamed requests answered together by one batched call; 1 turns batching off."""
    batch_window_s: float = 0.01
    prepare_workers: int = 1
    """Requests whose videos are decoded at once, beside the model's thread: a flood of (malformed) requests then
    takes one core at most, never the model's."""
    limits: MediaLimits = field(default_factory=MediaLimits)
    answers: str = "direct"
    """``stepwise`` or ``stepwise-vote``: a greedy one-turn question comparing objects is answered by reading each
    video in a pass of its own and concluding by rule (:mod:`tacreasoner.serve.stepwise`); others in one pass."""
    vocabulary: str = "physiclear"
    """The level words the stepwise readings are in (the model's training benchmark's)."""

    def __post_init__(self) -> None:
        for name in ("max_request_bytes", "decode_timeout_s", "max_pending", "max_batch"):
            if not getattr(self, name) > 0:
                raise ValueError(f"ServerSettings.{name} must be above 0, got {getattr(self, name)}")
        StepwiseAnswerer(self.answers, self.vocabulary)  # a known answering mode and vocabulary


class ChatRequest(BaseModel):
    """The fields of OpenAI's chat completion request this server reads; others are accepted and ignored."""

    model_config = ConfigDict(extra="ignore")

    model: str
    messages: list[dict[str, Any]]
    stream: bool = False
    temperature: float | None = None
    top_p: float | None = None
    max_tokens: int | None = None
    max_completion_tokens: int | None = None
    seed: int | None = None
    stop: str | list[str] | None = None
    n: int = 1
    stream_options: dict[str, Any] | None = None

    def sampling(self) -> Sampling:
        stop = [self.stop] if isinstance(self.stop, str) else list(self.stop or [])
        if len(stop) > 4:
            raise RequestError("stop: at most 4 stop strings", param="stop")
        if self.n != 1:
            raise RequestError("n: this server returns one choice per request", param="n")
        for name in ("max_completion_tokens", "max_tokens"):  # 0 is refused like OpenAI does, not read as unset
            value = getattr(self, name)
            if value is not None and value < 1:
                raise RequestError(f"{name} must be at least 1, got {value}", param=name)
        longest = next((v for v in (self.max_completion_tokens, self.max_tokens) if v is not None), REPLY_TOKENS)
        return Sampling(max_new_tokens=longest,
                        temperature=0.0 if self.temperature is None else self.temperature,
                        top_p=1.0 if self.top_p is None else self.top_p, seed=self.seed, stop=tuple(stop))


def _error(status: int, message: str, *, kind: str = "invalid_request_error", param: str | None = None,
           code: str | None = None, headers: dict[str, str] | None = None) -> JSONResponse:
    return JSONResponse({"error": {"message": message, "type": kind, "param": param, "code": code}},
                        status_code=status, headers=headers)


def _usage(reply: Reply) -> dict[str, int]:
    return {"prompt_tokens": reply.prompt_tokens, "completion_tokens": reply.completion_tokens,
            "total_tokens": reply.prompt_tokens + reply.completion_tokens}


def create_app(engine: TactileEngine, settings: ServerSettings | None = None) -> FastAPI:
    """The app serving ``engine``; its scheduler thread starts now and stops with the app."""
    settings = settings or ServerSettings()
    stepwise = StepwiseAnswerer(settings.answers, settings.vocabulary)
    scheduler = Scheduler(engine, max_pending=settings.max_pending, max_batch=settings.max_batch,
                          batch_window_s=settings.batch_window_s, decode_timeout_s=settings.decode_timeout_s)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        yield
        await run_in_threadpool(scheduler.close)

    app = FastAPI(title="TacReasoner", version="1", docs_url=None, redoc_url=None, lifespan=lifespan)
    app.state.scheduler = scheduler
    created = int(time.time())
    prepare_slots = asyncio.Semaphore(max(1, settings.prepare_workers))

    @app.middleware("http")
    async def guard(request: Request, call_next: Any) -> Any:
        if request.method == "POST":
            length = request.headers.get("content-length")
            if length is None:
                return _error(411, "send the request with a Content-Length header", code="length_required")
            if not length.isdigit() or int(length) > settings.max_request_bytes:
                return _error(413, f"the request is larger than {settings.max_request_bytes // 2**20} MiB",
                              code="request_too_large")
        if settings.api_key and (request.url.path.startswith("/v1/") or request.url.path == app.openapi_url):
            given = request.headers.get("authorization", "")
            if not hmac.compare_digest(given.encode(), f"Bearer {settings.api_key}".encode()):
                return _error(401, "a valid API key is needed: Authorization: Bearer <key>", code="invalid_api_key")
        try:
            return await call_next(request)
        except Exception:  # the error id ties the client's message to the log's traceback
            error_id = uuid.uuid4().hex[:12]
            log.exception("request failed (error id %s)", error_id)
            return _error(500, f"internal error (id {error_id}); the server log has the details",
                          kind="server_error")

    @app.exception_handler(StarletteHTTPException)
    async def http_error(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        return _error(exc.status_code, f"{request.method} {request.url.path}: {exc.detail}")

    @app.get("/health")
    async def health() -> dict[str, Any]:
        return {"status": "ok", "model": engine.name, "waiting": scheduler.waiting, **scheduler.stats}

    @app.get("/v1/models")
    async def models() -> dict[str, Any]:
        return {"object": "list", "data": [{"id": engine.name, "object": "model", "created": created,
                                            "owned_by": "tacreasoner"}]}

    @app.post("/v1/chat/completions")
    async def chat(request: Request) -> Any:
        try:
            body = json.loads(await request.body())
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            return _error(400, f"the body is not JSON ({exc})", code="invalid_json")
        if not isinstance(body, dict):
            return _error(400, f"the body must be a JSON object (the chat completion request), got a JSON "
                               f"{_json_kind(body)}", code="invalid_json")
        try:
            req = ChatRequest.model_validate(body)
        except ValidationError as exc:
            first = exc.errors()[0]
            where = ".".join(str(p) for p in first["loc"])
            return _error(400, f"{where}: {first['msg']}", param=where)
        if req.model != engine.name:
            return _error(404, f"model {req.model!r} is not served here; GET /v1/models lists {engine.name!r}",
                          param="model", code="model_not_found")
        try:
            sampling = req.sampling()
            async with prepare_slots:
                prepared, work = await run_in_threadpool(_prepare, engine, req.messages, settings.limits, sampling,
                                                         stepwise)
            job = scheduler.submit(prepared, sampling, stream=req.stream, work=work)
        except RequestError as exc:
            return _error(400, str(exc), param=exc.param, code=exc.code)
        except Busy as exc:
            return _error(503, str(exc), kind="server_error", code="server_busy", headers={"Retry-After": "1"})
        ident = f"chatcmpl-{uuid.uuid4().hex}"
        if req.stream:
            include_usage = bool((req.stream_options or {}).get("include_usage"))
            return StreamingResponse(_events(job, ident, engine.name, include_usage),
                                     media_type="text/event-stream", headers={"Cache-Control": "no-cache"})
        try:
            reply: Reply = await job.out  # type: ignore[misc]
        except asyncio.CancelledError:
            job.out.cancel()  # type: ignore[union-attr]
            raise
        except DecodeTimeout as exc:
            return _error(504, str(exc), kind="server_error", code="decode_timeout")
        message = {"role": "assistant", "content": reply.content, "reasoning_content": reply.reasoning or None}
        return {"id": ident, "object": "chat.completion", "created": int(time.time()), "model": engine.name,
                "choices": [{"index": 0, "message": message, "finish_reason": reply.finish_reason,
                             "logprobs": None}],
                "usage": _usage(reply), "timings": reply.timings,
                **({"asked_as": reply.asked_as} if reply.asked_as else {})}

    return app


def _prepare(engine: TactileEngine, messages: list[dict[str, Any]], limits: MediaLimits, sampling: Sampling,
             stepwise: StepwiseAnswerer) -> tuple[Any, Callable[[TactileEngine, float | None], Reply] | None]:
    """Decode the videos and tokenise, in a worker thread (the model's thread never waits on a client's bytes);
    the time it took, decoding included, is the reply's ``timings.prepare_s``. A question answered stepwise comes
    back as the work to run instead (its videos decoded)."""
    start = time.perf_counter()
    prompt = messages_to_prompt(messages, limits)
    view = stepwise.view(prompt, sampling)
    if view is not None:
        decoded = time.perf_counter() - start

        def work(engine: TactileEngine, timeout_s: float | None) -> Reply:
            reply = stepwise.answer(engine, view, prompt.videos, timeout_s)
            reply.timings = {"prepare_s": round(decoded, 4), **reply.timings,
                             "total_s": round(decoded + reply.timings["total_s"], 4)}
            return reply

        return None, work
    prepared = engine.prepare(prompt)
    prepared.prepare_s = time.perf_counter() - start
    return prepared, None


def _json_kind(value: Any) -> str:
    """What a JSON value is, in JSON's words (never a Python class name)."""
    kinds = ((list, "array"), (str, "string"), (bool, "boolean"), (int | float, "number"), (type(None), "null"))
    return next((name for kind, name in kinds if isinstance(value, kind)), "value")


def _chunk(ident: str, model: str, delta: dict[str, Any], finish: str | None = None,
           usage: dict[str, int] | None = None) -> str:
    choices = [] if usage is not None else [{"index": 0, "delta": delta, "finish_reason": finish, "logprobs": None}]
    body: dict[str, Any] = {"id": ident, "object": "chat.completion.chunk", "created": int(time.time()),
                            "model": model, "choices": choices}
    if usage is not None:
        body["usage"] = usage
    return f"data: {json.dumps(body)}\n\n"


async def _events(job: Any, ident: str, model: str, include_usage: bool) -> AsyncIterator[str]:
    """Server-sent events: the role, reasoning and answer deltas, the finish reason, usage on request, [DONE]."""
    field_of: dict[str, Literal["reasoning_content", "content"]] = {"reasoning": "reasoning_content",
                                                                     "content": "content"}
    try:
        yield _chunk(ident, model, {"role": "assistant", "content": ""})
        while (piece := await job.out.get()) is not None:
            if isinstance(piece, Delta):
                yield _chunk(ident, model, {field_of[piece.channel]: piece.text})
            elif isinstance(piece, Reply):
                yield _chunk(ident, model, {}, piece.finish_reason)
                if include_usage:
                    yield _chunk(ident, model, {}, usage=_usage(piece))
            else:  # an exception from the model's thread: the stream ends with an error event
                code = "decode_timeout" if isinstance(piece, DecodeTimeout) else None
                told = isinstance(piece, DecodeTimeout | RequestError)
                if not told:
                    log.error("streamed request failed", exc_info=piece)
                error = {"message": str(piece) if told else "internal error", "type": "server_error", "code": code}
                yield f"data: {json.dumps({'error': error})}\n\n"
        yield "data: [DONE]\n\n"
    finally:
        job.cancelled.set()  # a client that went away stops the decoding it asked for
