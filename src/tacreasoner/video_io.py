"""Video I/O for tactile clips (GelSight-style RGB videos) on top of PyAV.

A leaf at the package root (it needs only PyAV and numpy): the simulator writes clips with it and the data
readers, the cache, TouchCoT and the server read them, and none of those parts has to import another for it.

Design choices:

* Every FFmpeg failure surfaces as :class:`VideoError` (a ``ValueError``) naming the file, so callers
  iterating over a data set can catch one exception type and report the offending clip.
* :func:`write_video` is deterministic: the same frames give byte-identical files. The encoder runs
  single-threaded (x264's output depends on its thread count), and muxer and encoder run with the
  bitexact flag so no FFmpeg version string is stored; the mp4 muxer stores creation times of 0
  unless asked otherwise. x264 still writes its own version/settings SEI, so bytes are identical
  for a given FFmpeg/x264 build, not across builds.
* :func:`read_video` is strict: a clip that cannot be fully decoded (corrupt data, or fewer frames
  than the container index declares, i.e. a truncated file) raises :class:`VideoError` rather than
  silently returning a shorter clip, since a short clip would quietly skew temporal models.
"""

from __future__ import annotations

import os
import secrets
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any

import av
import numpy as np
from av.video.reformatter import VideoReformatter

__all__ = ["VideoError", "VideoInfo", "probe_video", "read_video", "write_video"]

# Highest fps denominator kept: exact for NTSC rates (30000/1001) and two-decimal rates (29.97).
_MAX_RATE_DENOMINATOR = 100_000
# x264/x265 understand crf/preset; other encoders would reject or silently ignore them.
_CRF_CODECS = frozenset({"libx264", "libx265"})


class VideoError(ValueError):
    """A video file exists but is not a usable video (or cannot be written as requested)."""


@dataclass(frozen=True)
class VideoInfo:
    """Container metadata; ``n_frames`` is estimated from the duration when no index gives it."""

    path: Path
    n_frames: int
    fps: float
    height: int
    width: int
    codec: str


# --------------------------------------------------------------------------------------------- writing


def write_video(
    path: str | os.PathLike[str],
    frames: np.ndarray | Iterable[np.ndarray],
    fps: float,
    *,
    crf: int = 20,
    preset: str = "veryfast",
    codec: str = "libx264",
) -> Path:
    """Encode RGB uint8 frames (T×H×W×3 array or iterable of H×W×3) to ``path``; returns the path.

    The file appears atomically (temp file in the same directory, then ``os.replace``) so readers
    never see a half-written clip.
    """
    path = Path(path)
    if not path.parent.is_dir():
        raise FileNotFoundError(f"{path.parent}: output directory does not exist")
    rate = _fps_to_rate(fps)
    frame_iter = _iter_frames(frames)
    first = next(frame_iter, None)
    if first is None:
        raise ValueError(f"{path.name}: no frames to write")
    height, width = _check_frame(first, None, 0)
    if height % 2 or width % 2:
        raise ValueError(f"{path.name}: height and width must be even for yuv420p, got {height}×{width}")

    tmp = path.with_name(f".{path.name}.{secrets.token_hex(4)}.tmp{path.suffix}")
    options = _codec_options(codec, crf, preset)
    try:
        size = (height, width)
        _encode(tmp, path.name, _chain(first, frame_iter, size), rate, size, codec, options)
        os.replace(tmp, path)
    except (av.error.FFmpegError, av.codec.codec.UnknownCodecError, OSError) as exc:
        raise VideoError(f"{path.name}: cannot encode video with {codec} ({_reason(exc)})") from exc
    finally:
        tmp.unlink(missing_ok=True)
    return path


def _fps_to_rate(fps: float) -> Fraction:
    """Exact rational rate for the stream, so non-integer fps (29.97, 12.5) round-trip exactly."""
    try:
        value = float(fps)
    except (TypeError, ValueError):
        raise ValueError(f"fps must be a positive number, got {fps!r}") from None
    if not np.isfinite(value) or value <= 0:
        raise ValueError(f"fps must be a positive finite number, got {fps!r}")
    rate = Fraction(value).limit_denominator(_MAX_RATE_DENOMINATOR)
    if rate <= 0:
        raise ValueError(f"fps {fps!r} is too small to represent")
    return rate


def _iter_frames(frames: np.ndarray | Iterable[np.ndarray]) -> Iterator[np.ndarray]:
    """Accept both a stacked array and a frame iterable, so generators can be encoded lazily."""
    if isinstance(frames, np.ndarray) and (frames.ndim != 4 or frames.shape[-1] != 3):
        raise ValueError(f"frames must have shape T×H×W×3, got {frames.shape}")
    return iter(frames)


def _check_frame(frame: Any, expected: tuple[int, int] | None, index: int) -> tuple[int, int]:
    """Reject wrong dtype/shape early with a message naming the frame, not deep inside FFmpeg."""
    if not isinstance(frame, np.ndarray):
        raise TypeError(f"frame {index}: expected a numpy array, got {type(frame).__name__}")
    if frame.dtype != np.uint8:
        raise TypeError(f"frame {index}: expected dtype uint8, got {frame.dtype}")
    if frame.ndim != 3 or frame.shape[2] != 3 or frame.shape[0] == 0 or frame.shape[1] == 0:
        raise ValueError(f"frame {index}: expected shape H×W×3, got {frame.shape}")
    size = (int(frame.shape[0]), int(frame.shape[1]))
    if expected is not None and size != expected:
        raise ValueError(f"frame {index}: size {size} differs from the first frame's {expected}")
    return size


def _chain(first: np.ndarray, rest: Iterator[np.ndarray], size: tuple[int, int]) -> Iterator[np.ndarray]:
    yield first
    for i, frame in enumerate(rest, start=1):
        _check_frame(frame, size, i)
        yield frame


def _codec_options(codec: str, crf: int, preset: str) -> dict[str, str]:
    options = {"crf": str(int(crf)), "preset": preset} if codec in _CRF_CODECS else {}
    if codec == "libx264":
        # x264's macroblock-tree lookahead gave run-to-run different bytes for identical frames
        # (seen with PyAV 18's bundled x264); without it the output is reproducible.
        options["x264-params"] = "mbtree=0"
    return options


def _encode(
    tmp: Path,
    name: str,
    frames: Iterator[np.ndarray],
    rate: Fraction,
    size: tuple[int, int],
    codec: str,
    options: dict[str, str],
) -> None:
    """Encode into ``tmp``; bitexact muxing keeps library version strings out of the file."""
    try:
        output = av.open(str(tmp), mode="w", options={"fflags": "+bitexact"})
    except ValueError as exc:  # PyAV raises a bare ValueError when the suffix names no known container
        raise VideoError(f"{name}: {exc} from its suffix; use .mp4, .mov, .avi or .mkv") from exc
    with output as container:
        stream = container.add_stream(codec, rate=rate, options=options)
        stream.height, stream.width = size
        stream.pix_fmt = "yuv420p"
        stream.codec_context.thread_count = 1  # x264 output depends on thread count
        stream.codec_context.flags |= int(av.codec.context.Flags.bitexact)  # no Lavc version in mpeg4 data
        for index, frame in enumerate(frames):
            av_frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(frame), format="rgb24")
            av_frame.pts = index  # explicit timestamps: nothing left for the encoder to guess
            container.mux(stream.encode(av_frame))
        container.mux(stream.encode(None))


# --------------------------------------------------------------------------------------------- reading


def read_video(path: str | os.PathLike[str], *, max_frames: int | None = None) -> tuple[np.ndarray, float]:
    """Decode the first video stream to (T×H×W×3 uint8 RGB, fps).

    With ``max_frames`` decoding stops early (and the truncation check is skipped, since the end of
    the file is never reached).
    """
    path = _existing(path)
    if max_frames is not None and max_frames < 1:
        raise ValueError(f"max_frames must be >= 1 or None, got {max_frames}")
    with _open(path) as container:
        stream = _video_stream(container, path)
        stream.thread_type = "AUTO"  # decoding is deterministic regardless of threads
        fps = _stream_fps(stream, path)
        frames = _decode(container, stream, path, max_frames)
        declared = int(stream.frames or 0)
    if not frames:
        raise VideoError(f"{path.name}: decoded 0 frames")
    if max_frames is None and len(frames) < declared:
        raise VideoError(f"{path.name}: decoded {len(frames)} of {declared} frames (truncated file?)")
    return np.stack(frames), fps


def probe_video(path: str | os.PathLike[str]) -> VideoInfo:
    """Read header metadata only, for cheap data-set scans."""
    path = _existing(path)
    with _open(path) as container:
        stream = _video_stream(container, path)
        fps = _stream_fps(stream, path)
        return VideoInfo(
            path=path,
            n_frames=_frame_count(container, stream, fps),
            fps=fps,
            height=int(stream.codec_context.height),
            width=int(stream.codec_context.width),
            codec=str(stream.codec_context.name),
        )


def _existing(path: str | os.PathLike[str]) -> Path:
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such video file")
    if path.is_dir():
        raise VideoError(f"{path}: is a directory, expected a video file")
    return path


def _open(path: Path) -> Any:
    try:
        return av.open(str(path), mode="r")
    except (av.error.FFmpegError, OSError, UnicodeDecodeError) as exc:
        raise VideoError(f"{path.name}: not a readable video ({_reason(exc)})") from exc


def _reason(exc: BaseException) -> str:
    """FFmpeg messages repeat the path; keep only the diagnosis."""
    return getattr(exc, "strerror", None) or str(exc)


def _video_stream(container: Any, path: Path) -> Any:
    if not container.streams.video:
        raise VideoError(f"{path.name}: no video stream")
    return container.streams.video[0]


def _stream_fps(stream: Any, path: Path) -> float:
    rate = stream.average_rate or stream.guessed_rate or stream.base_rate
    if not rate or rate <= 0:
        raise VideoError(f"{path.name}: frame rate unknown")
    return float(rate)


def _decode(container: Any, stream: Any, path: Path, max_frames: int | None) -> list[np.ndarray]:
    frames: list[np.ndarray] = []
    # One converter for the whole clip: frame.to_ndarray(format=...) builds a new swscale context per
    # frame, which cost 8x the decoding itself (the output is identical).
    to_rgb = VideoReformatter()
    try:
        for frame in container.decode(stream):
            frames.append(to_rgb.reformat(frame, format="rgb24").to_ndarray())
            if max_frames is not None and len(frames) >= max_frames:
                break
    except (av.error.FFmpegError, OSError) as exc:
        raise VideoError(
            f"{path.name}: corrupt video data after {len(frames)} frames ({_reason(exc)})"
        ) from exc
    return frames


def _frame_count(container: Any, stream: Any, fps: float) -> int:
    """Index count when the container has one (mp4/mov), else duration × fps."""
    if stream.frames:
        return int(stream.frames)
    if stream.duration is not None and stream.time_base is not None:
        seconds = float(stream.duration * stream.time_base)
    elif container.duration is not None:
        seconds = container.duration / av.time_base
    else:
        return 0
    return max(0, round(seconds * fps))
