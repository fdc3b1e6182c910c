"""A teacher behind any OpenAI-compatible chat API: OpenAI, DeepSeek (the paper's teacher), vLLM, ….

Uses the official ``openai`` client with its own retries switched off (``max_retries=0``) so that every
attempt is counted, the backoff is ours (exponential, full jitter, ``Retry-After`` honoured but capped)
and malformed replies are retried too, which the client does not do. Concurrency is bounded per teacher.
DeepSeek-reasoner's separate reasoning channel (``reasoning_content``; ``reasoning`` on newer vLLM) is
kept in :attr:`TeacherReply.reasoning`.
"""

from __future__ import annotations

import asyncio
import email.utils
import json
import math
import os
import random
import time
from typing import Any

from tacreasoner.cot.schema import CoTJob, Prompt, TeacherReply
from tacreasoner.cot.teacher import TeacherConfig, TeacherError, UsageMeter, cost_of

_RESERVED = ("model", "messages", "stream", "n")
_RETRYABLE_4XX = (408, 409, 429)
_FATAL = (401, 403, 404)
"""Statuses that will fail every later call too: the teacher stops calling the API after one."""


class _MalformedReply(Exception):
    """A 200 whose body is not a chat completion (no choices, not JSON, wrong shape)."""


class OpenAITeacher:
    """Chat-completions teacher. Safe to use from several ``asyncio.run`` calls in turn (the client and the
    semaphore are made per event loop)."""

    name = "openai"

    def __init__(self, config: TeacherConfig, *, rng: random.Random | None = None) -> None:
        try:
            import openai  # noqa: F401
        except ImportError:
            raise ImportError("the openai teacher needs the openai package: pip install 'tacreasoner[api]'") from None
        if not config.model.strip():
            raise ValueError("teacher: the openai backend needs a model name (e.g. deepseek-chat)")
        bad = sorted(set(config.extra) & set(_RESERVED))
        if bad:
            raise ValueError(f"teacher: extra may not set {bad}; they are fixed by the teacher")
        key = os.environ.get(config.api_key_env, "").strip()
        if not key:
            raise ValueError(f"teacher: no API key in environment variable {config.api_key_env} "
                             "(a local server without auth takes any value, e.g. EMPTY)")
        self.config = config
        self.model = config.model
        self.usage = UsageMeter()
        self._api_key = key
        self._rng = rng or random.Random()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._client: Any = None
        self._semaphore: asyncio.Semaphore | None = None
        self._fatal: TeacherError | None = None

    @property
    def endpoint(self) -> str:
        return self.config.base_url or os.environ.get("OPENAI_BASE_URL") or "https://api.openai.com/v1"

    def _session(self) -> tuple[Any, asyncio.Semaphore]:
        """Client + semaphore of the running event loop (asyncio objects must not cross loops)."""
        from openai import AsyncOpenAI

        loop = asyncio.get_running_loop()
        if self._loop is not loop or self._client is None or self._semaphore is None:
            self._client = AsyncOpenAI(base_url=self.config.base_url, api_key=self._api_key,
                                       timeout=self.config.timeout_s, max_retries=0)
            self._semaphore = asyncio.Semaphore(self.config.concurrency)
            self._loop = loop
        return self._client, self._semaphore

    async def aclose(self) -> None:
        """Close the HTTP connections of the current loop's client (optional; the process exit does it too)."""
        if self._client is not None and self._loop is asyncio.get_running_loop():
            await self._client.close()
        self._client = self._semaphore = self._loop = None

    def _request(self, prompt: Prompt) -> dict[str, Any]:
        messages = [{"role": "system", "content": prompt.system}] if prompt.system.strip() else []
        messages.append({"role": "user", "content": prompt.user})
        request: dict[str, Any] = {"model": self.config.model, "messages": messages,
                                   "temperature": self.config.temperature}
        if "max_completion_tokens" not in self.config.extra:  # newer OpenAI models want that name instead
            request["max_tokens"] = self.config.max_tokens
        if self.config.extra:
            request["extra_body"] = dict(self.config.extra)
        return request

    async def generate(self, job: CoTJob, prompt: Prompt) -> TeacherReply:
        """One reply for ``prompt``, retried on transient failures; raises :class:`TeacherError` when it gives up."""
        client, semaphore = self._session()
        attempts = 0
        while True:
            self._raise_if_fatal(attempts)
            attempts += 1
            try:
                async with semaphore:
                    self._raise_if_fatal(attempts - 1)  # another task hit a fatal error while this one waited
                    response = await client.chat.completions.create(**self._request(prompt))
                reply = self._reply(response, attempts)
            except Exception as exc:
                await asyncio.sleep(self._after_failure(exc, attempts))
                continue
            self.usage.record_attempt("ok")
            self.usage.record_tokens(reply.prompt_tokens, reply.completion_tokens, reply.cost_usd)
            return reply

    def _raise_if_fatal(self, attempts: int) -> None:
        """After a bad key / model, later calls fail at once instead of sending what would fail the same way."""
        if self._fatal is not None:
            self.usage.record_failure()
            raise TeacherError(str(self._fatal), status=self._fatal.status, attempts=attempts, fatal=True)

    def _after_failure(self, exc: Exception, attempts: int) -> float:
        """Count a failed attempt; the seconds to wait before retrying, or raise when there is no retry."""
        outcome = self._classify(exc)
        if outcome is None:  # not an API failure (a bug, or a TeacherError already counted): as it is
            raise exc
        status, retryable, hint = outcome
        self.usage.record_attempt(status)
        if not retryable:
            self.usage.record_failure()
            raise self._fatal_or_plain(exc, attempts) from exc
        if attempts > self.config.max_retries:
            self.usage.record_failure()
            raise TeacherError(f"{self.endpoint}: gave up after {attempts} attempts; last error: {_one_line(exc)}",
                               status=getattr(exc, "status_code", None), attempts=attempts) from exc
        self.usage.record_retry()
        return self._backoff(attempts, hint)

    def _reply(self, response: Any, attempts: int) -> TeacherReply:
        try:
            choice = response.choices[0]
            message = choice.message
            content = message.content
        except (AttributeError, IndexError, KeyError, TypeError):
            raise _MalformedReply(f"not a chat completion: {str(response)[:200]!r}") from None
        if content is not None and not isinstance(content, str):
            raise _MalformedReply(f"message content is {type(content).__name__}, not text")
        if getattr(choice, "finish_reason", None) == "length":
            self.usage.record_truncated()
        usage = getattr(response, "usage", None)
        prompt_tokens = int(getattr(usage, "prompt_tokens", 0) or 0)
        completion_tokens = int(getattr(usage, "completion_tokens", 0) or 0)
        return TeacherReply(
            text=content or "", reasoning=_reasoning_of(message), model=getattr(response, "model", None) or self.model,
            prompt_tokens=prompt_tokens, completion_tokens=completion_tokens,
            cost_usd=cost_of(self.config, prompt_tokens, completion_tokens), attempts=attempts,
        )

    def _classify(self, exc: Exception) -> tuple[str, bool, float | None] | None:
        """(status class, retryable, server-asked delay) for an attempt's exception; None = not an API failure."""
        import openai

        if isinstance(exc, openai.APITimeoutError):
            return "timeout", True, None
        if isinstance(exc, openai.APIConnectionError):
            return "connection", True, None
        if isinstance(exc, (_MalformedReply, json.JSONDecodeError, openai.APIResponseValidationError)):
            return "malformed", True, None
        if isinstance(exc, openai.APIStatusError):
            code = exc.status_code
            hint = _retry_after(exc.response.headers)
            if code == 429:
                return "429", True, hint
            if code >= 500:
                return "5xx", True, hint
            return "4xx", code in _RETRYABLE_4XX, hint
        return None

    def _fatal_or_plain(self, exc: Exception, attempts: int) -> TeacherError:
        code = getattr(exc, "status_code", None)
        detail = _api_message(exc)
        message = f"{self.endpoint} answered HTTP {code}: {detail}"
        if code == 401:
            message += f"; check the API key in env var {self.config.api_key_env}"
        elif code == 403:
            message += f"; the key in {self.config.api_key_env} may not use model {self.model!r}"
        elif code == 404:
            message += f"; check the model name {self.model!r} and base_url"
        error = TeacherError(message, status=code, attempts=attempts, fatal=code in _FATAL)
        if error.fatal:
            self._fatal = error
        return error

    def _backoff(self, attempt: int, hint: float | None) -> float:
        """Seconds to wait before retry ``attempt`` (1-based): the server's ``Retry-After`` if it gave one,
        else full jitter over an exponential ceiling; both capped by ``backoff_max_s``."""
        cap = self.config.backoff_max_s
        if hint is not None:
            return min(max(hint, 0.0), cap)
        ceiling = min(cap, self.config.backoff_base_s * 2 ** min(attempt - 1, 30))
        return self._rng.uniform(0.0, ceiling)


def _reasoning_of(message: Any) -> str | None:
    """DeepSeek's ``reasoning_content`` (vLLM: ``reasoning``): not in the client's types, so it arrives as
    an extra field (attribute access and ``model_extra`` both work)."""
    extra = getattr(message, "model_extra", None) or {}
    for key in ("reasoning_content", "reasoning"):
        value = extra.get(key, getattr(message, key, None))
        if isinstance(value, str) and value.strip():
            return value
    return None


def _retry_after(headers: Any) -> float | None:
    """Seconds asked for by ``retry-after-ms`` / ``retry-after`` (number or HTTP date), if any."""
    if headers is None:
        return None
    for name, scale in (("retry-after-ms", 0.001), ("retry-after", 1.0)):
        raw = headers.get(name)
        if raw is None:
            continue
        try:
            value = float(raw) * scale
        except ValueError:
            try:
                value = email.utils.parsedate_to_datetime(raw).timestamp() - time.time()
            except (TypeError, ValueError):
                continue
        if math.isfinite(value):
            return max(value, 0.0)
    return None


def _api_message(exc: Exception) -> str:
    body = getattr(exc, "body", None)
    if isinstance(body, dict):
        inner = body.get("error", body)
        if isinstance(inner, dict) and inner.get("message"):
            return _one_line(inner["message"])
    return _one_line(getattr(exc, "message", None) or exc)


def _one_line(value: Any) -> str:
    text = " ".join(str(value).split())
    return text if len(text) <= 300 else text[:297] + "..."
