"""Video decoding and resizing: one swscale context per clip vs PyAV's per-frame conversion, side by side.

``read_video`` and ``resize_keep_aspect`` convert every frame through one ``VideoReformatter`` (commit e897228);
before, each frame's ``to_ndarray(format=...)``/``reformat`` set up a fresh swscale context. This script times
both ways on the same clips in one run (alternating which goes first) and checks that they give identical
pixels: simulated GelSight-Mini clips (H.264) and PhysiCLeAR clips (MPEG-4) when ../shared is present.

Each set is timed twice: on a quiet machine, and with one core kept busy by a single-threaded matmul loop in
another process, as when training or another job shares the cores (the former quickstart pre-trained its tiny
LLM in the background while its data stages decoded). Setting up a swscale context is cheap on an idle machine but
slow when the cores are contended, so the per-frame way suffers most exactly where decoding shares the machine.

    python benchmarks/decode_speed.py [--sim-clips 12 --physiclear-clips 12 --rounds 3]
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import av
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp
from tacreasoner.data.readers import default_physiclear_dir, read_physiclear
from tacreasoner.data.sampling import resize_keep_aspect
from tacreasoner.sim.generate import generate_dataset, read_manifest
from tacreasoner.video_io import read_video

RESIZE = (64, 64)
BUSY_LOOP = ("import torch\ntorch.set_num_threads(1)\na = torch.randn(1000, 1000)\n"
             "while True:\n    a @ a\n")


def per_frame_decode(path: Path) -> np.ndarray:
    """The conversion read_video used before: a new swscale context for every frame."""
    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        stream.thread_type = "AUTO"
        return np.stack([f.to_ndarray(format="rgb24") for f in container.decode(stream)])


def per_frame_resize(frames: np.ndarray, height: int, width: int) -> np.ndarray:
    """resize_keep_aspect's resampling before (for a same-aspect target: no padding involved)."""
    return np.stack([av.VideoFrame.from_ndarray(np.ascontiguousarray(f), format="rgb24")
                     .reformat(width=width, height=height, interpolation="AREA").to_ndarray(format="rgb24")
                     for f in frames])


def _timed(fn, *args) -> tuple[float, np.ndarray]:
    start = time.perf_counter()
    out = fn(*args)
    return time.perf_counter() - start, out


def measure(paths: list[Path], rounds: int) -> dict:
    seconds = {"decode_per_frame": 0.0, "decode_shared": 0.0, "resize_per_frame": 0.0, "resize_shared": 0.0}
    identical, frames = True, 0
    for r in range(rounds):
        for path in paths:
            old_first = r % 2 == 0
            runs = [("decode_per_frame", per_frame_decode), ("decode_shared", lambda p: read_video(p)[0])]
            decoded = {}
            for name, fn in (runs if old_first else runs[::-1]):
                took, decoded[name] = _timed(fn, path)
                seconds[name] += took
            identical &= np.array_equal(decoded["decode_per_frame"], decoded["decode_shared"])
            clip = decoded["decode_shared"]
            h, w = clip.shape[1:3]
            size = (RESIZE[0], round(RESIZE[0] * w / h))  # same aspect: both produce exactly this size
            resized = {}
            runs = [("resize_per_frame", per_frame_resize), ("resize_shared", resize_keep_aspect)]
            for name, fn in (runs if old_first else runs[::-1]):
                took, resized[name] = _timed(fn, clip, *size)
                seconds[name] += took
            identical &= np.array_equal(resized["resize_per_frame"], resized["resize_shared"])
            frames += len(clip)
    per_frame_ms = {k: 1000 * v / frames for k, v in seconds.items()}
    return {"clips": len(paths), "frames_per_round": frames // rounds, "rounds": rounds, "identical": bool(identical),
            "ms_per_frame": per_frame_ms,
            "decode_speedup": seconds["decode_per_frame"] / seconds["decode_shared"],
            "resize_speedup": seconds["resize_per_frame"] / seconds["resize_shared"]}


def measure_busy(paths: list[Path], rounds: int) -> dict:
    """measure() while another process keeps one core busy (as the quickstart's background LLM does)."""
    loop = subprocess.Popen([sys.executable, "-c", BUSY_LOOP])
    try:
        time.sleep(2.0)  # let it import torch and start multiplying
        return measure(paths, rounds)
    finally:
        loop.kill()
        loop.wait()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sim-clips", type=int, default=12)
    ap.add_argument("--physiclear-clips", type=int, default=12)
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()

    sets: dict[str, list[Path]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        manifest = generate_dataset(Path(tmp) / "sim", n_objects=args.sim_clips, repeats=1, seed=0)
        sets["DynTAC-Sim (Mini, H.264)"] = [manifest.parent / r["video"] for r in read_manifest(manifest)]
        root = default_physiclear_dir()
        if root is not None and args.physiclear_clips > 0:
            sets["PhysiCLeAR (MPEG-4)"] = [c.path for c in list(read_physiclear(root))[:args.physiclear_clips]]
        results = {f"{name}, {load}": fn(paths, args.rounds) for name, paths in sets.items()
                   for load, fn in (("quiet", measure), ("one core busy", measure_busy))}

    info = stamp()
    rows = [[name, r["clips"], r["frames_per_round"], f"{r['ms_per_frame']['decode_per_frame']:.2f}",
             f"{r['ms_per_frame']['decode_shared']:.2f}", f"**{r['decode_speedup']:.1f}×**",
             f"{r['ms_per_frame']['resize_per_frame']:.2f}", f"{r['ms_per_frame']['resize_shared']:.2f}",
             f"**{r['resize_speedup']:.1f}×**", "yes" if r["identical"] else "**NO**"]
            for name, r in results.items()]
    md = header_md("Video decoding and resizing: one swscale context per clip", info)
    md += (f"Single process, the same clips for both ways, {args.rounds} rounds alternating which goes first. "
           "Quiet: nothing else running; one core busy: a single-threaded torch matmul loop in another "
           "process (the quickstart pre-trains the LLM in the background while it decodes). Per frame: PyAV's "
           "`to_ndarray(format='rgb24')`/`reformat` on each frame (a new swscale context every "
           "time, as before e897228); shared: `read_video`/`resize_keep_aspect`, one `VideoReformatter` per clip. "
           f"Resize: to {RESIZE[0]} px high keeping the aspect (AREA). Identical: every decoded and resized "
           "pixel equal.\n\n")
    md += md_table(["clips", "n", "frames", "decode per frame (ms/frame)", "decode shared (ms/frame)",
                    "decode speed-up", "resize per frame (ms/frame)", "resize shared (ms/frame)", "resize speed-up",
                    "identical"], rows)
    publish("decode_speed", {**info, "results": results}, md)


if __name__ == "__main__":
    main()
