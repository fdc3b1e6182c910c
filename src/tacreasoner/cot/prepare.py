"""TouchCoT step 1 (paper §3.1): QA items → jobs with step indicators and measured cues per video.

A job tells the teacher *which interaction stages* its reasoning must walk through and *what was
measured* in each video (contact area, creep during hold, shear during sliding, residual after
release, stage timings). Cues come from pixels only (:mod:`tacreasoner.data.cues`); the stage
boundaries come from the simulator's ground truth for simulated clips and from the frame-difference
phase detector for real video. One clip appears in many items, so cues are computed once per clip
and kept in a JSON cache file per clip, keyed by the video file's version (mtime, size).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import re
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tacreasoner.cot.schema import STAGES, CoTJob, VideoCues
from tacreasoner.data.cues import FrameSignals, clip_cues, frame_signals
from tacreasoner.jsonl import atomic_write_text
from tacreasoner.tasks.schema import PHASE_TO_STATE, TASKS, ZERO_SHOT_TASKS, QAItem, VideoRef

__all__ = [
    "ACTION_STAGES",
    "ATTRIBUTE_STAGES",
    "CUE_VERSION",
    "CueCache",
    "PrepareStats",
    "clip_cue_table",
    "prepare_jobs",
    "stages_for",
]

CUE_VERSION = "touchcot-cues-v1"
"""Bump when the cue computation changes: cached tables of another version are recomputed."""
ACTION_STAGES = ("slide", "rotate")
ACTION = "action"
"""Placeholder in :data:`ATTRIBUTE_STAGES` for the clip's own action (slide or rotate)."""
ATTRIBUTE_STAGES: dict[str, tuple[str, ...]] = {
    # Stiffness shows in how the imprint grows (press), settles (hold) and recovers (release).
    "hardness": ("press", "hold", ACTION, "release"),
    "elasticity": ("press", "hold", ACTION, "release"),
    # Friction shows as shear and stick-slip while moving, and in how contact is made and broken.
    "friction": ("press", ACTION, "release"),
    # Surface geometry is read from the loaded imprint: at rest (hold) and while scanning (action).
    "protrusion": ("press", "hold", ACTION),
    "roughness": ("press", "hold", ACTION),
    "bumpiness": ("press", "hold", ACTION),
}
"""Stages whose cues carry each attribute (the step indicators of TFA, SFD, PC, SOI and TSA)."""
RFOR_STAGES = ("press", "hold", "release")
"""Real fruit creeps during the hold and leaves a residual dent after release; fakes do not."""
STATE_TO_PHASE = {state: phase for phase, state in PHASE_TO_STATE.items()}
DETECTED, GROUND_TRUTH = "detected", "ground_truth"
NO_CONTACT = "no_contact"


# ------------------------------------------------------------------------------------------- stages


def stages_for(item: QAItem, videos: Sequence[VideoCues] | None = None) -> list[str]:
    """The interaction stages the reasoning for ``item`` must cover, in temporal order.

    Given ``videos`` (the job's cue tables), only stages present in at least one video's phases are
    kept, and the action placeholder becomes the action(s) those videos actually show. Without them
    the action is ``item.meta["action"]`` when known, else both slide and rotate.
    OCSE always requires its segment's own stage (the answer).
    """
    task = item.task
    if task == "OCSE":
        state = item.gold.get("state")
        if state not in STATE_TO_PHASE:
            raise ValueError(f"item {item.id!r} (OCSE): gold 'state' {state!r} is not a contact state "
                             f"({', '.join(STATE_TO_PHASE)})")
        return [STATE_TO_PHASE[state]]
    if task in ("TFA-combined", "OSC"):
        wanted: set[str] = {*STAGES, ACTION}
    elif task == "RFOR":
        wanted = set(RFOR_STAGES)
    elif task.startswith("TFA-"):
        wanted = set(_attribute_stages(item, task.removeprefix("TFA-")))
    elif task in ("SFD", "PC", "SOI"):
        wanted = set(_attribute_stages(item, item.gold.get("attribute")))
    elif task == "TSA":
        needs = item.gold.get("needs")
        if not isinstance(needs, dict) or not needs:
            raise ValueError(f"item {item.id!r} (TSA): gold 'needs' must map attributes to 'high'/'low'")
        wanted = {s for a in needs for s in _attribute_stages(item, a)}
    else:
        raise ValueError(f"item {item.id!r}: no stage indicators for task {task!r}; known: {', '.join(TASKS)}")
    if videos is None:
        known = item.meta.get("action")
        present = set(STAGES) if known not in ACTION_STAGES else set(STAGES) - (set(ACTION_STAGES) - {known})
    else:
        present = {s for v in videos for s in v.phases}
    if ACTION in wanted:
        wanted |= set(ACTION_STAGES)
    return [s for s in STAGES if s in wanted and s in present]


def _attribute_stages(item: QAItem, attribute: object) -> tuple[str, ...]:
    if attribute not in ATTRIBUTE_STAGES:
        raise ValueError(f"item {item.id!r} ({item.task}): no stage indicators for attribute {attribute!r}; "
                         f"known: {', '.join(ATTRIBUTE_STAGES)}")
    return ATTRIBUTE_STAGES[str(attribute)]


# ------------------------------------------------------------------------------------------- cues


Segment = tuple[int | None, int | None]


def clip_cue_table(clip_path: str | os.PathLike[str], phases: Sequence[str] | None, fps: float,
                   action: str | None, *, clip_id: str | None = None, start: int | None = None,
                   end: int | None = None) -> VideoCues:
    """Cue table of one video: pixel cues (``frame_signals`` + ``clip_cues``) plus stage timings.

    ``phases`` are per-frame labels (simulator ground truth); None detects them from the pixels
    (``detect_contact_phases``, ``phase_source="detected"``) with ``action`` as the name of the
    moving stage. ``start``/``end`` restrict the cues to a segment [start, end) (OCSE): the
    background is still the clip's gel at rest, but every measurement uses the segment's frames only,
    and phases and timings are relative to the segment's first frame.
    """
    path = Path(clip_path)
    return _cue_tables(path, phases, fps, action, [(start, end)], clip_id or path.stem)[0]


def _cue_tables(path: Path, phases: Sequence[str] | None, fps: float, action: str | None,
                segments: Sequence[Segment], clip_id: str) -> list[VideoCues]:
    """Cue tables for several segments of one clip, decoding it and measuring its frames once."""
    from tacreasoner.data.cache import load_frames
    from tacreasoner.data.sampling import background_frame, detect_contact_phases

    fps = float(fps)
    if not np.isfinite(fps) or fps <= 0:
        raise ValueError(f"clip {clip_id!r}: fps must be a positive number, got {fps!r}")
    frames = load_frames(path)
    n = len(frames)
    if phases is None:
        detector_action = action if action in ACTION_STAGES else "dynamic"
        labels = np.asarray(detect_contact_phases(frames, detector_action), dtype=object)
        source = DETECTED
    else:
        labels = np.asarray([str(p) for p in phases], dtype=object)
        source = GROUND_TRUTH
        if len(labels) != n:
            raise ValueError(f"clip {clip_id!r} ({path}): {len(labels)} phase labels but the video has {n} frames")
    signals = frame_signals(frames, background_frame(frames, labels))
    out = []
    for start, end in segments:
        s, e = _check_segment(clip_id, n, start, end)
        seg_signals = signals if (s, e) == (0, n) else _slice_signals(signals, s, e)
        is_segment = start is not None or end is not None
        out.append(VideoCues(clip_id=clip_id, phases=_phase_ranges(labels[s:e]), phase_source=source,
                             cues=_cue_dict(seg_signals, labels[s:e], fps, is_segment), fps=fps))
    return out


def _check_segment(clip_id: str, n: int, start: int | None, end: int | None) -> tuple[int, int]:
    s = 0 if start is None else int(start)
    e = n if end is None else int(end)
    if not 0 <= s < e <= n:
        raise ValueError(f"clip {clip_id!r}: segment [{start}, {end}) is not inside its {n} frames")
    return s, e


def _slice_signals(signals: FrameSignals, start: int, end: int) -> FrameSignals:
    """The segment's own per-frame signals; its first frame has no predecessor inside the segment."""
    parts = {f.name: getattr(signals, f.name)[start:end].copy() for f in dataclasses.fields(signals)}
    parts["diff_energy"][0] = 0.0
    return FrameSignals(**parts)


def _phase_ranges(labels: np.ndarray) -> dict[str, list[int]]:
    """Stage → [first frame, last frame + 1) for every stage of :data:`STAGES` present."""
    out = {}
    for stage in STAGES:
        idx = np.flatnonzero(labels == stage)
        if idx.size:
            out[stage] = [int(idx[0]), int(idx[-1]) + 1]
    return out


def _cue_dict(signals: FrameSignals, labels: np.ndarray, fps: float, is_segment: bool) -> dict[str, float]:
    """``clip_cues`` plus the timings and trends a reasoning trace cites (all floats, all finite)."""
    cues = clip_cues(signals, labels)
    n = len(labels)
    area, inten = signals.area, signals.intensity
    cues["duration_s"] = n / fps
    for stage, (s, e) in _phase_ranges(labels).items():
        cues[f"{stage}_start_s"] = s / fps
        cues[f"{stage}_end_s"] = e / fps
    press = np.flatnonzero(labels == "press")
    if press.size:
        cues["press_area"] = float(area[press].max())
    contact = press if press.size else np.flatnonzero(labels != NO_CONTACT)
    if contact.size:
        # Loading time: from first touch until the pressed imprint is (nearly, 95 %) at its largest.
        reach = contact[area[contact] >= 0.95 * max(float(area[contact].max()), 1e-9)]
        cues["time_to_max_contact_s"] = float(reach[0] - contact[0]) / fps
    cues["hold_intensity_change"] = _relative_change(inten, np.flatnonzero(labels == "hold"))
    action = np.flatnonzero(np.isin(labels, ACTION_STAGES))
    cues["action_travel_px"] = _travel(signals.centroid[action])
    release = np.flatnonzero(labels == "release")
    if release.size:
        peak = max(float(area.max()), 1e-6)
        faded = release[area[release] < 0.2 * peak]
        cues["release_time_s"] = float((faded[0] - release[0]) / fps) if faded.size else release.size / fps
    if is_segment:
        q = max(1, n // 4)
        peak = max(float(area.max()), 1e-6)
        cues["seg_area_start"] = float(area[:q].mean())
        cues["seg_area_end"] = float(area[-q:].mean())
        cues["seg_area_change"] = float((area[-q:].mean() - area[:q].mean()) / peak)
        cues["seg_intensity_change"] = _relative_change(inten, np.arange(n))
        cues["seg_motion"] = float(signals.diff_energy[1:].mean() / max(float(inten.mean()), 1e-6)) if n > 1 else 0.0
        cues["seg_travel_px"] = _travel(signals.centroid)
    return {k: (float(v) if np.isfinite(v) else 0.0) for k, v in cues.items()}


def _relative_change(x: np.ndarray, idx: np.ndarray) -> float:
    """(last quarter − first quarter) / first quarter over the frames ``idx`` (0 when too short)."""
    if idx.size < 4:
        return 0.0
    q = max(1, idx.size // 4)
    start, end = float(x[idx[:q]].mean()), float(x[idx[-q:]].mean())
    return (end - start) / max(abs(start), 1e-6)


def _travel(centroid: np.ndarray) -> float:
    """Straight-line distance in pixels between where the imprint starts and ends (0 without contact)."""
    finite = centroid[np.isfinite(centroid).all(axis=1)]
    return float(np.linalg.norm(finite[-1] - finite[0])) if len(finite) >= 2 else 0.0


# ------------------------------------------------------------------------------------------- cache


class CueCache:
    """One JSON file per clip (``<clip>-<hash>.json``) holding its cue tables for every segment asked.

    A file remembers the video's mtime and size; when the video changes, its tables are recomputed.
    ``hits``/``misses`` count cue tables served from the cache / computed.
    """

    def __init__(self, directory: str | os.PathLike[str]) -> None:
        self.directory = Path(directory)
        self.hits = 0
        self.misses = 0

    def file_for(self, clip_id: str) -> Path:
        safe = re.sub(r"[^A-Za-z0-9._-]+", "_", clip_id).strip("._")[:80] or "clip"
        return self.directory / f"{safe}-{hashlib.sha1(clip_id.encode()).hexdigest()[:10]}.json"

    def lookup(self, clip_id: str, path: Path) -> dict[str, VideoCues]:
        """Cached tables of this clip (entry key → table); empty when absent, stale or unreadable."""
        file = self.file_for(clip_id)
        try:
            data = json.loads(file.read_text(encoding="utf-8"))
        except FileNotFoundError:
            return {}
        except (OSError, ValueError):
            return {}  # a damaged cache file is recomputed and rewritten
        if not isinstance(data, dict) or data.get("cue_version") != CUE_VERSION or data.get("clip_id") != clip_id:
            return {}
        if data.get("video") != _file_version(path):
            return {}
        try:
            return {k: VideoCues(**v) for k, v in data.get("entries", {}).items()}
        except TypeError:
            return {}

    def store(self, clip_id: str, path: Path, tables: dict[str, VideoCues]) -> None:
        """Merge ``tables`` into the clip's file (atomic write)."""
        entries = {**self.lookup(clip_id, path), **tables}
        payload = {"cue_version": CUE_VERSION, "clip_id": clip_id, "path": str(path), "video": _file_version(path),
                   "entries": {k: dataclasses.asdict(v) for k, v in sorted(entries.items())}}
        atomic_write_text(self.file_for(clip_id), json.dumps(payload, indent=1))


def _file_version(path: Path) -> dict[str, int]:
    try:
        st = Path(path).stat()
    except FileNotFoundError:
        raise FileNotFoundError(f"{path}: no such video file") from None
    return {"mtime_ns": st.st_mtime_ns, "size": st.st_size}


# ------------------------------------------------------------------------------------------- jobs


@dataclass
class PrepareStats:
    """What :func:`prepare_jobs` did: filled in when passed as ``stats=``."""

    items: int = 0
    """Items of the split before task filtering."""
    jobs: int = 0
    skipped_zero_shot: int = 0
    clips: int = 0
    tables: int = 0
    """Distinct (clip, segment) cue tables the jobs use."""
    computed: int = 0
    cached: int = 0
    seconds: float = 0.0
    by_task: dict[str, int] = field(default_factory=dict)


@dataclass
class _ClipWork:
    """Everything needed to measure one clip, picklable for the process pool."""

    clip_id: str
    path: Path
    phases: list[str] | None
    fps: float
    action: str | None
    segments: list[Segment] = field(default_factory=list)

    def entry_key(self, segment: Segment) -> str:
        """Cache entry: the segment plus what the cues depend on besides the pixels."""
        if self.phases is None:
            labels = f"{DETECTED}:{self.action}"
        else:
            labels = hashlib.sha1("\n".join(self.phases).encode()).hexdigest()[:12]
        start, end = segment
        return f"{'' if start is None else start}:{'' if end is None else end}|{labels}|{self.fps:.6g}"


def _measure(work: _ClipWork) -> list[VideoCues]:
    return _cue_tables(work.path, work.phases, work.fps, work.action, work.segments, work.clip_id)


def prepare_jobs(bench_dir: str | os.PathLike[str], split: str = "train", *, cache_dir: str | os.PathLike[str],
                 tasks: Iterable[str] | None = None, limit: int | None = None, workers: int = 1,
                 progress: Callable[[int, int], None] | None = None,
                 stats: PrepareStats | None = None) -> list[CoTJob]:
    """CoT jobs for the items of one benchmark split, in file order (TSA is never included).

    Phases of simulated clips are the simulator's ground truth (the dataset at ``info["data"]`` is
    read once and indexed by clip id); other sources' phases are detected from the pixels. Cue
    tables are computed once per clip (``workers`` > 1: in a process pool) and cached in
    ``cache_dir``. ``progress(done, total)`` counts clips. ``limit`` keeps the first N jobs.
    """
    from tacreasoner.tasks.bench import load_bench

    t0 = time.perf_counter()
    stats = stats if stats is not None else PrepareStats()
    wanted = _check_tasks(tasks)
    if limit is not None and (isinstance(limit, bool) or not isinstance(limit, int) or limit < 0):
        raise ValueError(f"limit must be an integer >= 0, got {limit!r}")
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    info, all_items = load_bench(bench_dir, split)
    stats.items = len(all_items)
    stats.skipped_zero_shot = sum(i.task in ZERO_SHOT_TASKS for i in all_items)
    items = [i for i in all_items if i.task not in ZERO_SHOT_TASKS and (wanted is None or i.task in wanted)]
    items = items if limit is None else items[:limit]

    work = _plan_clips(items, info, Path(bench_dir))
    tables = _cue_tables_for(work, CueCache(cache_dir), workers, progress, stats)
    jobs = []
    for item in items:
        videos = [tables[ref.clip_id, (ref.start, ref.end)] for ref in item.videos]
        jobs.append(CoTJob(item=item, stages=stages_for(item, videos), videos=videos))
        stats.by_task[item.task] = stats.by_task.get(item.task, 0) + 1
    stats.jobs = len(jobs)
    stats.clips = len(work)
    stats.tables = len(tables)
    stats.seconds = time.perf_counter() - t0
    return jobs


def _check_tasks(tasks: Iterable[str] | None) -> set[str] | None:
    if tasks is None:
        return None
    wanted = set([tasks] if isinstance(tasks, str) else tasks)
    unknown = sorted(wanted - set(TASKS))
    if unknown:
        raise ValueError(f"unknown task(s) {unknown}; known: {', '.join(TASKS)}")
    zero_shot = sorted(wanted & set(ZERO_SHOT_TASKS))
    if zero_shot:
        raise ValueError(f"{', '.join(zero_shot)} is zero-shot: it is evaluated only and never gets TouchCoT "
                         "training data")
    return wanted


def _plan_clips(items: Sequence[QAItem], info: dict, bench_dir: Path) -> dict[str, _ClipWork]:
    """One unit of work per clip: its file, phases (ground truth or None), fps, action and segments."""
    from tacreasoner.video_io import probe_video

    source = info.get("source", "")
    root = Path(info.get("video_root") or info.get("data") or bench_dir)
    sim = _sim_clips(info) if source == "sim" and items else {}
    work: dict[str, _ClipWork] = {}
    for item in items:
        for ref in item.videos:
            w = work.get(ref.clip_id)
            if w is None:
                clip = sim.get(ref.clip_id)
                if source == "sim" and clip is None:
                    raise ValueError(f"item {item.id!r}: clip {ref.clip_id!r} is not in the simulator dataset "
                                     f"{info.get('data')} (regenerate the benchmark?)")
                path = _resolve(ref, root, clip.path if clip is not None else None, item)
                if clip is not None:
                    w = _ClipWork(ref.clip_id, path, list(clip.phases) if clip.phases else None, clip.fps,
                                  clip.action)
                else:
                    action = "rotate" if source == "physiclear" else None
                    w = _ClipWork(ref.clip_id, path, None, probe_video(path).fps, action)
                work[ref.clip_id] = w
            if (ref.start, ref.end) not in w.segments:
                w.segments.append((ref.start, ref.end))
    return work


def _sim_clips(info: dict) -> dict:
    from tacreasoner.data.readers import read_sim_dataset

    data = info.get("data")
    if not data:
        raise ValueError("bench.json has no 'data' field: cannot find the simulator dataset for phase ground truth")
    return {c.clip_id: c for c in read_sim_dataset(data)}


def _resolve(ref: VideoRef, root: Path, fallback: Path | None, item: QAItem) -> Path:
    if ref.path:
        path = Path(ref.path)
        path = path if path.is_absolute() else root / path
    elif fallback is not None:
        path = Path(fallback)
    else:
        raise ValueError(f"item {item.id!r}: video {ref.clip_id!r} has no path")
    if not path.exists():
        raise FileNotFoundError(f"item {item.id!r}: video {ref.clip_id!r} not found at {path}")
    return path


def _cue_tables_for(work: dict[str, _ClipWork], cache: CueCache, workers: int,
                    progress: Callable[[int, int], None] | None,
                    stats: PrepareStats) -> dict[tuple[str, Segment], VideoCues]:
    """Every (clip, segment) table: from the cache where valid, else measured (once per clip)."""
    tables: dict[tuple[str, Segment], VideoCues] = {}
    todo: list[_ClipWork] = []
    for w in work.values():
        cached = cache.lookup(w.clip_id, w.path)
        missing = [s for s in w.segments if w.entry_key(s) not in cached]
        for s in w.segments:
            if w.entry_key(s) in cached:
                tables[w.clip_id, s] = cached[w.entry_key(s)]
                cache.hits += 1
        if missing:
            todo.append(dataclasses.replace(w, segments=missing))
    total, done = len(work), len(work) - len(todo)
    if progress:
        progress(done, total)

    def finish(w: _ClipWork, result: list[VideoCues]) -> None:
        nonlocal done
        cache.store(w.clip_id, w.path, {w.entry_key(s): v for s, v in zip(w.segments, result, strict=True)})
        for s, v in zip(w.segments, result, strict=True):
            tables[w.clip_id, s] = v
        cache.misses += len(result)
        done += 1
        if progress:
            progress(done, total)

    if workers == 1 or len(todo) <= 1:
        for w in todo:
            finish(w, _measure(w))
    else:
        from tacreasoner.data.cache import set_memory_limit

        # workers measure each clip once: keeping decoded frames in memory would only cost RAM
        with ProcessPoolExecutor(max_workers=min(workers, len(todo)), initializer=set_memory_limit,
                                 initargs=(0,)) as pool:
            futures = {pool.submit(_measure, w): w for w in todo}
            for future in as_completed(futures):
                finish(futures[future], future.result())
    stats.computed += cache.misses
    stats.cached += cache.hits
    return tables
