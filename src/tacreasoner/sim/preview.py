"""Preview images of a simulated clip: a contact sheet of key frames and a plot of its ground truth.

A preview is how a person checks that a clip shows what its labels claim (an imprint while pressing,
a shifting imprint while sliding, a residual dent after release) without opening a video player.
It works both on a clip simulated in memory and on one read back from a dataset directory, so the
two only have to share the few fields listed in :class:`PreviewClip`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

import numpy as np

from tacreasoner.sim.generate import Clip, clip_seed, read_manifest, simulate_clip
from tacreasoner.sim.materials import Material, catalogue, derive_labels, get_material
from tacreasoner.sim.protocol import ACTIONS
from tacreasoner.sim.sensors import SensorStyle, get_sensor
from tacreasoner.video_io import read_video

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["DatasetClip", "GroundTruth", "PreviewClip", "PreviewTrajectory", "preview_from_dataset",
           "real_and_fake_clip_ids", "simulate_catalogue_clip", "write_preview"]

PHASE_COLOURS = {
    "no_contact": "#b0b0b0",
    "press": "#4c78a8",
    "hold": "#54a24b",
    "rotate": "#f58518",
    "slide": "#b279a2",
    "release": "#e45756",
}
LEVELS = ("low", "moderate", "high")
DIFF_TARGET = 100.0
"""Grey levels the 99.5th percentile of a difference image is stretched to (so faint cues are visible)."""
MAX_GAIN = 60.0
SLIP_NAMES = ("stick", "partial", "gross slip")


class PreviewTrajectory(Protocol):
    """Per-frame ground truth a preview plots (``ContactTrajectory`` and :class:`GroundTruth` have it)."""

    @property
    def phase(self) -> np.ndarray: ...
    @property
    def normal_force(self) -> np.ndarray: ...
    @property
    def shear(self) -> np.ndarray: ...
    @property
    def torque(self) -> np.ndarray: ...
    @property
    def contact_area(self) -> np.ndarray: ...
    @property
    def indent_gel(self) -> np.ndarray: ...
    @property
    def indent_object(self) -> np.ndarray: ...
    @property
    def stick_ratio(self) -> np.ndarray: ...
    @property
    def slip(self) -> np.ndarray: ...


class PreviewClip(Protocol):
    """What a preview needs from a clip (satisfied by ``generate.Clip`` and :class:`DatasetClip`)."""

    @property
    def frames(self) -> np.ndarray: ...
    @property
    def trajectory(self) -> PreviewTrajectory: ...
    @property
    def material(self) -> Material: ...
    @property
    def sensor(self) -> SensorStyle: ...
    @property
    def action(self) -> str: ...


@dataclass(frozen=True)
class GroundTruth:
    """The per-frame ground truth stored in a manifest line (a subset of ``ContactTrajectory``)."""

    phase: np.ndarray
    normal_force: np.ndarray
    shear: np.ndarray
    torque: np.ndarray
    contact_radius: np.ndarray
    contact_area: np.ndarray
    indent_gel: np.ndarray
    indent_object: np.ndarray
    stick_ratio: np.ndarray
    slip: np.ndarray

    @classmethod
    def from_manifest(cls, frames: dict[str, list]) -> GroundTruth:
        floats = {name: np.asarray(frames[name], dtype=float)
                  for name in ("normal_force", "torque", "contact_radius", "contact_area", "indent_gel",
                               "indent_object", "stick_ratio")}
        return cls(phase=np.asarray(frames["phase"], dtype=object),
                   shear=np.stack([frames["shear_x"], frames["shear_y"]], axis=1).astype(float),
                   slip=np.asarray(frames["slip"], dtype=np.int64), **floats)

    def __len__(self) -> int:
        return len(self.phase)


@dataclass(frozen=True)
class DatasetClip:
    """A clip read back from a dataset directory: decoded frames plus the manifest's ground truth."""

    clip_id: str
    frames: np.ndarray
    trajectory: GroundTruth
    material: Material
    sensor: SensorStyle
    action: str
    seed: list[int]


# ------------------------------------------------------------------------------------------ loading


def preview_from_dataset(dataset_dir: str | Path, clip_id: str) -> DatasetClip:
    """Rebuild a previewable clip from ``manifest.jsonl`` and the clip's mp4."""
    dataset = Path(dataset_dir)
    records = read_manifest(dataset)
    record = next((r for r in records if r.get("clip_id") == clip_id), None)
    if record is None:
        known = ", ".join(r.get("clip_id", "?") for r in records[:5])
        more = f" (and {len(records) - 5} more)" if len(records) > 5 else ""
        raise KeyError(f"clip {clip_id!r} is not in {dataset}; known: {known}{more}")
    frames, _ = read_video(dataset / record["video"])
    truth = GroundTruth.from_manifest(record["frames"])
    if len(frames) != len(truth):
        raise ValueError(f"{record['video']}: video has {len(frames)} frames, the manifest {len(truth)}")
    return DatasetClip(clip_id=clip_id, frames=frames, trajectory=truth,
                       material=Material.from_dict(record["material"]), sensor=get_sensor(record["sensor"]),
                       action=record["action"], seed=list(record.get("seed", [])))


def simulate_catalogue_clip(object_name: str, sensor: str = "mini", action: str = "slide",
                            seed: int = 0) -> Clip:
    """Simulate a named catalogue object with the seed the dataset generator would give it.

    Object index = catalogue position, repeat 0 for slide / 1 for rotate, first sensor: so the
    preview shows the same clip as ``<sensor>/<object>_<repeat>`` in a dataset made with the same
    ``--seed`` (when that sensor is listed first).
    """
    material = get_material(object_name)
    if action not in ACTIONS:
        raise ValueError(f"unknown --action {action!r}; choose from {', '.join(ACTIONS)}")
    index = [m.name for m in catalogue()].index(material.name)
    return simulate_clip(material, sensor, action, clip_seed(seed, index, ACTIONS.index(action), 0))


def real_and_fake_clip_ids(records: list[dict]) -> list[str]:
    """The first real-fruit clip and the first fake-fruit clip of a manifest (those that exist)."""
    picked: dict[bool, str] = {}
    for record in records:
        real = record.get("labels", {}).get("real")
        if real is not None and real not in picked:
            picked[real] = record["clip_id"]
    return [picked[k] for k in (True, False) if k in picked]


# ------------------------------------------------------------------------------------------ writing


def write_preview(clip: PreviewClip, out_png: str | Path) -> list[Path]:
    """Write the contact sheet to ``out_png`` and the signal plot to ``<stem>_signals.png``."""
    import matplotlib

    matplotlib.use("Agg")  # here, not at import: importing the package must not change a user's backend
    out = Path(out_png)
    if out.suffix.lower() != ".png":
        raise ValueError(f"--out must be a .png file, got {out}")
    if len(clip.frames) != len(clip.trajectory.phase):
        raise ValueError(f"clip has {len(clip.frames)} frames, {len(clip.trajectory.phase)} rows of truth")
    _ensure_dir(out.parent)
    signals = out.with_name(f"{out.stem}_signals.png")
    _save(_contact_sheet(clip), out)
    _save(_signal_plot(clip), signals)
    return [out, signals]


def _ensure_dir(path: Path) -> None:
    """Create the output folder, naming the folder (not a bare errno) when that is impossible."""
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        reason = "a file is in the way" if isinstance(exc, FileExistsError) else exc.strerror or str(exc)
        raise ValueError(f"cannot write to output directory {path}: {reason}") from None


def _save(fig: Figure, path: Path) -> None:
    import matplotlib.pyplot as plt

    try:
        fig.savefig(path, dpi=110)
    finally:
        plt.close(fig)


def phase_runs(phase: np.ndarray) -> list[tuple[str, int, int]]:
    """Contiguous runs of one phase as (phase, first frame, last frame + 1)."""
    runs: list[tuple[str, int, int]] = []
    start = 0
    for i in range(1, len(phase) + 1):
        if i == len(phase) or phase[i] != phase[start]:
            runs.append((str(phase[start]), start, i))
            start = i
    return runs


def key_frames(trajectory: PreviewTrajectory) -> list[tuple[str, int]]:
    """(label, frame) pairs in time order: the middle of each phase's first run, plus peak contact."""
    picks: dict[int, str] = {}
    seen: set[str] = set()
    for name, start, stop in phase_runs(trajectory.phase):
        if name not in seen:
            seen.add(name)
            picks[(start + stop - 1) // 2] = name.replace("_", " ")
    area = np.asarray(trajectory.contact_area, dtype=float)
    if area.size and area.max() > 0:
        peak = int(np.argmax(area))
        picks[peak] = f"{picks[peak]} · max contact" if peak in picks else "max contact"
    return sorted(((label, i) for i, label in picks.items()), key=lambda p: p[1])


def _amplify(diffs: list[np.ndarray]) -> tuple[list[np.ndarray], float]:
    """Stretch signed differences around mid-grey with one gain shared by the row (so columns compare)."""
    magnitude = float(np.percentile(np.abs(np.stack(diffs)), 99.5)) if diffs else 0.0
    gain = float(np.clip(DIFF_TARGET / max(magnitude, 1e-6), 1.0, MAX_GAIN))
    return [np.clip(128.0 + gain * d, 0, 255).astype(np.uint8) for d in diffs], gain


def _label_lines(material: Material) -> list[str]:
    labels = derive_labels(material)
    vtv = ", ".join(f"{k} {v} ({LEVELS[v]})" for k, v in labels["vtv150k"].items())
    pcl = ", ".join(f"{k} {v} ({LEVELS[v]})" for k, v in labels["physiclear"].items() if k != "hardness")
    real = {True: " · real object", False: " · fake object", None: ""}[labels["real"]]
    return [f"labels: VTV-150K {vtv}", f"PhysiCLeAR {pcl}{real}"]


def _title(clip: PreviewClip, wide: bool) -> str:
    """Figure title; the narrow signal plot puts each label vocabulary on its own line."""
    m = clip.material
    sensor = f"sensor {clip.sensor.name} @ {clip.sensor.fps:g} fps"
    head = f"{m.display_name} ({m.name}) · {sensor} · action {clip.action}"
    labels = _label_lines(m)
    return "\n".join([head, " · ".join(labels)] if wide else [head, *labels])


def _contact_sheet(clip: PreviewClip) -> Figure:
    import matplotlib.pyplot as plt

    frames = clip.frames.astype(np.float32)
    picks = key_frames(clip.trajectory)
    idx = [i for _, i in picks]
    vs_first, g1 = _amplify([frames[i] - frames[0] for i in idx])
    step, g2 = _amplify([frames[i] - frames[max(i - 1, 0)] for i in idx])
    rows = [("frame", [clip.frames[i] for i in idx]),
            (f"Δ vs frame 0 (×{g1:.1f})", vs_first),
            (f"Δ vs previous (×{g2:.1f})", step)]
    h, w = clip.frames.shape[1:3]
    col_w = 2.6
    fig, axes = plt.subplots(3, len(picks), figsize=(col_w * len(picks) + 0.6, 3 * col_w * h / w + 1.5),
                             squeeze=False, layout="constrained")
    for r, (row_name, images) in enumerate(rows):
        for c, image in enumerate(images):
            ax = axes[r][c]
            ax.imshow(image)
            ax.set_xticks([])
            ax.set_yticks([])
            if r == 0:
                label, i = picks[c]
                ax.set_title(f"{label}\nframe {i} · t = {i / clip.sensor.fps:.2f} s", fontsize=9)
            if c == 0:
                ax.set_ylabel(row_name, fontsize=9)
    fig.suptitle(_title(clip, wide=len(picks) >= 5), fontsize=9.5)
    return fig


def _shade_phases(ax: Axes, phase: np.ndarray, fps: float) -> None:
    for name, start, stop in phase_runs(phase):
        ax.axvspan(start / fps, stop / fps, color=PHASE_COLOURS.get(name, "#dddddd"), alpha=0.18, lw=0)


def _legend(ax: Axes, twin: Axes) -> None:
    """One legend for an axis and its twin (matplotlib keeps them separate otherwise)."""
    handles, labels = ax.get_legend_handles_labels()
    h2, l2 = twin.get_legend_handles_labels()
    ax.legend(handles + h2, labels + l2, loc="upper right", fontsize=8, framealpha=0.85)


def _signal_plot(clip: PreviewClip) -> Figure:
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    traj = clip.trajectory
    fps = clip.sensor.fps
    t = np.arange(len(traj.phase)) / fps
    fig, axes = plt.subplots(3, 1, figsize=(10, 7.5), sharex=True, layout="constrained")
    for ax in axes:
        _shade_phases(ax, traj.phase, fps)
        ax.grid(alpha=0.3)
    _plot_forces(axes[0], t, traj)
    _plot_contact(axes[1], t, traj)
    _plot_slip(axes[2], t, traj)
    axes[2].set_xlabel("time (s)")
    present = [name for name, _, _ in phase_runs(traj.phase)]
    order = [p for p in PHASE_COLOURS if p in present]
    patches = [Patch(color=PHASE_COLOURS[p], alpha=0.4, label=p.replace("_", " ")) for p in order]
    fig.suptitle(_title(clip, wide=False), fontsize=9.5)
    fig.legend(handles=patches, loc="outside lower center", ncols=len(patches) + 1, fontsize=8,
               title="phase (background)", title_fontsize=8)
    return fig


def _plot_forces(ax: Axes, t: np.ndarray, traj: PreviewTrajectory) -> None:
    ax.plot(t, traj.normal_force, color="#1f3b73", label="normal force (N)")
    ax.plot(t, np.linalg.norm(np.asarray(traj.shear), axis=1), color="#c0392b", label="|shear| (N)")
    ax.set_ylabel("force (N)")
    twin = ax.twinx()
    twin.plot(t, traj.torque, color="#7d3c98", ls="--", label="torque (N·mm)")
    twin.set_ylabel("torque (N·mm)")
    _symmetric_zero(twin, np.asarray(traj.torque))
    _legend(ax, twin)


def _plot_contact(ax: Axes, t: np.ndarray, traj: PreviewTrajectory) -> None:
    # Area and gel indentation both scale with the Hertz approach, so their curves often coincide:
    # draw area as a wide pale band under the indentation lines to keep both visible.
    ax.plot(t, traj.contact_area, color="#117a65", lw=4, alpha=0.45, label="contact area (mm²)")
    ax.set_ylabel("contact area (mm²)")
    twin = ax.twinx()
    twin.plot(t, traj.indent_gel, color="#d68910", label="indentation, gel (mm)")
    twin.plot(t, traj.indent_object, color="#6e2c00", ls="--", label="indentation, object (mm)")
    twin.set_ylabel("indentation (mm)")
    _legend(ax, twin)


def _plot_slip(ax: Axes, t: np.ndarray, traj: PreviewTrajectory) -> None:
    ax.step(t, traj.slip, where="mid", color="#34495e", label="slip state")
    ax.set_yticks(range(len(SLIP_NAMES)), SLIP_NAMES)
    ax.set_ylim(-0.2, len(SLIP_NAMES) - 0.8)
    ax.set_ylabel("slip state")
    twin = ax.twinx()
    twin.plot(t, traj.stick_ratio, color="#16a085", label="stick ratio")
    twin.set_ylim(-0.05, 1.05)
    twin.set_ylabel("stick ratio")
    _legend(ax, twin)


def _symmetric_zero(ax: Axes, values: np.ndarray) -> None:
    """Torque changes sign with the rotation direction; keep zero visible and centred."""
    peak = float(np.abs(values).max()) if np.size(values) else 0.0
    if peak > 0:
        ax.set_ylim(-1.1 * peak, 1.1 * peak)
