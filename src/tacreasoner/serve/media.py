"""OpenAI chat messages with tactile videos → a :class:`~tacreasoner.serve.engine.Prompt`.

Videos come as content parts in vLLM's convention, ``{"type": "video_url", "video_url": {"url": …}}``, with the
URL either ``data:video/<type>;base64,<bytes>`` or ``file:///path`` inside a directory the server allows. Each video
part stands where it is in the message unless the text already places it with ``<tactile>``: then the number of
placeholders must equal the number of videos. The model answers questions about clips, so a request must carry at
least one, each of at least :data:`~tacreasoner.serve.engine.MIN_CLIP_FRAMES` frames. Every fault is a
:class:`RequestError` naming the part.
"""

from __future__ import annotations

import base64
import binascii
import os
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any
from urllib.parse import unquote, urlparse

import numpy as np

from tacreasoner.serve.engine import Prompt, RequestError, check_clip_length
from tacreasoner.tasks.schema import PLACEHOLDER
from tacreasoner.video_io import VideoError, read_video

__all__ = ["MediaLimits", "decode_video_bytes", "messages_to_prompt", "video_data_url"]

_ROLES = ("system", "user", "assistant")


@dataclass(frozen=True)
class MediaLimits:
    """What one request may carry."""

    max_videos: int = 4
    max_video_bytes: int = 32 * 2**20
    max_frames: int = 2000
    allowed_dirs: tuple[Path, ...] = ()
    """``file://`` URLs are read only inside these (resolved) directories; none: ``file://`` is refused."""


def video_data_url(path: str | os.PathLike[str]) -> str:
    """A file as the ``data:`` URL a client sends (for clients written in Python, and the tests)."""
    suffix = Path(path).suffix.lower().lstrip(".") or "mp4"
    mime = {"mov": "video/quicktime", "mkv": "video/x-matroska", "avi": "video/x-msvideo"}.get(suffix,
                                                                                            f"video/{suffix}")
    return f"data:{mime};base64,{base64.b64encode(Path(path).read_bytes()).decode('ascii')}"


def decode_video_bytes(data: bytes, where: str, limits: MediaLimits) -> np.ndarray:
    """T×H×W×3 uint8 frames of a video file's bytes; a truncated or non-video file is a :class:`RequestError`."""
    if not data:
        raise RequestError(f"{where}: the video is empty", param=where, code="invalid_video")
    with tempfile.NamedTemporaryFile(suffix=".video") as f:
        f.write(data)
        f.flush()
        try:
            frames, _ = read_video(f.name)
        except VideoError as exc:
            raise RequestError(f"{where}: {_video_fault(exc)}", param=where, code="invalid_video") from exc
    if len(frames) > limits.max_frames:
        raise RequestError(f"{where}: {len(frames)} frames; at most {limits.max_frames} per video",
                           param=where, code="video_too_long")
    check_clip_length(len(frames), where, where)
    return frames


def _video_fault(exc: VideoError) -> str:
    """The reader's diagnosis without its file name (a temporary file the client never named), said once."""
    reason = str(exc).split(": ", 1)[-1]
    return reason if reason.startswith("not a readable video") else f"not a readable video ({reason})"


def _data_url_bytes(url: str, where: str, limits: MediaLimits) -> bytes:
    header, sep, payload = url.partition(",")
    if not sep or not header.endswith(";base64"):
        raise RequestError(f"{where}: a data URL must be data:video/<type>;base64,<data>", param=where,
                           code="invalid_video_url")
    mime = header[len("data:"):-len(";base64")]
    if mime and not (mime.startswith("video/") or mime == "application/octet-stream"):
        raise RequestError(f"{where}: media type {mime!r} is not a video", param=where, code="invalid_video")
    if len(payload) * 3 // 4 > limits.max_video_bytes:
        raise RequestError(f"{where}: the video is larger than {limits.max_video_bytes // 2**20} MiB", param=where,
                           code="video_too_large")
    try:
        return base64.b64decode(payload, validate=True)
    except (binascii.Error, ValueError) as exc:
        raise RequestError(f"{where}: the base64 data does not decode ({exc})", param=where,
                           code="invalid_base64") from exc


def _file_url_bytes(url: str, where: str, limits: MediaLimits) -> bytes:
    if not limits.allowed_dirs:
        raise RequestError(f"{where}: file:// URLs are not allowed by this server (start it with --allow-dir)",
                           param=where, code="file_url_not_allowed")
    parsed = urlparse(url)
    if parsed.netloc not in ("", "localhost"):
        raise RequestError(f"{where}: a file:// URL must name a local path", param=where, code="invalid_video_url")
    path = Path(unquote(parsed.path)).resolve()
    if not any(path.is_relative_to(d) for d in limits.allowed_dirs):
        raise RequestError(f"{where}: {path} is outside the directories this server allows", param=where,
                           code="file_url_not_allowed")
    if not path.is_file():
        raise RequestError(f"{where}: {path}: no such file", param=where, code="invalid_video_url")
    if path.stat().st_size > limits.max_video_bytes:
        raise RequestError(f"{where}: the video is larger than {limits.max_video_bytes // 2**20} MiB", param=where,
                           code="video_too_large")
    return path.read_bytes()


def _video_part(part: dict[str, Any], where: str, limits: MediaLimits) -> np.ndarray:
    video_url = part.get("video_url")
    url = video_url.get("url") if isinstance(video_url, dict) else video_url
    if not isinstance(url, str) or not url:
        raise RequestError(f"{where}: video_url.url must be a string", param=where, code="invalid_video_url")
    scheme = url.split(":", 1)[0].lower()
    if scheme == "data":
        data = _data_url_bytes(url, where, limits)
    elif scheme == "file":
        data = _file_url_bytes(url, where, limits)
    else:
        raise RequestError(f"{where}: only data: and file:// video URLs are read (this server fetches nothing "
                           f"from the network), got {scheme}:", param=where, code="invalid_video_url")
    return decode_video_bytes(data, where, limits)


def _check_parts_before_decoding(messages: Sequence[dict[str, Any]]) -> None:
    """Per message, placeholders against video parts: a mismatch is refused before any video is decoded."""
    for i, message in enumerate(messages):
        content = message.get("content")
        if not isinstance(content, list):
            continue
        parts = [p for p in content if isinstance(p, dict)]
        written = sum(p["text"].count(PLACEHOLDER) for p in parts
                      if p.get("type") == "text" and isinstance(p.get("text"), str))
        n = sum(p.get("type") == "video_url" for p in parts)
        if written and written != n:
            missing = "no tactile clip (video_url part)" if n == 0 else f"{n} video part(s)"
            raise RequestError(f"messages[{i}]: the text holds {written} {PLACEHOLDER} placeholder(s) but the "
                               f"message has {missing}", param=f"messages[{i}]", code="placeholder_mismatch")


def messages_to_prompt(messages: Sequence[dict[str, Any]], limits: MediaLimits | None = None) -> Prompt:
    """The chat turns and their videos, in order; checked against ``limits`` before any video is decoded."""
    limits = limits or MediaLimits()
    if not messages:
        raise RequestError("messages: at least one message is needed", param="messages")
    n_videos = sum(1 for m in messages if isinstance(m.get("content"), list)
                   for p in m["content"] if isinstance(p, dict) and p.get("type") == "video_url")
    if n_videos > limits.max_videos:
        raise RequestError(f"messages: {n_videos} videos; this server takes at most {limits.max_videos} per request",
                           param="messages", code="too_many_videos")
    written = sum(m["content"].count(PLACEHOLDER) for m in messages
                  if m.get("role") == "user" and isinstance(m.get("content"), str))
    if written and n_videos == 0:  # caught before any decoding: a malformed request costs next to nothing
        raise RequestError(f"messages: the text holds {written} {PLACEHOLDER} placeholder(s) but no tactile clip was "
                           f"sent: add one video_url part per {PLACEHOLDER}", param="messages",
                           code="placeholder_mismatch")
    _check_parts_before_decoding(messages)
    if n_videos == 0:  # without a clip the model would still reason about a touch it never felt
        raise RequestError("messages: no tactile clip was sent; this model answers questions about tactile videos: "
                           "add a video_url part to the user message", param="messages", code="missing_video")
    turns: list[dict[str, str]] = []
    videos: list[np.ndarray] = []
    for i, message in enumerate(messages):
        role = message.get("role")
        if role not in _ROLES:
            raise RequestError(f"messages[{i}].role must be one of {', '.join(_ROLES)}, got {role!r}",
                               param=f"messages[{i}].role")
        content = message.get("content")
        if isinstance(content, str):
            turns.append({"role": role, "content": content})
            continue
        if not isinstance(content, list):
            raise RequestError(f"messages[{i}].content must be a string or a list of parts",
                               param=f"messages[{i}].content")
        texts: list[str | None] = []
        own_videos: list[np.ndarray] = []
        for j, part in enumerate(content):
            where = f"messages[{i}].content[{j}]"
            kind = part.get("type") if isinstance(part, dict) else None
            if kind == "text" and isinstance(part.get("text"), str):
                texts.append(part["text"])
            elif kind == "video_url":
                if role != "user":
                    raise RequestError(f"{where}: videos go in user messages", param=where)
                own_videos.append(_video_part(part, where, limits))
                texts.append(None)  # where the video stands
            else:
                raise RequestError(f"{where}: a part must be {{'type': 'text', 'text': …}} or "
                                   f"{{'type': 'video_url', 'video_url': {{'url': …}}}}", param=where)
        written = any(PLACEHOLDER in t for t in texts if t is not None)  # counts checked before decoding
        pieces = [t for t in texts if t is not None] if written else \
            [PLACEHOLDER if t is None else t for t in texts]
        turns.append({"role": role, "content": " ".join(p.strip() for p in pieces if p.strip())})
        videos.extend(own_videos)
    if turns[-1]["role"] != "user":
        raise RequestError("messages: the last message must be the user's", param="messages")
    return Prompt(tuple(turns), tuple(videos))
