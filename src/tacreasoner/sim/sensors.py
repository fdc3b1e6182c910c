"""Sensor styles: resolution, frame rate, lights, background and markers of each simulated sensor."""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np


@dataclass(frozen=True)
class Light:
    azimuth_deg: float
    elevation_deg: float
    rgb: tuple[float, float, float]


@dataclass(frozen=True)
class SensorStyle:
    name: str
    height: int
    width: int
    fps: float
    mm_per_px: float
    background_rgb: tuple[float, float, float]
    centre_tint_rgb: tuple[float, float, float]
    """Added at the image centre (the bright LED hot spot of real sensors)."""
    gradient_rgb: tuple[float, float, float]
    """Added linearly from the top edge to the bottom edge (uneven illumination)."""
    vignette: float
    lights: tuple[Light, ...]
    shading_gain: float
    depth_darkening: float
    """Brightness change per mm of gel indentation (thinned gel over the contact looks darker/brighter)."""
    markers: tuple[int, int] | None
    marker_bright: bool
    noise_std: float
    spread_sigmas_mm: tuple[float, ...]
    spread_weights: tuple[float, ...]
    varied: float = 0.0
    """The share of clips that draw their own look (``vary_look``: lights, gel colour, gain, noise; the geometry
    stays); the rest keep the style's own look. 0: none, 1: every clip."""

    @property
    def shape(self) -> tuple[int, int]:
        return (self.height, self.width)


_MINI_LIGHTS = (
    Light(40.0, 35.0, (1.0, 0.25, 0.15)),
    Light(160.0, 35.0, (0.15, 0.9, 0.35)),
    Light(280.0, 35.0, (0.2, 0.35, 1.0)),
)
_DIGIT_LIGHTS = (
    Light(90.0, 30.0, (1.0, 0.1, 0.1)),
    Light(210.0, 30.0, (0.1, 1.0, 0.1)),
    Light(330.0, 30.0, (0.1, 0.1, 1.0)),
)
_TAC3D_LIGHTS = (
    Light(0.0, 45.0, (0.6, 0.6, 0.6)),
    Light(90.0, 45.0, (0.5, 0.5, 0.6)),
    Light(180.0, 45.0, (0.6, 0.6, 0.6)),
    Light(270.0, 45.0, (0.5, 0.5, 0.6)),
)

SENSORS: dict[str, SensorStyle] = {
    # Background fitted (Nelder–Mead) to the colour mean/contrast of real PhysiCLeAR Mini frames; see
    # benchmarks/sim_realism.py. Shading gain and noise chosen to match real contact contrast and noise.
    "mini": SensorStyle(
        name="mini", height=240, width=320, fps=25.0, mm_per_px=0.058,
        background_rgb=(36.4, 95.8, 137.4), centre_tint_rgb=(122.4, 48.7, 50.3), gradient_rgb=(-9.3, -2.0, -79.0),
        vignette=0.25, lights=_MINI_LIGHTS, shading_gain=260.0, depth_darkening=-8.0, markers=None,
        marker_bright=False, noise_std=0.6, spread_sigmas_mm=(0.06, 0.25, 0.9), spread_weights=(0.55, 0.3, 0.15),
    ),
    "digit": SensorStyle(
        name="digit", height=320, width=240, fps=30.0, mm_per_px=0.06,
        background_rgb=(150.0, 140.0, 145.0), centre_tint_rgb=(10.0, 5.0, 5.0), gradient_rgb=(45.0, -15.0, -20.0),
        vignette=0.25, lights=_DIGIT_LIGHTS, shading_gain=380.0, depth_darkening=-12.0, markers=None,
        marker_bright=False, noise_std=1.6, spread_sigmas_mm=(0.08, 0.3, 1.1), spread_weights=(0.5, 0.3, 0.2),
    ),
    "tac3d": SensorStyle(
        name="tac3d", height=240, width=320, fps=30.0, mm_per_px=0.0625,
        background_rgb=(28.0, 30.0, 38.0), centre_tint_rgb=(10.0, 10.0, 14.0), gradient_rgb=(0.0, 0.0, 6.0),
        vignette=0.3, lights=_TAC3D_LIGHTS, shading_gain=90.0, depth_darkening=10.0, markers=(20, 26),
        marker_bright=True, noise_std=1.0, spread_sigmas_mm=(0.1, 0.4, 1.2), spread_weights=(0.5, 0.3, 0.2),
    ),
}


# PhysiCLeAR's real Mini clips show about a third of the simulated Mini's contact signal (the largest mean
# |frame - first frame|: 3.0 against 9.0 grey levels) and of its frame-to-frame change (0.5 against 1.3);
# benchmarks/sim_realism.py measures both. ``mini+physiclear`` scales the contact shading and the indentation
# darkening by this factor (fitted with ``sim_realism.py --sensor mini+physiclear``) and leaves the background,
# lights and noise, which already match, alone.
PHYSICLEAR_CONTACT_GAIN = 0.33


def get_sensor(spec: str) -> SensorStyle:
    """Look up a sensor by name; ``name@fps`` overrides the frame rate, ``+markers`` adds the 7×9 marker grid and
    ``mini+physiclear`` calibrates the contact signal to PhysiCLeAR's real clips, ``+varied`` gives every clip its
    own look and ``+variedNN`` NN% of clips (the rest keep the style's look); options combine: a+b+c."""
    text = spec.strip().lower()
    name, _, fps_text = text.partition("@")
    base_name, *options = name.split("+")
    if base_name not in SENSORS:
        raise ValueError(f"unknown sensor {spec!r}; known: {', '.join(SENSORS)} "
                         "(optionally NAME@FPS, NAME+markers, mini+physiclear)")
    style = SENSORS[base_name]
    for option in options:
        if option == "markers" and style.markers is None:
            style = replace(style, name=f"{style.name}+markers", markers=(7, 9))
        elif (share := _varied_share(option)) is not None and not style.varied:
            style = replace(style, name=f"{style.name}+{option}", varied=share)
        elif option == "physiclear" and base_name == "mini" and "physiclear" not in style.name:
            style = replace(style, name=f"{style.name}+physiclear",
                            shading_gain=style.shading_gain * PHYSICLEAR_CONTACT_GAIN,
                            depth_darkening=style.depth_darkening * PHYSICLEAR_CONTACT_GAIN)
        else:
            raise ValueError(f"unknown sensor option {option!r} in {spec!r}; only 'mini+markers', "
                             "'digit+markers', 'mini+physiclear', NAME+varied and NAME+variedNN (NN from 1 to 99)")
    if fps_text:
        try:
            fps = float(fps_text)
        except ValueError:
            raise ValueError(f"sensor {spec!r}: frame rate after '@' must be a number") from None
        if not 1 <= fps <= 240:
            raise ValueError(f"sensor {spec!r}: frame rate must be between 1 and 240 fps")
        style = replace(style, name=f"{style.name}@{fps:g}", fps=fps)
    return style


def _varied_share(option: str) -> float | None:
    """``varied`` → 1.0, ``varied50`` → 0.5; None for any other option (or a percentage outside 1–99)."""
    match = re.fullmatch(r"varied(\d{1,2})?", option)
    if match is None:
        return None
    percent = int(match.group(1) or 100)
    return percent / 100 if 1 <= percent <= 100 else None


def clip_look(style: SensorStyle, seed: Sequence[int]) -> SensorStyle:
    """The look of the clip simulated from ``seed``: the style's own, or (for a share ``style.varied`` of clips)
    one drawn by ``vary_look`` from the clip's look stream ``[*seed, 1]``. Whether a clip is varied is drawn from
    its own stream ``[*seed, 2]``, so every-clip ``+varied`` clips look the same whatever the share option."""
    if style.varied <= 0:
        return style
    if style.varied < 1 and np.random.default_rng(np.random.SeedSequence([*seed, 2])).random() >= style.varied:
        return replace(style, varied=0.0)
    return vary_look(style, np.random.default_rng(np.random.SeedSequence([*seed, 1])))


def vary_look(style: SensorStyle, rng: np.random.Generator) -> SensorStyle:
    """One clip's look drawn around ``style`` (domain randomisation), so a model trained on it cannot lean on one
    unit's colours.

    Vision-based tactile sensors differ in their gel's paint (the no-contact colour), LED colours and where they
    sit, brightness falloff, how strongly a slope shows (gain) and noise; they share the physics. The ranges are broad
    and generic (every channel over most of its range, the LEDs turned anywhere and their colours in any order),
    not fitted to any one sensor. Resolution, scale and frame rate stay the style's: they change what is measured,
    not how it looks.
    """
    order = rng.permutation(3)
    turn = rng.uniform(0.0, 360.0)
    lights = tuple(Light((light.azimuth_deg + turn) % 360.0, float(rng.uniform(25.0, 50.0)),
                         tuple(float(light.rgb[c]) for c in order))  # type: ignore[arg-type]
                   for light in style.lights)
    return replace(
        style, varied=0.0,
        background_rgb=tuple(float(v) for v in rng.uniform(20.0, 170.0, 3)),  # type: ignore[arg-type]
        centre_tint_rgb=tuple(float(v) for v in rng.uniform(0.0, 100.0, 3)),  # type: ignore[arg-type]
        gradient_rgb=tuple(float(v) for v in rng.uniform(-80.0, 50.0, 3)),  # type: ignore[arg-type]
        vignette=float(rng.uniform(0.1, 0.4)), lights=lights,
        shading_gain=style.shading_gain * float(np.exp(rng.uniform(np.log(0.4), np.log(2.0)))),
        depth_darkening=float(rng.uniform(-15.0, 10.0)), noise_std=float(rng.uniform(0.3, 2.0)),
    )


def render_background(style: SensorStyle, rng: np.random.Generator) -> np.ndarray:
    """The no-contact image of one sensor unit (float32 H×W×3): tint, hot spot, gradient, vignette.

    Small per-unit jitter makes two clips from "different sensor units" distinguishable, as in real data.
    """
    h, w = style.shape
    y = np.linspace(-1.0, 1.0, h, dtype=np.float32)[:, None]
    x = np.linspace(-1.0, 1.0, w, dtype=np.float32)[None, :]
    cx, cy = rng.uniform(-0.15, 0.15, size=2)
    spot = np.exp(-(((x - cx) / 0.55) ** 2 + ((y - cy) / 0.5) ** 2)).astype(np.float32)
    ramp = (y + 1.0) / 2.0
    r2 = x**2 + y**2
    vignette = 1.0 - style.vignette * np.clip(r2 / 2.0, 0.0, 1.0) ** 1.5
    base = np.asarray(style.background_rgb, np.float32) + rng.normal(0.0, 3.0, 3).astype(np.float32)
    tint = np.asarray(style.centre_tint_rgb, np.float32)
    grad = np.asarray(style.gradient_rgb, np.float32)
    img = base[None, None, :] + spot[..., None] * tint + ramp[..., None] * grad
    img = img * vignette[..., None]
    # Fixed-pattern blotches of the elastomer coating (dust, uneven paint) – static over the clip.
    blotch = rng.normal(0.0, 1.0, (h // 8 + 1, w // 8 + 1)).astype(np.float32)
    blotch = np.kron(blotch, np.ones((8, 8), np.float32))[:h, :w]
    img += 1.5 * blotch[..., None]
    return img.astype(np.float32)
