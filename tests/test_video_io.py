"""Tests for tacreasoner.video_io: round trips, determinism, and clear errors on bad input."""

from __future__ import annotations

from pathlib import Path

import av
import numpy as np
import pytest

from tacreasoner.video_io import VideoError, VideoInfo, probe_video, read_video, write_video

PHYSICLEAR = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "physiclear" / "videos"


def gradient_video(t: int = 12, h: int = 48, w: int = 64) -> np.ndarray:
    """Smooth moving gradient: compresses well, so decoded pixels should be close to the input."""
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    frames = np.empty((t, h, w, 3), dtype=np.uint8)
    for i in range(t):
        frames[i, ..., 0] = 40 + 150 * xx / w + 2 * i
        frames[i, ..., 1] = 40 + 150 * yy / h
        frames[i, ..., 2] = 120 + 3 * i
    return frames


@pytest.fixture
def clip(tmp_path: Path) -> Path:
    return write_video(tmp_path / "clip.mp4", gradient_video(), fps=30)


# ---------------------------------------------------------------------------------------------- round trip


@pytest.mark.parametrize("suffix", [".mp4", ".mov", ".avi"])
def test_round_trip(tmp_path: Path, suffix: str) -> None:
    frames = gradient_video()
    out = write_video(tmp_path / f"clip{suffix}", frames, fps=30)
    assert out == tmp_path / f"clip{suffix}"
    video, fps = read_video(out)
    assert video.shape == frames.shape
    assert video.dtype == np.uint8
    assert fps == pytest.approx(30)
    assert np.abs(video.astype(np.int16) - frames).mean() < 2.0


@pytest.mark.parametrize("fps", [29.97, 30000 / 1001, 12.5, 7.3])
def test_non_integer_fps_round_trips(tmp_path: Path, fps: float) -> None:
    out = write_video(tmp_path / "clip.mp4", gradient_video(t=4), fps=fps)
    assert read_video(out)[1] == pytest.approx(fps, rel=1e-6)


def test_accepts_frame_iterable(tmp_path: Path) -> None:
    frames = gradient_video(t=5)
    out = write_video(tmp_path / "gen.mp4", (f for f in frames), fps=10)
    assert read_video(out)[0].shape == frames.shape


def test_decoded_frames_equal_pyavs_own_per_frame_conversion(tmp_path: Path) -> None:
    """read_video converts YUV to RGB with one shared swscale context; it must give PyAV's per-frame pixels."""
    rng = np.random.default_rng(3)
    frames = rng.integers(0, 256, (6, 48, 64, 3), dtype=np.uint8)  # noise: every chroma rounding shows
    out = write_video(tmp_path / "noise.mp4", frames, fps=10)
    with av.open(str(out)) as container:
        reference = np.stack([f.to_ndarray(format="rgb24") for f in container.decode(video=0)])
    video, _ = read_video(out)
    assert np.array_equal(video, reference)


def test_max_frames(clip: Path) -> None:
    video, _ = read_video(clip, max_frames=3)
    assert video.shape[0] == 3
    with pytest.raises(ValueError):
        read_video(clip, max_frames=0)


def test_probe_agrees_with_read(clip: Path) -> None:
    info = probe_video(clip)
    video, fps = read_video(clip)
    assert isinstance(info, VideoInfo)
    assert (info.n_frames, info.height, info.width) == video.shape[:3]
    assert info.fps == pytest.approx(fps)
    assert info.codec == "h264"
    assert info.path == clip


# ---------------------------------------------------------------------------------------------- determinism


def test_identical_input_gives_identical_bytes(tmp_path: Path) -> None:
    frames = np.random.default_rng(0).integers(0, 256, size=(10, 32, 48, 3), dtype=np.uint8)
    a = write_video(tmp_path / "a.mp4", frames, fps=29.97).read_bytes()
    b = write_video(tmp_path / "b.mp4", frames, fps=29.97).read_bytes()
    assert a == b
    assert b"Lavf" not in a  # bitexact muxing: no FFmpeg version string that differs between builds


def test_write_is_atomic_and_leaves_no_temp_files(tmp_path: Path) -> None:
    write_video(tmp_path / "clip.mp4", gradient_video(t=3), fps=10)
    with pytest.raises(TypeError):
        write_video(tmp_path / "clip.mp4", [gradient_video(t=1)[0], np.zeros((48, 64, 3))], fps=10)
    assert [p.name for p in tmp_path.iterdir()] == ["clip.mp4"]
    assert read_video(tmp_path / "clip.mp4")[0].shape[0] == 3  # failed overwrite left the old file intact


# ---------------------------------------------------------------------------------------------- bad input


def test_odd_dimensions_rejected(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="even"):
        write_video(tmp_path / "odd.mp4", np.zeros((2, 33, 64, 3), np.uint8), fps=10)
    with pytest.raises(ValueError, match="even"):
        write_video(tmp_path / "odd.mp4", np.zeros((2, 32, 63, 3), np.uint8), fps=10)


def test_wrong_dtype_rejected(tmp_path: Path) -> None:
    with pytest.raises(TypeError, match="uint8"):
        write_video(tmp_path / "f.mp4", np.zeros((2, 32, 32, 3), np.float32), fps=10)


@pytest.mark.parametrize("shape", [(2, 32, 32), (2, 32, 32, 4), (32, 32, 3)])
def test_wrong_shape_rejected(tmp_path: Path, shape: tuple[int, ...]) -> None:
    with pytest.raises(ValueError, match="shape"):
        write_video(tmp_path / "s.mp4", np.zeros(shape, np.uint8), fps=10)


@pytest.mark.parametrize("fps", [0, -5, float("nan"), float("inf")])
def test_bad_fps_rejected(tmp_path: Path, fps: float) -> None:
    with pytest.raises(ValueError, match="fps"):
        write_video(tmp_path / "f.mp4", gradient_video(t=2), fps=fps)


def test_no_frames_rejected(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="no frames"):
        write_video(tmp_path / "e.mp4", [], fps=10)


def test_unknown_codec_is_video_error(tmp_path: Path) -> None:
    with pytest.raises(VideoError, match=r"x\.mp4"):
        write_video(tmp_path / "x.mp4", gradient_video(t=2), fps=10, codec="no-such-codec")
    assert list(tmp_path.iterdir()) == []


def test_unknown_container_suffix(tmp_path: Path) -> None:
    with pytest.raises(VideoError, match=r"clip\.xyz: .*suffix"):
        write_video(tmp_path / "clip.xyz", gradient_video(t=2), fps=10)
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------------------------------- bad files


def test_missing_file(tmp_path: Path) -> None:
    missing = tmp_path / "missing.mp4"
    with pytest.raises(FileNotFoundError, match=r"missing\.mp4"):
        read_video(missing)
    with pytest.raises(FileNotFoundError, match=r"missing\.mp4"):
        probe_video(missing)


def test_corrupt_file(tmp_path: Path) -> None:
    bad = tmp_path / "corrupt.mp4"
    bad.write_bytes(np.random.default_rng(0).bytes(4096))
    with pytest.raises(VideoError, match=r"corrupt\.mp4"):
        read_video(bad)
    with pytest.raises(VideoError, match=r"corrupt\.mp4"):
        probe_video(bad)


def test_empty_file(tmp_path: Path) -> None:
    empty = tmp_path / "empty.mp4"
    empty.touch()
    with pytest.raises(VideoError, match=r"empty\.mp4"):
        read_video(empty)


def test_truncated_file_is_error(clip: Path) -> None:
    """Documented: truncated clips raise rather than returning a silently shortened video."""
    data = clip.read_bytes()
    clip.write_bytes(data[: int(0.3 * len(data))])
    with pytest.raises(VideoError, match=r"clip\.mp4"):
        read_video(clip)


def test_truncated_faststart_file_is_error(tmp_path: Path) -> None:
    """With the index at the front the container still opens; the frame-count check catches the cut."""
    path = tmp_path / "fast.mp4"
    frames = np.random.default_rng(1).integers(0, 256, size=(30, 48, 64, 3), dtype=np.uint8)
    with av.open(str(path), "w", options={"movflags": "+faststart"}) as container:
        stream = container.add_stream("libx264", rate=30)
        stream.height, stream.width, stream.pix_fmt = 48, 64, "yuv420p"
        for f in frames:
            container.mux(stream.encode(av.VideoFrame.from_ndarray(f, format="rgb24")))
        container.mux(stream.encode(None))
    assert read_video(path)[0].shape[0] == 30
    data = path.read_bytes()
    path.write_bytes(data[: int(0.3 * len(data))])
    assert probe_video(path).n_frames == 30  # header intact: probe cannot tell
    with pytest.raises(VideoError, match=r"fast\.mp4"):
        read_video(path)
    assert read_video(path, max_frames=2)[0].shape[0] == 2  # frames before the cut stay readable


def test_file_without_video_stream(tmp_path: Path) -> None:
    path = tmp_path / "audio.mp4"
    with av.open(str(path), "w") as container:
        stream = container.add_stream("aac", rate=8000)
        frame = av.AudioFrame.from_ndarray(np.zeros((1, 1024), np.float32), format="fltp", layout="mono")
        frame.sample_rate = 8000
        container.mux(stream.encode(frame))
        container.mux(stream.encode(None))
    with pytest.raises(VideoError, match="no video stream"):
        read_video(path)


# ---------------------------------------------------------------------------------------------- real data


def test_reads_physiclear_mov() -> None:
    movs = sorted(PHYSICLEAR.glob("*.mov")) if PHYSICLEAR.is_dir() else []
    if not movs:
        pytest.skip(f"PhysiCLeAR videos not available at {PHYSICLEAR}")
    video, fps = read_video(movs[0])
    info = probe_video(movs[0])
    assert video.ndim == 4 and video.shape[1:] == (240, 320, 3)
    assert video.dtype == np.uint8
    assert fps > 0 and info.fps == pytest.approx(fps)
    assert info.n_frames == video.shape[0]
    assert info.codec == "mpeg4"
