"""Readers that turn tactile data on disk into :class:`TactileClip` lists.

Sources: single videos, image folders, DynTAC-Sim datasets, the VTV-150K layout and PhysiCLeAR.

Every video is checked when it is listed, not when a training step first decodes it: a header probe
plus a packet scan (no decoding, well under a millisecond per clip) catches corrupt, empty,
truncated, zero-frame and non-video files.

One API for bad files everywhere (``on_error``):

* ``"skip"`` (default): the file is left out, and its path and reason go into a :class:`LoadReport`;
  nothing is dropped silently, and the dataset readers also log one warning naming what was skipped.
* ``"raise"``: the first bad file raises (:class:`VideoError`, or ``FileNotFoundError`` for a listed
  file that does not exist).

:func:`load_clips` returns the :class:`LoadReport` itself. The dataset readers return a
:class:`ClipList`: an ordinary ``list`` of clips with the report attached as ``.report``, so code
that only wants clips treats it as a list. Label problems (an unknown rank, a missing field) are
never skipped: they mean the dataset description is wrong, so they raise ``ValueError`` naming the
file, object and field.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import logging
import os
import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import av
import numpy as np

from tacreasoner.data.clip import TactileClip
from tacreasoner.video_io import VideoError, VideoInfo, probe_video

__all__ = [
    "IMAGE_SUFFIXES",
    "PHYSICLEAR_ATTRIBUTES",
    "VIDEO_SUFFIXES",
    "VTV_ATTRIBUTES",
    "ClipList",
    "LoadReport",
    "check_video",
    "default_physiclear_dir",
    "load_clips",
    "read_image_folder",
    "read_physiclear",
    "read_sim_dataset",
    "read_video_clip",
    "read_vtv150k",
]

logger = logging.getLogger(__name__)

OnError = Literal["skip", "raise"]
VIDEO_SUFFIXES = (".mp4", ".mov", ".avi")
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp")
VTV_ATTRIBUTES = ("hardness", "protrusion", "elasticity", "friction")
PHYSICLEAR_ATTRIBUTES = ("hardness", "roughness", "bumpiness")
PHYSICLEAR_ENV = "TACREASONER_PHYSICLEAR"
UNLABELLED = "unlabelled"
_RANKS = (0, 1, 2)
# TactileClip fields a reader fills itself: passing them in **fields would contradict the file.
_READER_OWNED = frozenset({"clip_id", "object_id", "fps", "n_frames", "path", "frames_in_memory"})
_CLIP_FIELDS = frozenset(f.name for f in dataclasses.fields(TactileClip)) - _READER_OWNED


# ------------------------------------------------------------------------------------------- reports


@dataclass
class LoadReport:
    """What a scan produced: the clips, every file left out with its reason, and unlabelled clips."""

    clips: list[TactileClip] = field(default_factory=list)
    skipped: list[tuple[Path, str]] = field(default_factory=list)
    """(path, reason) for each file that was not loaded."""
    unlabelled: int = 0
    """Clips loaded without property labels (kept: usable for self-supervised pre-training)."""
    unlabelled_objects: list[str] = field(default_factory=list)
    source: str = ""
    """What was scanned (a directory or manifest), for messages."""

    @property
    def n_scanned(self) -> int:
        return len(self.clips) + len(self.skipped)

    def summary(self, max_listed: int = 10) -> str:
        where = f" from {self.source}" if self.source else ""
        text = f"loaded {len(self.clips)} of {self.n_scanned} clips{where}"
        if self.unlabelled:
            text += f" ({self.unlabelled} unlabelled, objects: {', '.join(self.unlabelled_objects)})"
        if self.skipped:
            listed = "; ".join(why if Path(p).name in why else f"{Path(p).name}: {why}"
                               for p, why in self.skipped[:max_listed])
            more = f"; … {len(self.skipped) - max_listed} more" if len(self.skipped) > max_listed else ""
            text += f"; skipped {len(self.skipped)}: {listed}{more}"
        return text

    def __str__(self) -> str:
        return self.summary()

    def _add_unlabelled(self, clip: TactileClip) -> None:
        self.unlabelled += 1
        if clip.object_id not in self.unlabelled_objects:
            self.unlabelled_objects.append(clip.object_id)


class ClipList(list):
    """A ``list[TactileClip]`` that also carries the :class:`LoadReport` of the scan that made it."""

    def __init__(self, report: LoadReport) -> None:
        super().__init__(report.clips)
        self.report = report


def _check_on_error(on_error: str) -> None:
    if on_error not in ("skip", "raise"):
        raise ValueError(f"on_error must be 'skip' or 'raise', got {on_error!r}")


def _attempt(report: LoadReport, path: Path, on_error: OnError, make: Callable[[], TactileClip | None]) -> None:
    """Run ``make``; a bad or missing file is recorded (skip) or re-raised (raise)."""
    try:
        clip = make()
    except (VideoError, OSError) as exc:
        if on_error == "raise":
            raise
        report.skipped.append((path, str(exc)))
        return
    if clip is not None:
        report.clips.append(clip)


def _finish(report: LoadReport) -> ClipList:
    if report.skipped:
        logger.warning("%s", report.summary())
    return ClipList(report)


# ------------------------------------------------------------------------------------------- checks


def check_video(path: str | os.PathLike[str], min_frames: int = 1) -> VideoInfo:
    """Header probe plus packet scan: a usable video's info, else :class:`VideoError` naming the file.

    The scan reads the compressed packets without decoding them, so it is cheap, yet it sees what a
    header alone cannot: fewer packets than the index declares (a truncated file), no packets at all,
    and still images (FFmpeg opens a .png as a one-frame "video").
    """
    info = probe_video(path)
    path = Path(path)
    packets = 0
    try:
        with av.open(str(path), mode="r") as container:
            fmt = container.format.name
            if fmt == "image2" or fmt.endswith("_pipe"):
                raise VideoError(f"{path.name}: a still image ({fmt}), not a video")
            stream = container.streams.video[0]
            declared = int(stream.frames or 0)
            for packet in container.demux(stream):
                if packet.size:
                    packets += 1
    except (av.error.FFmpegError, OSError) as exc:
        raise VideoError(f"{path.name}: corrupt container after {packets} packets ({exc})") from exc
    if packets == 0:
        raise VideoError(f"{path.name}: contains 0 frames")
    if declared and packets < declared:
        raise VideoError(f"{path.name}: holds {packets} of {declared} frames (truncated file?)")
    n_frames = declared or packets
    if n_frames < min_frames:
        raise VideoError(f"{path.name}: has {n_frames} frames, fewer than min_frames={min_frames}")
    return dataclasses.replace(info, n_frames=n_frames)


def _split_stem(stem: str) -> tuple[str, int] | None:
    """``<object>_<k>`` → (object, k), splitting at the last underscore; None if it does not fit."""
    obj, sep, index = stem.rpartition("_")
    if not sep or not obj or not index.isdigit():
        return None
    return obj, int(index)


def _clip_fields(fields: Mapping[str, Any], what: str) -> dict[str, Any]:
    owned = sorted(set(fields) & _READER_OWNED)
    if owned:
        raise TypeError(f"{what}: {', '.join(owned)} come from the file itself and cannot be passed")
    unknown = sorted(set(fields) - _CLIP_FIELDS)
    if unknown:
        raise TypeError(f"{what}: unknown TactileClip field(s) {', '.join(unknown)}; "
                        f"allowed: {', '.join(sorted(_CLIP_FIELDS))}")
    return dict(fields)


# ------------------------------------------------------------------------------------------- single sources


def read_video_clip(path: str | os.PathLike[str], *, clip_id: str | None = None, object_id: str | None = None,
                    **fields: Any) -> TactileClip:
    """One video as a clip (frames decoded lazily); fps and n_frames come from a cheap probe.

    ``clip_id`` defaults to the file stem, ``object_id`` to the stem without its ``_<k>`` suffix.
    ``fields`` are other :class:`TactileClip` fields (sensor, labels, split, …).
    """
    path = Path(path)
    return _video_clip(path, 1, clip_id, object_id, _clip_fields(fields, f"read_video_clip({path.name})"))


def _video_clip(path: Path, min_frames: int, clip_id: str | None, object_id: str | None,
                fields: dict[str, Any]) -> TactileClip:
    info = check_video(path, min_frames)
    parsed = _split_stem(path.stem)
    fields = dict(fields)
    meta = {"height": info.height, "width": info.width, "codec": info.codec, **fields.pop("meta", {})}
    return TactileClip(
        clip_id=clip_id if clip_id is not None else path.stem,
        object_id=object_id if object_id is not None else (parsed[0] if parsed else path.stem),
        fps=info.fps,
        path=path,
        n_frames=info.n_frames,
        meta=meta,
        **fields,
    )


def _natural_key(name: str) -> list[Any]:
    """frame2 before frame10: digit runs compare as numbers."""
    return [(0, int(part), part) if part.isdigit() else (1, 0, part.lower()) for part in re.split(r"(\d+)", name)]


def _decode_image(path: Path) -> np.ndarray:
    try:
        with av.open(str(path), mode="r") as container:
            frame = next(container.decode(video=0))
            return frame.to_ndarray(format="rgb24")
    except (av.error.FFmpegError, OSError, StopIteration, IndexError) as exc:
        raise VideoError(f"{path}: not a readable image ({exc or 'no picture'})") from exc


def read_image_folder(folder: str | os.PathLike[str], fps: float, *, clip_id: str | None = None,
                      object_id: str | None = None, **fields: Any) -> TactileClip:
    """A folder of frames (png/jpg/jpeg/bmp, natural sort order) as one clip, decoded into memory."""
    folder = Path(folder)
    if not folder.is_dir():
        raise FileNotFoundError(f"{folder}: not a directory of frames")
    try:
        fps = float(fps)
    except (TypeError, ValueError):
        raise ValueError(f"{folder}: fps must be a positive number, got {fps!r}") from None
    if not np.isfinite(fps) or fps <= 0:
        raise ValueError(f"{folder}: fps must be a positive number, got {fps!r}")
    kwargs = _clip_fields(fields, f"read_image_folder({folder.name})")
    files = sorted((p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES),
                   key=lambda p: _natural_key(p.name))
    if not files:
        raise ValueError(f"{folder}: no frames found (expected {', '.join(IMAGE_SUFFIXES)} files)")
    frames = [_decode_image(files[0])]
    for file in files[1:]:
        image = _decode_image(file)
        if image.shape != frames[0].shape:
            raise ValueError(f"{folder}: {file.name} is {image.shape[1]}×{image.shape[0]} (W×H) but "
                             f"{files[0].name} is {frames[0].shape[1]}×{frames[0].shape[0]}; "
                             "all frames must have the same size")
        frames.append(image)
    stack = np.stack(frames)
    stack.flags.writeable = False
    meta = {"height": stack.shape[1], "width": stack.shape[2], "frame_files": [f.name for f in files],
            **kwargs.pop("meta", {})}
    return TactileClip(
        clip_id=clip_id if clip_id is not None else folder.name,
        object_id=object_id if object_id is not None else folder.name,
        fps=fps,
        path=folder,
        frames_in_memory=stack,
        meta=meta,
        **kwargs,
    )


def load_clips(paths: Iterable[str | os.PathLike[str]], *, on_error: OnError = "skip", min_frames: int = 1,
               **fields: Any) -> LoadReport:
    """Probe every video in ``paths`` and return the clips plus what was skipped and why.

    ``min_frames`` also skips clips too short to use (PhysiCLeAR has a few 3- and 7-frame clips);
    ``fields`` are passed to every clip (see :func:`read_video_clip`).
    """
    _check_on_error(on_error)
    kwargs = _clip_fields(fields, "load_clips")
    report = LoadReport()
    for raw in paths:
        path = Path(raw)
        _attempt(report, path, on_error, lambda path=path: _video_clip(path, min_frames, None, None, kwargs))
    return report


# ------------------------------------------------------------------------------------------- datasets


def read_sim_dataset(root: str | os.PathLike[str], *, on_error: OnError = "skip", min_frames: int = 1) -> ClipList:
    """A DynTAC-Sim dataset (directory or ``manifest.jsonl``) with its ground truth: labels, per-frame
    phases, action, sensor. The per-frame physics (force, shear, …) goes to ``meta["ground_truth"]``."""
    from tacreasoner.sim.generate import MANIFEST, read_manifest

    _check_on_error(on_error)
    root = Path(root)
    manifest = root / MANIFEST if root.is_dir() else root
    records = read_manifest(manifest)
    report = LoadReport(source=str(manifest))
    for lineno, rec in enumerate(records, 1):
        missing = [k for k in ("clip_id", "video", "object", "fps", "n_frames", "labels", "frames") if k not in rec]
        if missing:
            raise ValueError(f"{manifest}:{lineno}: record lacks field(s) {', '.join(missing)}")
        path = manifest.parent / rec["video"]
        _attempt(report, path, on_error, lambda rec=rec, path=path: _sim_clip(rec, path, min_frames))
    return _finish(report)


def _sim_clip(rec: dict, path: Path, min_frames: int) -> TactileClip:
    info = check_video(path, min_frames)
    truth = dict(rec["frames"])
    phases = [str(p) for p in truth.pop("phase", [])] or None
    if info.n_frames != rec["n_frames"] or (phases is not None and len(phases) != info.n_frames):
        raise VideoError(f"{path.name}: video has {info.n_frames} frames but the manifest says {rec['n_frames']} "
                         f"(and {len(phases or [])} phase labels); regenerate the clip")
    material = rec.get("material") or {}
    return TactileClip(
        clip_id=rec["clip_id"],
        object_id=rec["object"],
        fps=info.fps,
        path=path,
        sensor=rec.get("sensor", "unknown"),
        object_name=rec.get("object_name", ""),
        category=rec.get("category", ""),
        material=material.get("material", "") if isinstance(material, dict) else str(material),
        labels=rec["labels"],
        phases=phases,
        action=rec.get("action"),
        n_frames=info.n_frames,
        source="sim",
        meta={"repeat": rec.get("repeat"), "seed": rec.get("seed"), "height": info.height, "width": info.width,
              "material_params": material, "ground_truth": truth},
    )


def _check_rank(value: Any, where: str, obj: str, attr: str) -> int:
    """0/1/2 as int (CSV gives strings); anything else names the file, object and field."""
    if isinstance(value, str):
        value = value.strip()
        value = int(value) if value.isdigit() else value
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, bool) or value not in _RANKS:
        raise ValueError(f"{where}: object {obj!r}, field {attr!r}: expected a rank 0, 1 or 2, got {value!r}")
    return int(value)


def _read_rank_table(ranks: str | os.PathLike[str] | Mapping[str, Mapping[str, Any]]) -> dict[str, dict[str, int]]:
    """VTV-150K per-object ranks from JSON ``{object: {attr: r}}``, CSV ``object,<attrs>``, or a dict."""
    if isinstance(ranks, Mapping):
        where, table = "rank table", ranks
    else:
        path = Path(ranks)
        where = str(path)
        if not path.is_file():
            raise FileNotFoundError(f"{path}: no rank table (expected a .json or .csv file)")
        if path.suffix.lower() == ".json":
            try:
                table = json.loads(path.read_text())
            except json.JSONDecodeError as exc:
                raise ValueError(f"{path}: not valid JSON ({exc.msg} at line {exc.lineno})") from None
            if not isinstance(table, dict):
                raise ValueError(f"{path}: expected an object {{object: {{attribute: rank}}}}")
        elif path.suffix.lower() == ".csv":
            table = _read_rank_csv(path)
        else:
            raise ValueError(f"{path}: rank table must be .json or .csv, got {path.suffix or 'no suffix'}")
    out: dict[str, dict[str, int]] = {}
    for obj, row in table.items():
        if not isinstance(row, Mapping):
            raise ValueError(f"{where}: object {obj!r}: expected {{attribute: rank}}, got {type(row).__name__}")
        missing = [a for a in VTV_ATTRIBUTES if a not in row]
        if missing:
            raise ValueError(f"{where}: object {obj!r}: missing field(s) {', '.join(missing)}")
        out[str(obj)] = {a: _check_rank(row[a], where, str(obj), a) for a in VTV_ATTRIBUTES}
    return out


def _read_rank_csv(path: Path) -> dict[str, dict[str, str]]:
    with path.open(newline="") as fh:
        reader = csv.DictReader(fh)
        header = [h.strip() for h in reader.fieldnames or []]
        missing = [c for c in ("object", *VTV_ATTRIBUTES) if c not in header]
        if missing:
            raise ValueError(f"{path}: header lacks column(s) {', '.join(missing)}; "
                             f"expected object,{','.join(VTV_ATTRIBUTES)}")
        table: dict[str, dict[str, str]] = {}
        for lineno, row in enumerate(reader, 2):
            row = {(k or "").strip(): v for k, v in row.items()}
            obj = (row.get("object") or "").strip()
            if not obj:
                raise ValueError(f"{path}:{lineno}: empty object name")
            if obj in table:
                raise ValueError(f"{path}:{lineno}: object {obj!r} listed twice")
            table[obj] = {a: row.get(a) or "" for a in VTV_ATTRIBUTES}
    return table


def read_vtv150k(root: str | os.PathLike[str], ranks: str | os.PathLike[str] | Mapping[str, Mapping[str, Any]], *,
                 on_error: OnError = "skip", min_frames: int = 1, sensor: str = "unknown") -> ClipList:
    """VTV-150K layout: a flat folder of ``<object>_<k>.<mp4|mov|avi>`` plus a per-object rank table.

    Object names may contain underscores (the index follows the last one). Videos of objects without
    ranks are kept with split ``"unlabelled"`` and empty labels, and counted in the report; files
    whose name does not fit ``<object>_<k>`` are skipped with that reason.
    """
    _check_on_error(on_error)
    root = Path(root)
    if not root.is_dir():
        raise FileNotFoundError(f"{root}: not a VTV-150K video directory")
    table = _read_rank_table(ranks)
    report = LoadReport(source=str(root))
    videos = sorted((p for p in root.iterdir() if p.is_file() and p.suffix.lower() in VIDEO_SUFFIXES),
                    key=lambda p: _natural_key(p.name))
    for path in videos:
        _attempt(report, path, on_error, lambda path=path: _vtv_clip(path, table, min_frames, sensor))
    for clip in report.clips:
        if not clip.labels:
            report._add_unlabelled(clip)
    return _finish(report)


def _vtv_clip(path: Path, table: Mapping[str, dict[str, int]], min_frames: int, sensor: str) -> TactileClip:
    parsed = _split_stem(path.stem)
    if parsed is None:
        raise VideoError(f"{path.name}: name does not follow <object>_<k>.{path.suffix.lstrip('.')}")
    obj, _ = parsed
    ranks = table.get(obj)
    fields = {"sensor": sensor, "object_name": obj.replace("_", " "), "source": "vtv150k",
              "labels": {"vtv150k": dict(ranks)} if ranks else {}, "split": "" if ranks else UNLABELLED}
    return _video_clip(path, min_frames, None, obj, fields)


def default_physiclear_dir() -> Path | None:
    """Where PhysiCLeAR lives: ``$TACREASONER_PHYSICLEAR``, ``../shared/data/physiclear`` from the current
    directory, or next to the repository checkout; the first holding ``labels.json``, else None."""
    import tacreasoner

    candidates = []
    env = os.environ.get(PHYSICLEAR_ENV, "").strip()
    if env:
        candidates.append(Path(env).expanduser())
    candidates.append(Path.cwd().parent / "shared" / "data" / "physiclear")
    # src/tacreasoner/__init__.py → parents[2] is the checkout; the shared folder sits beside it.
    candidates.append(Path(tacreasoner.__file__).resolve().parents[3] / "shared" / "data" / "physiclear")
    for candidate in candidates:
        if (candidate / "labels.json").is_file():
            return candidate
    return None


def _normalise_split(split: Any, where: str, obj: str) -> str:
    if not isinstance(split, str) or not split.strip():
        raise ValueError(f"{where}: object {obj!r}, field 'split': expected a split name, got {split!r}")
    split = split.strip().lower()
    return UNLABELLED if split in ("unlabeled", "unlabelled") else split


def read_physiclear(root: str | os.PathLike[str] | None = None, *, on_error: OnError = "skip",
                    min_frames: int = 1) -> ClipList:
    """PhysiCLeAR (Octopi): ``labels.json`` + ``videos/``; per-object hardness/roughness/bumpiness ranks.

    ``root`` defaults to :func:`default_physiclear_dir`. Splits come from labels.json ("unlabeled" →
    ``"unlabelled"``; those objects have no labels). Videos listed but missing are skipped and
    reported. Sensor is GelSight Mini; the procedures are pressing then rotation (``action="rotate"``).
    """
    _check_on_error(on_error)
    if root is None:
        root = default_physiclear_dir()
        if root is None:
            raise FileNotFoundError(f"PhysiCLeAR not found: set {PHYSICLEAR_ENV} to the directory holding "
                                    "labels.json, or pass its path")
    root = Path(root)
    labels_path = root / "labels.json" if root.is_dir() else root
    if not labels_path.is_file():
        raise FileNotFoundError(f"{labels_path}: no PhysiCLeAR labels.json here")
    try:
        data = json.loads(labels_path.read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"{labels_path}: not valid JSON ({exc.msg} at line {exc.lineno})") from None
    objects = data.get("objects") if isinstance(data, dict) else None
    if not isinstance(objects, dict):
        raise ValueError(f"{labels_path}: expected a top-level 'objects' mapping")
    report = LoadReport(source=str(labels_path.parent))
    for obj, entry in objects.items():
        fields = _physiclear_fields(entry, str(labels_path), obj)
        videos = entry.get("videos")
        if not isinstance(videos, list):
            raise ValueError(f"{labels_path}: object {obj!r}, field 'videos': expected a list of paths")
        for rel in videos:
            path = labels_path.parent / rel
            _attempt(report, path, on_error,
                     lambda path=path, obj=obj, fields=fields: _video_clip(path, min_frames, None, obj, fields))
    for clip in report.clips:
        if not clip.labels:
            report._add_unlabelled(clip)
    return _finish(report)


def _physiclear_fields(entry: Any, where: str, obj: str) -> dict[str, Any]:
    if not isinstance(entry, dict):
        raise ValueError(f"{where}: object {obj!r}: expected a mapping, got {type(entry).__name__}")
    split = _normalise_split(entry.get("split"), where, obj)
    labels: dict[str, Any] = {}
    if split != UNLABELLED:
        missing = [a for a in PHYSICLEAR_ATTRIBUTES if a not in entry]
        if missing:
            raise ValueError(f"{where}: object {obj!r} (split {split!r}): missing field(s) {', '.join(missing)}")
        labels["physiclear"] = {a: _check_rank(entry[a], where, obj, a) for a in PHYSICLEAR_ATTRIBUTES}
    return {
        "sensor": "mini",
        "object_name": entry.get("name") or obj.replace("_", " "),
        "material": entry.get("material") or "",
        "labels": labels,
        "action": "rotate",
        "source": "physiclear",
        "split": split,
    }
