"""Clip and dataset generation: material + sensor + protocol → mp4 + manifest line.

Every clip's random stream comes from ``SeedSequence([seed, object index, repeat, sensor index])``,
so a clip's bytes depend only on the seed and its position, not on worker count or scheduling, and
an interrupted run resumes by skipping the clips whose sidecar JSON already exists.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tacreasoner.jsonl import iter_jsonl
from tacreasoner.sim.materials import Material, build_object_set, derive_labels
from tacreasoner.sim.mechanics import ContactTrajectory, simulate_contact
from tacreasoner.sim.protocol import ACTIONS, make_protocol
from tacreasoner.sim.render import RenderScene, render_frames
from tacreasoner.sim.sensors import SensorStyle, clip_look, get_sensor
from tacreasoner.video_io import write_video

GENERATOR_VERSION = "dyntac-sim-1"
MANIFEST = "manifest.jsonl"
DATASET_INFO = "dataset.json"


@dataclass
class Clip:
    """One simulated clip in memory."""

    frames: np.ndarray
    trajectory: ContactTrajectory
    material: Material
    sensor: SensorStyle
    action: str
    seed: list[int]


def clip_seed(seed: int, object_index: int, repeat: int, sensor_index: int) -> list[int]:
    return [int(seed), int(object_index), int(repeat), int(sensor_index)]


def action_for_repeat(repeat: int) -> str:
    """Repeats alternate slide / rotate, starting with slide, so every object has both."""
    return ACTIONS[repeat % len(ACTIONS)]


def simulate_trajectory(material: Material, sensor: SensorStyle, action: str,
                        rng: np.random.Generator) -> ContactTrajectory:
    protocol = make_protocol(sensor.fps, action, rng)
    return simulate_contact(material, protocol, rng)


def iter_clip_frames(material: Material, sensor: SensorStyle, action: str, seed: Sequence[int],
                     backend: str = "fft") -> tuple[ContactTrajectory, Iterator[np.ndarray]]:
    """Simulate one clip; frames come lazily, one H×W×3 uint8 frame at a time."""
    rng = np.random.default_rng(np.random.SeedSequence(list(seed)))
    traj = simulate_trajectory(material, sensor, action, rng)
    max_shift = float(np.abs(traj.object_shift_mm).max()) + 1.0
    # A varied style draws the clip's look from its own stream: the contact and texture stay the plain style's.
    look = clip_look(sensor, seed)
    scene = RenderScene.build(look, material, max_shift, rng)

    def frames() -> Iterator[np.ndarray]:
        for chunk in render_frames(traj, scene, backend=backend):
            yield from chunk

    return traj, frames()


def simulate_clip(material: Material, sensor: SensorStyle | str, action: str = "slide",
                  seed: Sequence[int] = (0, 0, 0, 0), backend: str = "fft") -> Clip:
    """Simulate one clip fully in memory (for previews, tests and notebooks)."""
    style = get_sensor(sensor) if isinstance(sensor, str) else sensor
    traj, frames = iter_clip_frames(material, style, action, seed, backend)
    return Clip(np.stack(list(frames)), traj, material, style, action, list(seed))


def _manifest_record(material: Material, sensor: SensorStyle, traj: ContactTrajectory, action: str,
                     repeat: int, seed: list[int], video_rel: str) -> dict:
    return {
        "clip_id": f"{sensor.name}/{material.name}_{repeat}",
        "video": video_rel,
        "object": material.name,
        "object_name": material.display_name,
        "category": material.category,
        "repeat": repeat,
        "sensor": sensor.name,
        "fps": sensor.fps,
        "height": sensor.height,
        "width": sensor.width,
        "n_frames": len(traj),
        "action": action,
        "seed": seed,
        "labels": derive_labels(material),
        "material": material.to_dict(),
        "frames": traj.ground_truth(),
    }


@dataclass(frozen=True)
class ClipJob:
    out_dir: str
    material: Material
    sensor: SensorStyle
    object_index: int
    sensor_index: int
    repeat: int
    seed: int

    @property
    def stem(self) -> Path:
        return Path("clips") / self.sensor.name / f"{self.material.name}_{self.repeat}"


def _run_job(job: ClipJob) -> str:
    """Render + encode one clip, then write its sidecar (the sidecar's existence marks the clip done)."""
    out = Path(job.out_dir)
    seed = clip_seed(job.seed, job.object_index, job.repeat, job.sensor_index)
    action = action_for_repeat(job.repeat)
    traj, frames = iter_clip_frames(job.material, job.sensor, action, seed)
    video_path = out / job.stem.with_suffix(".mp4")
    video_path.parent.mkdir(parents=True, exist_ok=True)
    write_video(video_path, frames, job.sensor.fps)
    record = _manifest_record(job.material, job.sensor, traj, action, job.repeat, seed,
                              job.stem.with_suffix(".mp4").as_posix())
    sidecar = out / job.stem.with_suffix(".json")
    tmp = sidecar.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(record))
    os.replace(tmp, sidecar)
    return record["clip_id"]


def plan_jobs(out_dir: Path, n_objects: int, repeats: int, sensors: Sequence[str], seed: int) -> list[ClipJob]:
    if n_objects < 1:
        raise ValueError(f"number of objects (--objects) must be at least 1, got {n_objects}")
    if repeats < 1:
        raise ValueError(f"repeats per object (--repeats) must be at least 1, got {repeats}")
    if not sensors:
        raise ValueError("--sensors must name at least one sensor")
    styles = [get_sensor(s) for s in sensors]
    names = [s.name for s in styles]
    if len(set(names)) != len(names):
        raise ValueError(f"--sensors lists a sensor twice: {', '.join(sensors)}")
    objects = build_object_set(n_objects, seed)
    return [ClipJob(str(out_dir), m, style, oi, si, r, seed)
            for si, style in enumerate(styles) for oi, m in enumerate(objects) for r in range(repeats)]


def _check_out_dir(out_dir: Path, settings: dict) -> None:
    """Refuse to mix two different generation settings in one directory (resume needs identical ones)."""
    info_path = out_dir / DATASET_INFO
    if info_path.exists():
        try:
            previous = json.loads(info_path.read_text())
        except json.JSONDecodeError as exc:
            raise ValueError(f"{info_path}: not valid JSON ({exc.msg}); remove it or use a new --out") from None
        old = previous.get("settings") or {}
        changed = [f"{k}: {old.get(k)!r} → {v!r}" for k, v in settings.items() if old.get(k) != v]
        if changed:
            raise ValueError(f"{out_dir} already holds a dataset made with different settings "
                             f"({'; '.join(changed)}); use a new output directory or overwrite it")
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        probe = out_dir / ".write-test"
        probe.write_text("ok")
        probe.unlink()
    except OSError as exc:
        raise ValueError(f"cannot write to output directory {out_dir}: {exc.strerror or exc}") from None


def generate_dataset(out_dir: str | Path, n_objects: int, repeats: int = 5, sensors: Sequence[str] = ("mini",),
                     seed: int = 0, workers: int | None = None, overwrite: bool = False,
                     progress: Callable[[int, int], None] | None = None) -> Path:
    """Write ``n_objects × repeats × len(sensors)`` clips plus ``manifest.jsonl``; returns the manifest path.

    Resumable: re-running with the same settings skips finished clips. ``progress(done, total)`` is
    called once before any work (with the clips already finished) and then after every clip.
    """
    out = Path(out_dir)
    jobs = plan_jobs(out, n_objects, repeats, sensors, seed)
    settings = {"generator": GENERATOR_VERSION, "objects": n_objects, "repeats": repeats,
                "sensors": [j.name for j in {j.sensor.name: j.sensor for j in jobs}.values()], "seed": seed}
    if overwrite and (out / DATASET_INFO).exists():
        (out / DATASET_INFO).unlink()
        (out / MANIFEST).unlink(missing_ok=True)
        for side in out.glob("clips/*/*.json"):
            side.unlink()
    _check_out_dir(out, settings)
    (out / DATASET_INFO).write_text(json.dumps({"settings": settings, "n_clips": len(jobs)}, indent=2))

    todo = [j for j in jobs if not (out / j.stem.with_suffix(".json")).exists()]
    done = len(jobs) - len(todo)
    if progress:
        progress(done, len(jobs))
    workers = max(1, min(workers or os.cpu_count() or 1, len(todo) or 1))
    if workers == 1:
        for job in todo:
            _run_job(job)
            done += 1
            if progress:
                progress(done, len(jobs))
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            for _ in pool.map(_run_job, todo, chunksize=1):
                done += 1
                if progress:
                    progress(done, len(jobs))

    return write_manifest(out, jobs)


def write_manifest(out: Path, jobs: Sequence[ClipJob]) -> Path:
    """Concatenate the sidecars in job order into one manifest (atomic)."""
    manifest = out / MANIFEST
    tmp = manifest.with_suffix(".jsonl.tmp")
    with tmp.open("w") as fh:
        for job in jobs:
            fh.write((out / job.stem.with_suffix(".json")).read_text().strip() + "\n")
    os.replace(tmp, manifest)
    return manifest


def read_manifest(path: str | Path) -> list[dict]:
    """Read a simulator manifest (a dataset directory or the manifest file itself)."""
    path = Path(path)
    if path.is_dir():
        path = path / MANIFEST
    if not path.exists():
        raise FileNotFoundError(f"{path}: no simulator manifest here (run `tacreasoner simulate` first)")
    return [record for _, record in iter_jsonl(path)]
