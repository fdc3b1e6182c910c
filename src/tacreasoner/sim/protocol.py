"""The interaction protocol (paper Fig. 4): hover → approach → press → hold → rotate|slide → release → retract.

A protocol is the *commanded* robot motion for one clip. Mechanics turns it into what the gel feels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

PHASES = ("no_contact", "press", "hold", "rotate", "slide", "release")
ACTIONS = ("slide", "rotate")

# Nominal stage durations in seconds; each repeat jitters them by ±10 %.
_STAGES = (
    ("hover", 0.35),
    ("approach", 0.35),
    ("press", 1.0),
    ("hold", 1.0),
    ("action", 1.3),
    ("release", 0.6),
    ("retract", 0.4),
)
_STAGE_TO_PHASE = {"hover": "no_contact", "approach": "no_contact", "retract": "no_contact"}


@dataclass(frozen=True)
class Protocol:
    """Commanded motion, sampled once per frame."""

    fps: float
    action: str
    stage: np.ndarray
    """Stage name per frame (object array): hover, approach, press, hold, action, release, retract."""
    force_cmd: np.ndarray
    """Commanded normal force per frame, N (force-controlled pressing, as on a UR5 with an F/T sensor)."""
    slide_mm: np.ndarray
    """Commanded tangential base displacement per frame, mm (T×2)."""
    twist_rad: np.ndarray
    """Commanded base rotation about the normal per frame, rad."""
    offset_mm: tuple[float, float]
    """Where on the gel the object first touches (pose jitter), mm from the centre."""
    max_force_n: float
    light_force_n: float

    @property
    def n_frames(self) -> int:
        return len(self.stage)

    @property
    def times(self) -> np.ndarray:
        return np.arange(self.n_frames) / self.fps

    def nominal_phase(self) -> np.ndarray:
        """Phase label per frame as commanded; contact loss is applied later by the mechanics."""
        out = []
        for s in self.stage:
            out.append(self.action if s == "action" else _STAGE_TO_PHASE.get(s, s))
        return np.asarray(out, dtype=object)


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def make_protocol(fps: float, action: str, rng: np.random.Generator, duration_scale: float = 1.0) -> Protocol:
    """One repeat of the protocol with pose, force and timing jitter."""
    if action not in ACTIONS:
        raise ValueError(f"action must be one of {ACTIONS}, got {action!r}")
    durations = [(name, d * duration_scale * rng.uniform(0.9, 1.1)) for name, d in _STAGES]
    bounds = np.cumsum([0.0] + [d for _, d in durations])
    n = round(bounds[-1] * fps)
    t = np.arange(n) / fps
    idx = np.clip(np.searchsorted(bounds, t, side="right") - 1, 0, len(durations) - 1)
    stage = np.asarray([durations[i][0] for i in idx], dtype=object)
    local = (t - bounds[idx]) / np.asarray([durations[i][1] for i in idx])

    max_force = float(rng.uniform(3.0, 6.0))
    light_force = float(rng.uniform(0.08, 0.15))
    force = np.zeros(n)
    force[stage == "press"] = max_force * _smoothstep(local[stage == "press"])
    force[(stage == "hold") | (stage == "action")] = max_force
    rel = stage == "release"
    force[rel] = light_force + (max_force - light_force) * (1.0 - _smoothstep(local[rel] / 0.7))

    slide = np.zeros((n, 2))
    twist = np.zeros(n)
    progress = np.where(stage == "action", local, 0.0)
    after = np.isin(stage, ("release", "retract"))
    progress[after] = 1.0
    if action == "slide":
        angle = rng.uniform(0.0, 2.0 * np.pi)
        distance = rng.uniform(2.5, 4.0)
        s = distance * _smoothstep(progress)
        slide = np.stack([s * np.cos(angle), s * np.sin(angle)], axis=1)
    else:
        twist = np.deg2rad(rng.uniform(15.0, 25.0)) * rng.choice([-1.0, 1.0]) * _smoothstep(progress)

    offset = tuple(float(v) for v in rng.uniform(-1.5, 1.5, size=2))
    return Protocol(fps=float(fps), action=action, stage=stage, force_cmd=force, slide_mm=slide,
                    twist_rad=twist, offset_mm=offset, max_force_n=max_force, light_force_n=light_force)
