"""A local fake OpenAI-compatible chat server for teacher tests: real HTTP, scripted faults, recorded calls.

Only ``POST /v1/chat/completions`` (and ``/chat/completions``) on 127.0.0.1, an ephemeral port, in a
background thread; stopped when the ``with`` block (or the fixture) ends. Each request takes the next
action from the first matching script: per prompt (a substring of the user message) first, then the
global queue, else ``default``. Actions:

``ok`` (``<think>…</think><answer>GOLD</answer>``, GOLD echoed from the line after ``answer_marker`` in
the prompt), ``wrong`` (a wrong answer), ``reasoning`` (DeepSeek style: answer only in ``content``, the
reasoning in ``reasoning_content``), ``429`` (with ``Retry-After: retry_after``), ``400`` ``401`` ``403``
``404`` ``500`` ``502`` ``503``, ``slow`` (sleep ``slow_s`` before answering, to trip a client timeout),
``malformed`` (200, JSON content type, a body that is not JSON), ``no_choices`` (200, empty choices),
``html`` (200, an HTML page).
"""

from __future__ import annotations

import json
import re
import threading
import time
from collections import Counter, deque
from collections.abc import Iterable, Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import pytest

ACTIONS = ("ok", "wrong", "reasoning", "429", "400", "401", "403", "404", "500", "502", "503", "slow",
           "malformed", "no_choices", "html")


class FakeOpenAIServer:
    def __init__(self, *, default: str = "ok", answer_marker: str = "Gold answer:", retry_after: str | None = "0",
                 slow_s: float = 1.0, hold_s: float = 0.0, expected_key: str | None = None) -> None:
        self.default = default
        self.answer_marker = answer_marker
        self.retry_after = retry_after
        self.slow_s = slow_s
        self.hold_s = hold_s
        """Seconds every answered request stays in flight (makes concurrency observable)."""
        self.expected_key = expected_key
        """When set, requests with another bearer token get 401."""
        self.requests: list[dict] = []
        """Every request: its JSON body, its headers (lower-case names) and its arrival time (monotonic)."""
        self.per_prompt: Counter[str] = Counter()
        self.actions: list[str] = []
        self.in_flight = 0
        self.max_in_flight = 0
        self._queue: deque[str] = deque()
        self._scripts: list[tuple[str, deque[str]]] = []
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._httpd: ThreadingHTTPServer | None = None
        self._thread: threading.Thread | None = None

    # scripting -----------------------------------------------------------------------------------------
    def script(self, actions: Iterable[str]) -> None:
        """Actions for the next requests, in arrival order, whatever their prompt."""
        self._queue.extend(_checked(actions))

    def script_for(self, needle: str, actions: Iterable[str]) -> None:
        """Actions for the next requests whose user message contains ``needle``."""
        self._scripts.append((needle, deque(_checked(actions))))

    def calls(self, needle: str) -> int:
        """Requests so far whose user message contains ``needle``."""
        with self._lock:
            return sum(n for prompt, n in self.per_prompt.items() if needle in prompt)

    def _next_action(self, user: str) -> str:
        with self._lock:
            for needle, queue in self._scripts:
                if needle in user and queue:
                    return queue.popleft()
            return self._queue.popleft() if self._queue else self.default

    # lifecycle -----------------------------------------------------------------------------------------
    @property
    def base_url(self) -> str:
        assert self._httpd is not None, "server not started"
        host, port = self._httpd.server_address[:2]
        return f"http://{host}:{port}/v1"

    def start(self) -> FakeOpenAIServer:
        handler = type("Handler", (_Handler,), {"fake": self})
        self._httpd = ThreadingHTTPServer(("127.0.0.1", 0), handler)
        self._httpd.daemon_threads = True
        self._thread = threading.Thread(target=self._httpd.serve_forever, kwargs={"poll_interval": 0.05},
                                        name="fake-openai", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()  # wakes handlers sleeping in "slow" / hold
        if self._httpd is not None:
            self._httpd.shutdown()
            self._httpd.server_close()
        if self._thread is not None:
            self._thread.join(timeout=5)

    def __enter__(self) -> FakeOpenAIServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # replies -------------------------------------------------------------------------------------------
    def gold_of(self, user: str) -> str:
        m = re.search(re.escape(self.answer_marker) + r"\s*(.+)", user)
        return m.group(1).strip() if m else "unknown"

    def completion(self, body: dict, action: str) -> dict:
        messages = body.get("messages") or []
        user = next((m.get("content", "") for m in reversed(messages) if m.get("role") == "user"), "")
        gold = self.gold_of(user)
        answer = "definitely-wrong" if action == "wrong" else gold
        reasoning = ("The press phase shows a large contact area; during hold the imprint relaxes; "
                     "on release it recovers.")
        message: dict = {"role": "assistant"}
        if action == "reasoning":
            message.update(content=answer, reasoning_content=reasoning)
        else:
            message["content"] = f"<think>{reasoning}</think><answer>{answer}</answer>"
        prompt_tokens = sum(len(str(m.get("content", "")).split()) for m in messages)
        completion_tokens = len(message["content"].split()) + len(message.get("reasoning_content", "").split())
        return {
            "id": f"chatcmpl-{len(self.requests)}", "object": "chat.completion", "created": int(time.time()),
            "model": body.get("model", "fake"),
            "choices": [{"index": 0, "message": message, "finish_reason": "stop", "logprobs": None}],
            "usage": {"prompt_tokens": prompt_tokens, "completion_tokens": completion_tokens,
                      "total_tokens": prompt_tokens + completion_tokens},
        }


def _checked(actions: Iterable[str]) -> list[str]:
    actions = list(actions)
    unknown = [a for a in actions if a not in ACTIONS]
    if unknown:
        raise ValueError(f"unknown fake-server actions {unknown}; known: {ACTIONS}")
    return actions


class _Handler(BaseHTTPRequestHandler):
    fake: FakeOpenAIServer

    def log_message(self, format: str, *args: object) -> None:  # keep test output quiet
        pass

    def do_POST(self) -> None:
        if self.path.rstrip("/") not in ("/v1/chat/completions", "/chat/completions"):
            self._send(404, {"error": {"message": f"no route {self.path}", "type": "invalid_request_error"}})
            return
        fake = self.fake
        raw = self.rfile.read(int(self.headers.get("Content-Length") or 0))
        body = json.loads(raw or b"{}")
        messages = body.get("messages") or []
        user = next((m.get("content", "") for m in reversed(messages) if m.get("role") == "user"), "")
        with fake._lock:
            headers = {k.lower(): v for k, v in self.headers.items()}
            fake.requests.append({"body": body, "headers": headers, "time": time.monotonic()})
            fake.per_prompt[user] += 1
            fake.in_flight += 1
            fake.max_in_flight = max(fake.max_in_flight, fake.in_flight)
        try:
            token = (self.headers.get("Authorization") or "").removeprefix("Bearer ").strip()
            wrong_key = fake.expected_key is not None and token != fake.expected_key
            action = "401" if wrong_key else fake._next_action(user)
            with fake._lock:
                fake.actions.append(action)
            self._act(action, body)
        except (BrokenPipeError, ConnectionResetError):  # the client gave up (timeout): nothing to answer
            pass
        finally:
            with fake._lock:
                fake.in_flight -= 1

    def _act(self, action: str, body: dict) -> None:
        fake = self.fake
        if action == "slow":
            if fake._stop.wait(fake.slow_s):
                return
            action = "ok"
        if fake.hold_s:
            fake._stop.wait(fake.hold_s)
        if action in ("ok", "wrong", "reasoning"):
            self._send(200, fake.completion(body, action))
        elif action == "429":
            headers = {"Retry-After": fake.retry_after} if fake.retry_after is not None else {}
            self._send(429, {"error": {"message": "Rate limit reached", "type": "rate_limit_error"}}, headers)
        elif action.isdigit():
            messages = {"400": "bad request", "401": "Incorrect API key provided", "403": "forbidden",
                        "404": "The model does not exist", "500": "internal error", "502": "bad gateway",
                        "503": "overloaded"}
            self._send(int(action), {"error": {"message": messages[action], "type": "api_error"}})
        elif action == "malformed":
            self._send_raw(200, b'{"id": "x", "choices": [', "application/json")
        elif action == "no_choices":
            self._send(200, {"id": "x", "object": "chat.completion", "created": 0, "model": "fake", "choices": []})
        elif action == "html":
            self._send_raw(200, b"<html><body>502 from a proxy</body></html>", "text/html")

    def _send(self, status: int, payload: dict, headers: dict[str, str] | None = None) -> None:
        self._send_raw(status, json.dumps(payload).encode(), "application/json", headers)

    def _send_raw(self, status: int, data: bytes, content_type: str, headers: dict[str, str] | None = None) -> None:
        self.send_response(status)
        self.send_header("Content-Type", content_type)
        self.send_header("Content-Length", str(len(data)))
        for name, value in (headers or {}).items():
            self.send_header(name, value)
        self.end_headers()
        self.wfile.write(data)


@pytest.fixture
def fake_openai() -> Iterator[FakeOpenAIServer]:
    """A running fake server, stopped at the end of the test."""
    with FakeOpenAIServer() as server:
        yield server
