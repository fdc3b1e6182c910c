"""A simulation run as commands show it: ``generate_dataset`` with a progress display, timed, and counted.

Resumed clips are told apart from newly rendered ones, so the frames/s a user reads is the renderer's speed, not
inflated by clips found on disk.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

from tacreasoner.progress import ClipProgress

__all__ = ["SimulationSummary", "run_simulation"]


@dataclass(frozen=True)
class SimulationSummary:
    manifest: Path
    clips: int
    frames: int
    new_clips: int
    new_frames: int
    seconds: float

    def text(self) -> str:
        rate = self.new_frames / self.seconds if self.seconds > 0 else 0.0
        reused = self.clips - self.new_clips
        rendered = (f"{self.new_clips} clips ({self.new_frames} frames) rendered in {self.seconds:.1f} s "
                    f"wall time ({rate:.0f} frames/s)" if self.new_clips else "nothing left to render")
        resumed = f", {reused} clips resumed from disk" if reused else ""
        return (f"Dataset: {self.clips} clips, {self.frames} frames; {rendered}{resumed}. "
                f"Manifest: {self.manifest}")


def run_simulation(out: Path, objects: int, repeats: int, sensors: list[str], seed: int, workers: int | None,
                   overwrite: bool = False) -> SimulationSummary:
    """Simulate ``objects`` × ``repeats`` clips per sensor into ``out`` (resuming what is there)."""
    from tacreasoner.sim.generate import generate_dataset, read_manifest

    if workers is not None and workers < 1:
        raise ValueError(f"--workers must be at least 1, got {workers}")
    before = set() if overwrite else set(out.glob("clips/*/*.json"))
    start = time.perf_counter()
    with ClipProgress() as progress:
        manifest = generate_dataset(out, objects, repeats, sensors, seed, workers, overwrite, progress=progress)
    seconds = time.perf_counter() - start
    records = read_manifest(manifest)
    new = [r for r in records if (out / r["video"]).with_suffix(".json") not in before]
    return SimulationSummary(manifest, len(records), sum(r["n_frames"] for r in records), len(new),
                             sum(r["n_frames"] for r in new), seconds)
