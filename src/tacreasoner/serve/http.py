"""Running the API: in the foreground (``tacreasoner serve``) or in a background thread (tests, notebooks,
benchmarks), with uvicorn."""

from __future__ import annotations

import errno
import socket
import sys
import threading
import time
from typing import Any

import uvicorn

__all__ = ["ServerThread", "bind_socket", "serve_forever"]


def bind_socket(host: str, port: int) -> socket.socket:
    """A socket bound to ``host:port`` now: ``serve`` binds before loading the model (which can take minutes), so a
    port already taken is a one-line error at once; :func:`serve_forever` then listens on this socket."""
    try:
        family, kind, proto, _, address = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM,
                                                             flags=socket.AI_PASSIVE)[0]
        sock = socket.socket(family, kind, proto)
    except OSError as exc:
        raise ValueError(f"cannot listen on {host}:{port}: {exc.strerror or exc}") from None
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as uvicorn does: a port in TIME_WAIT is free
        sock.bind(address)
    except OSError as exc:
        sock.close()
        hint = " (is another server running there?)" if exc.errno == errno.EADDRINUSE else ""
        raise ValueError(f"cannot listen on {host}:{port}: {exc.strerror or exc}{hint}") from None
    return sock


def serve_forever(app: Any, host: str = "127.0.0.1", port: int = 8000, log_level: str = "info",
                  sock: socket.socket | None = None) -> None:
    """Serve until interrupted; on ``sock`` (from :func:`bind_socket`) when given, else on ``host:port``."""
    server = uvicorn.Server(uvicorn.Config(app, host=host, port=port, log_level=log_level,
                                           timeout_graceful_shutdown=5))
    server.run(sockets=None if sock is None else [sock])
    if not server.started:  # as uvicorn.run: a failed startup (already logged) is a failed command
        sys.exit(3)


class ServerThread:
    """``with ServerThread(app, port=...) as url:`` serves ``app`` on loopback until the block ends."""

    def __init__(self, app: Any, host: str = "127.0.0.1", port: int = 8000, log_level: str = "warning") -> None:
        self.server = uvicorn.Server(uvicorn.Config(app, host=host, port=port, log_level=log_level,
                                                    timeout_graceful_shutdown=2))
        self.url = f"http://{host}:{port}"
        self._thread = threading.Thread(target=self.server.run, name="tacreasoner-http", daemon=True)

    def __enter__(self) -> str:
        self._thread.start()
        deadline = time.monotonic() + 30
        while not self.server.started:
            if not self._thread.is_alive() or time.monotonic() > deadline:
                raise RuntimeError(f"the server did not start on {self.url}")
            time.sleep(0.02)
        return self.url

    def __exit__(self, *exc: Any) -> None:
        self.server.should_exit = True
        self._thread.join(timeout=30)
