"""What every teacher backend shares: the :class:`Teacher` interface, :class:`TeacherConfig`, errors, usage.

A module of its own so that the backends (``openai_backend``, ``hf_backend``) need not import the module
whose factory builds them (``backends.make_teacher``): that was an import cycle.
"""

from __future__ import annotations

import dataclasses
import math
import re
import threading
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, runtime_checkable
from urllib.parse import urlparse

from tacreasoner.cot.schema import CoTJob, Prompt, TeacherReply
from tacreasoner.fields import reject_unknown_fields
from tacreasoner.yamlfile import read_yaml

__all__ = ["BACKENDS", "DEEPSEEK_KEY_ENV", "DEFAULT_KEY_ENV", "Teacher", "TeacherConfig", "TeacherError", "UsageMeter",
           "cost_of", "load_teacher_config"]

BACKENDS = ("openai", "hf", "rules")
DEFAULT_KEY_ENV = "OPENAI_API_KEY"
DEEPSEEK_KEY_ENV = "DEEPSEEK_API_KEY"


@runtime_checkable
class Teacher(Protocol):
    """What the generation loop needs from a teacher; ``f"{name}:{model}"`` goes into every job's cache key."""

    name: str
    model: str

    async def generate(self, job: CoTJob, prompt: Prompt) -> TeacherReply: ...


class TeacherError(RuntimeError):
    """A teacher call that failed for good (after retries, or at once for a non-retryable status).

    ``fatal`` marks errors that will fail every later call too (bad key, no permission, unknown model or
    endpoint): a run can stop instead of sending the rest of its jobs into the same wall.
    """

    def __init__(self, message: str, *, status: int | None = None, attempts: int = 1, fatal: bool = False) -> None:
        super().__init__(message)
        self.status = status
        self.attempts = attempts
        self.fatal = fatal


@dataclass
class TeacherConfig:
    """How to reach and drive one teacher. Unknown keys are errors (a typo must not silently change a run)."""

    backend: str = "rules"
    """``openai`` (any OpenAI-compatible API: OpenAI, DeepSeek, vLLM, …), ``hf`` (local model) or ``rules``."""
    model: str = ""
    """API model name (``deepseek-chat``, ``deepseek-reasoner``, …) or, for ``hf``, a local directory / hub id."""
    base_url: str | None = None
    """API root, e.g. ``https://api.deepseek.com`` or ``http://localhost:8000/v1``; None = OpenAI's."""
    api_key_env: str = ""
    """Environment variable holding the key; empty = ``DEEPSEEK_API_KEY`` for a deepseek.com base URL,
    else ``OPENAI_API_KEY``. The key itself never goes into a config file."""
    temperature: float = 0.7
    max_tokens: int = 1024
    concurrency: int = 8
    """Requests in flight at once (per teacher)."""
    timeout_s: float = 120.0
    max_retries: int = 5
    """Retries after the first attempt on 429, 5xx, timeouts, connection errors and malformed replies."""
    backoff_base_s: float = 1.0
    backoff_max_s: float = 60.0
    """Cap on one backoff sleep, including one asked for by a ``Retry-After`` header."""
    price_per_1k_prompt: float = 0.0
    price_per_1k_completion: float = 0.0
    extra: dict[str, Any] = field(default_factory=dict)
    """Backend-specific options: ``openai`` sends them as extra request-body fields (``top_p``, vLLM's
    ``top_k``, ``seed``, …); ``hf`` reads ``device``, ``dtype``, ``seed``, ``trust_remote_code`` and passes the
    rest to ``generate`` (``top_p``, ``repetition_penalty``, …); ``rules`` reads ``seed`` and ``style``
    (``full`` or ``brief``)."""

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Raise a one-line ValueError for the first bad setting."""
        if self.backend not in BACKENDS:
            raise ValueError(f"teacher: unknown backend {self.backend!r}; known: {', '.join(BACKENDS)}")
        if self.backend in ("openai", "hf") and not str(self.model or "").strip():
            raise ValueError(f"teacher: backend {self.backend!r} needs a model "
                             f"({'API model name' if self.backend == 'openai' else 'local directory or hub id'})")
        if self.base_url is not None:
            parsed = urlparse(str(self.base_url))
            if parsed.scheme not in ("http", "https") or not parsed.netloc:
                raise ValueError(f"teacher: base_url must be an http(s) URL with a host, got {self.base_url!r}")
        if not self.api_key_env:
            host = urlparse(str(self.base_url or "")).hostname or ""
            self.api_key_env = DEEPSEEK_KEY_ENV if host.endswith("deepseek.com") else DEFAULT_KEY_ENV
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", self.api_key_env):
            raise ValueError(f"teacher: api_key_env must name an environment variable, got {self.api_key_env!r}")
        _check_number("temperature", self.temperature, low=0.0)
        _check_int("max_tokens", self.max_tokens, low=1)
        _check_int("concurrency", self.concurrency, low=1)
        _check_number("timeout_s", self.timeout_s, low=0.0, strict=True)
        _check_int("max_retries", self.max_retries, low=0)
        _check_number("backoff_base_s", self.backoff_base_s, low=0.0)
        _check_number("backoff_max_s", self.backoff_max_s, low=0.0)
        _check_number("price_per_1k_prompt", self.price_per_1k_prompt, low=0.0)
        _check_number("price_per_1k_completion", self.price_per_1k_completion, low=0.0)
        if not isinstance(self.extra, dict):
            raise ValueError(f"teacher: extra must be a mapping, got {type(self.extra).__name__}")

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> TeacherConfig:
        if not isinstance(data, dict):
            raise ValueError(f"teacher config must be a mapping, got {type(data).__name__}")
        reject_unknown_fields(cls, data, "teacher: unknown config keys", known="sorted")
        return cls(**data)

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def _check_number(name: str, value: Any, *, low: float, strict: bool = False) -> None:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    if not ok or value < low or (strict and value == low):
        relation = ">" if strict else ">="
        raise ValueError(f"teacher: {name} must be a number {relation} {low:g}, got {value!r}")


def _check_int(name: str, value: Any, *, low: int) -> None:
    if not isinstance(value, int) or isinstance(value, bool) or value < low:
        raise ValueError(f"teacher: {name} must be an integer >= {low}, got {value!r}")


def load_teacher_config(path: str | Path) -> TeacherConfig:
    """Read a teacher config from YAML: the mapping itself, or under a top-level ``teacher:`` key."""
    path = Path(path)
    data, _ = read_yaml(path)
    if isinstance(data, dict) and set(data) == {"teacher"}:
        data = data["teacher"]
    if not isinstance(data, dict):
        raise ValueError(f"{path}: a teacher config must be a mapping, got {type(data).__name__}")
    try:
        return TeacherConfig.from_dict(data)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{path}: {exc}") from None


class UsageMeter:
    """Counters a paid run needs (requests, retries, failures, tokens, cost), safe across threads and tasks.

    ``by_status`` counts every attempt by outcome class: ``ok``, ``429``, ``4xx``, ``5xx``, ``timeout``,
    ``connection``, ``malformed``. ``truncated`` counts replies cut off at ``max_tokens`` (raise it if many).
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.requests = 0
        self.retries = 0
        self.failures = 0
        self.prompt_tokens = 0
        self.completion_tokens = 0
        self.cost_usd = 0.0
        self.truncated = 0
        self.by_status: Counter[str] = Counter()

    def record_attempt(self, status: str) -> None:
        with self._lock:
            self.requests += 1
            self.by_status[status] += 1

    def record_retry(self) -> None:
        with self._lock:
            self.retries += 1

    def record_failure(self) -> None:
        with self._lock:
            self.failures += 1

    def record_truncated(self) -> None:
        with self._lock:
            self.truncated += 1

    def record_tokens(self, prompt_tokens: int, completion_tokens: int, cost_usd: float) -> None:
        with self._lock:
            self.prompt_tokens += prompt_tokens
            self.completion_tokens += completion_tokens
            self.cost_usd += cost_usd

    def summary(self) -> dict[str, Any]:
        with self._lock:
            return {
                "requests": self.requests, "retries": self.retries, "failures": self.failures,
                "prompt_tokens": self.prompt_tokens, "completion_tokens": self.completion_tokens,
                "cost_usd": round(self.cost_usd, 6), "truncated": self.truncated,
                "by_status": dict(sorted(self.by_status.items())),
            }


def cost_of(config: TeacherConfig, prompt_tokens: int, completion_tokens: int) -> float:
    return (prompt_tokens * config.price_per_1k_prompt + completion_tokens * config.price_per_1k_completion) / 1000.0
