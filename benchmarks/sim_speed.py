"""DynTAC-Sim speed: rendered-and-encoded frames per second, and time to build the quickstart corpus.

Measured side by side in one run: the fast renderer (batched FFT spreading, float32) and the naive
per-frame SciPy reference (``gaussian_filter`` per scale, bilinear ``map_coordinates``, float64),
both rendering the same clips at 240×320 (GelSight Mini) and encoding H.264 with the same settings.

    python benchmarks/sim_speed.py [--clips 8 --baseline-clips 2 --corpus-objects 100 --corpus-repeats 5]
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp
from tacreasoner.sim.generate import (
    action_for_repeat,
    generate_dataset,
    iter_clip_frames,
    read_manifest,
)
from tacreasoner.sim.materials import catalogue
from tacreasoner.sim.sensors import get_sensor
from tacreasoner.video_io import write_video


def _throughput(backend: str, n_clips: int, encode: bool, tmp: Path) -> dict:
    """Frames/s of one process rendering (and optionally encoding) ``n_clips`` catalogue clips."""
    style = get_sensor("mini")
    objects = catalogue()
    frames = 0
    start = time.perf_counter()
    for k in range(n_clips):
        material = objects[k % len(objects)]
        traj, stream = iter_clip_frames(material, style, action_for_repeat(k), (0, k, 0, 0), backend=backend)
        if encode:
            write_video(tmp / f"{backend}_{k}.mp4", stream, style.fps)
        else:
            for _ in stream:
                pass
        frames += len(traj)
    seconds = time.perf_counter() - start
    return {"backend": backend, "encode": encode, "clips": n_clips, "frames": frames, "seconds": round(seconds, 2),
            "fps": round(frames / seconds, 1)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clips", type=int, default=8)
    ap.add_argument("--baseline-clips", type=int, default=2)
    ap.add_argument("--corpus-objects", type=int, default=100)
    ap.add_argument("--corpus-repeats", type=int, default=5)
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()

    tmp = Path(tempfile.mkdtemp(prefix="tacreasoner-speed-"))
    try:
        single = [
            _throughput("fft", args.clips, encode=False, tmp=tmp),
            _throughput("fft", args.clips, encode=True, tmp=tmp),
            _throughput("scipy", args.baseline_clips, encode=False, tmp=tmp),
            _throughput("scipy", args.baseline_clips, encode=True, tmp=tmp),
        ]
        start = time.perf_counter()
        generate_dataset(tmp / "corpus", args.corpus_objects, args.corpus_repeats, ["mini"], seed=0,
                         workers=args.workers)
        corpus_s = time.perf_counter() - start
        n_clips = args.corpus_objects * args.corpus_repeats
        n_videos = sum(1 for _ in (tmp / "corpus").glob("clips/mini/*.mp4"))
        corpus_frames = sum(r["n_frames"] for r in read_manifest(tmp / "corpus"))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)

    fast = next(r for r in single if r["backend"] == "fft" and r["encode"])
    naive = next(r for r in single if r["backend"] == "scipy" and r["encode"])
    corpus = {"clips": n_clips, "videos_written": n_videos, "frames": corpus_frames, "workers": args.workers,
              "seconds": round(corpus_s, 1), "fps": round(corpus_frames / corpus_s, 1)}
    info = stamp()
    payload = {**info, "settings": vars(args), "single_process": single, "speedup_vs_naive_scipy":
               round(fast["fps"] / naive["fps"], 2), "corpus": corpus,
               "targets": {"fps": 300, "corpus_clips": 500, "corpus_seconds": 180}}
    md = header_md("DynTAC-Sim speed (240×320 GelSight-Mini style, H.264)", info)
    md += "Single process, one core, same clips for both renderers:\n\n"
    md += md_table(["renderer", "encode H.264", "clips", "frames", "seconds", "frames/s"],
                   [[r["backend"], r["encode"], r["clips"], r["frames"], r["seconds"], r["fps"]] for r in single])
    md += (f"\nFast renderer vs naive per-frame SciPy baseline (render + encode): "
           f"**{payload['speedup_vs_naive_scipy']}×**.\n\n")
    md += (f"Quickstart corpus ({n_clips} clips, {corpus_frames} frames, {args.workers} worker processes): "
           f"**{corpus['seconds']} s**, **{corpus['fps']} frames/s** rendered and encoded "
           f"(targets: ≥300 frames/s, ≥500 clips in ≤180 s).\n")
    publish("sim_speed", payload, md)


if __name__ == "__main__":
    main()
