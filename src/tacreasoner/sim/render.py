"""Optics: gel height field → shading by coloured lights → sensor image.

Pipeline per frame: object macro shape + texture → gel penetration → multi-scale Gaussian spreading
(the elastomer smooths what it is pressed by), pinned at the frame edges → surface normals →
Lambertian shading by 3–4 coloured lights → added to the sensor's background → markers, noise.

Two interchangeable backends compute the same thing:
- ``fft`` (default): whole chunks of frames at once; the multi-scale spreading is one multiplication
  in the frequency domain, texture lookup is a nearest-neighbour gather, float32 throughout.
- ``scipy``: the naive reference, frame by frame with ``gaussian_filter`` per scale and bilinear
  ``map_coordinates`` in float64. It exists to check the fast path and as the speed baseline.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import fft as sfft
from scipy import ndimage

from tacreasoner.sim.materials import GEL_MODULUS_MPA, Material
from tacreasoner.sim.mechanics import ContactTrajectory
from tacreasoner.sim.sensors import SensorStyle, render_background
from tacreasoner.sim.texture import texture_map

BACKENDS = ("fft", "scipy")
CHUNK = 16
NOISE_BANK = 7
MARKER_DILATION_MM = 3.0
PAD = 24
"""Pixels rendered beyond each image edge so the frequency-domain spreading does not wrap around."""
SHEAR_TILT_PER_MM = 0.08
TORSION_RIM_MM_PER_RAD = 1.5
"""Gel surface slope inside the contact per mm of stuck-patch shear displacement."""


@dataclass
class RenderScene:
    """Everything fixed over one clip: sensor, background, object texture, markers, noise."""

    style: SensorStyle
    background: np.ndarray
    texture: np.ndarray
    texture_gain: float
    markers_mm: np.ndarray | None
    noise: np.ndarray

    @classmethod
    def build(cls, style: SensorStyle, material: Material, max_shift_mm: float,
              rng: np.random.Generator) -> RenderScene:
        h, w = style.shape
        margin = int(np.ceil(max_shift_mm / style.mm_per_px)) + 8 + PAD
        size = int(np.ceil((np.hypot(h + 2 * PAD, w + 2 * PAD) + 2 * margin) / 32.0) * 32)
        background = render_background(style, rng)
        texture = texture_map(material, size, style.mm_per_px, rng)
        # A stiff object prints its texture fully into the gel; a soft one flattens under the load.
        gain = float(np.sqrt(material.e0_mpa / (material.e0_mpa + GEL_MODULUS_MPA)))
        markers = None
        if style.markers is not None:
            rows, cols = style.markers
            ys = (np.arange(rows) + 0.5) / rows * h
            xs = (np.arange(cols) + 0.5) / cols * w
            gy, gx = np.meshgrid(ys, xs, indexing="ij")
            markers = np.stack([(gx.ravel() - w / 2) * style.mm_per_px, (gy.ravel() - h / 2) * style.mm_per_px], 1)
        noise = rng.normal(0.0, style.noise_std, (NOISE_BANK, h, w, 3)).astype(np.float32)
        return cls(style, background, texture, gain, markers, noise)


def _padded_shape(style: SensorStyle) -> tuple[int, int]:
    return style.height + 2 * PAD, style.width + 2 * PAD


def _spread_kernel(style: SensorStyle) -> np.ndarray:
    h, w = _padded_shape(style)
    fy = sfft.fftfreq(h)[:, None]
    fx = sfft.rfftfreq(w)[None, :]
    f2 = fx**2 + fy**2
    k = np.zeros_like(f2)
    for sigma_mm, weight in zip(style.spread_sigmas_mm, style.spread_weights, strict=True):
        sigma = sigma_mm / style.mm_per_px
        k += weight * np.exp(-2.0 * (np.pi * sigma) ** 2 * f2)
    return k.astype(np.float32)


def _crop(height: np.ndarray) -> np.ndarray:
    """Drop the padding: the camera sees only the middle of the gel, whose glued rim lies outside the view."""
    return height[:, PAD:-PAD, PAD:-PAD]


def _macro_height(traj: ContactTrajectory, idx: np.ndarray, style: SensorStyle, dtype) -> np.ndarray:
    """Gel penetration by the object's shape (no texture), mm, for frames ``idx`` on the padded grid."""
    h, w = _padded_shape(style)
    ys = ((np.arange(h) - h / 2 + 0.5) * style.mm_per_px).astype(dtype)[None, :, None]
    xs = ((np.arange(w) - w / 2 + 0.5) * style.mm_per_px).astype(dtype)[None, None, :]
    cx = traj.centre_mm[idx, 0].astype(dtype)[:, None, None]
    cy = traj.centre_mm[idx, 1].astype(dtype)[:, None, None]
    a = np.maximum(traj.contact_radius[idx], 1e-3).astype(dtype)[:, None, None]
    dx, dy = xs - cx, ys - cy
    if traj.elongation != 1.0:
        ca, sa = np.cos(traj.axis_angle), np.sin(traj.axis_angle)
        across, along = dx * ca + dy * sa, (dy * ca - dx * sa) / traj.elongation
        r2 = across * across + along * along
    else:
        r2 = dx * dx + dy * dy
    # Frame-sized arrays are updated in place below: the same operations in the same order as the plain
    # expressions (so the same numbers), without a fresh temporary for every step.
    profile = np.divide(r2, a * a)
    np.subtract(1.0, profile, out=profile)
    np.maximum(profile, 0.0, out=profile)
    conform = traj.conform[idx]
    if np.any(conform > 0):
        # Resting in a residual dent: a flatter, wider imprint (flat-punch-like).
        q = (1.0 - 0.65 * conform).astype(dtype)[:, None, None]
        np.power(profile, q, out=profile)
    depth = traj.indent_gel[idx].astype(dtype)[:, None, None]
    height = depth * profile
    shear = traj.gel_shift_mm[idx]
    if np.any(shear != 0):
        # Tangential traction tilts the gel surface inside the contact along the shear: a colour shift
        # over the whole imprint proportional to the friction force (visible without markers).
        ux = shear[:, 0].astype(dtype)[:, None, None]
        uy = shear[:, 1].astype(dtype)[:, None, None]
        tilt = ux * dx + uy * dy
        np.multiply(SHEAR_TILT_PER_MM, tilt, out=tilt)
        height += tilt * np.sqrt(profile, out=profile)  # not tilt *= …: profile is float64 for elongated shapes
    twist = np.abs(traj.gel_twist[idx])
    if np.any(twist > 0):
        # Torsion wrinkles the gel at the contact rim: a raised ring growing with the stuck-patch twist.
        rim = np.sqrt(r2, out=r2)  # r2 is not needed after this
        rim -= a
        rim /= 0.25 * a
        np.square(rim, out=rim)
        np.negative(rim, out=rim)
        np.exp(rim, out=rim)
        rim *= TORSION_RIM_MM_PER_RAD * twist.astype(dtype)[:, None, None]
        height += rim
    return height.astype(dtype, copy=False)


def _texture_coords(traj: ContactTrajectory, i: int, scene: RenderScene) -> tuple[np.ndarray, np.ndarray]:
    """Texture-map coordinates (float px) of every (padded-grid) sensor pixel for frame ``i``."""
    style = scene.style
    h, w = _padded_shape(style)
    size = scene.texture.shape[0]
    ys = (np.arange(h) - h / 2 + 0.5)[:, None]
    xs = (np.arange(w) - w / 2 + 0.5)[None, :]
    sx, sy = traj.object_shift_mm[i] / style.mm_per_px
    rot = traj.object_rotation[i]
    c, s = np.cos(rot), np.sin(rot)
    dx, dy = xs - sx, ys - sy
    # Sensor → object frame: undo the object's rotation.
    u = c * dx + s * dy + size / 2
    v = -s * dx + c * dy + size / 2
    return v, u


def _contact_mask(macro: np.ndarray, traj: ContactTrajectory, idx: np.ndarray) -> np.ndarray:
    depth = np.maximum(traj.indent_gel[idx], 1e-6).astype(macro.dtype)[:, None, None]
    fill = np.minimum(traj.indent_gel[idx] / 0.05, 1.0).astype(macro.dtype)[:, None, None]
    mask = macro / depth
    mask *= 3.0
    np.minimum(mask, 1.0, out=mask)
    mask *= fill
    return mask


def _height_fft(traj: ContactTrajectory, idx: np.ndarray, scene: RenderScene, kernel: np.ndarray) -> np.ndarray:
    macro = _macro_height(traj, idx, scene.style, np.float32)
    mask = _contact_mask(macro, traj, idx)
    tex = np.zeros_like(macro)
    for j, i in enumerate(idx):
        if traj.indent_gel[i] <= 0:
            continue
        v, u = _texture_coords(traj, int(i), scene)
        size = scene.texture.shape[0]
        vi = np.clip(np.rint(v).astype(np.intp), 0, size - 1)
        ui = np.clip(np.rint(u).astype(np.intp), 0, size - 1)
        tex[j] = scene.texture[vi, ui]
    # raw = macro + gain·tex·mask, computed in place (addition commutes exactly, so the same numbers)
    raw = np.multiply(scene.texture_gain, tex, out=tex)
    raw *= mask
    raw += macro
    spectrum = sfft.rfft2(raw, axes=(1, 2))
    spectrum *= kernel
    spread = sfft.irfft2(spectrum, s=raw.shape[1:], axes=(1, 2))
    return _crop(spread).astype(np.float32)


def _height_scipy(traj: ContactTrajectory, i: int, scene: RenderScene) -> np.ndarray:
    idx = np.asarray([i])
    macro = _macro_height(traj, idx, scene.style, np.float64)
    mask = _contact_mask(macro, traj, idx)[0]
    raw = macro[0]
    if traj.indent_gel[i] > 0:
        v, u = _texture_coords(traj, i, scene)
        tex = ndimage.map_coordinates(scene.texture.astype(np.float64), [v, u], order=1, mode="nearest")
        raw = raw + scene.texture_gain * tex * mask
    style = scene.style
    out = np.zeros_like(raw)
    for sigma_mm, weight in zip(style.spread_sigmas_mm, style.spread_weights, strict=True):
        out += weight * ndimage.gaussian_filter(raw, sigma_mm / style.mm_per_px, mode="wrap")
    return _crop(out[None])[0]


def _light_coefficients(style: SensorStyle) -> np.ndarray:
    """Per output channel c: (Σ_l C_lc·Lx_l, Σ_l C_lc·Ly_l, Σ_l C_lc·Lz_l), so shading is 3 passes, not 3×L."""
    az = np.deg2rad([lt.azimuth_deg for lt in style.lights])
    el = np.deg2rad([lt.elevation_deg for lt in style.lights])
    directions = np.stack([np.cos(az) * np.cos(el), np.sin(az) * np.cos(el), np.sin(el)], 1)
    colours = np.asarray([lt.rgb for lt in style.lights])
    return (colours.T @ directions).astype(np.float32)


def _shade(height: np.ndarray, scene: RenderScene, frame_ids: np.ndarray, traj: ContactTrajectory) -> np.ndarray:
    """Height (F×H×W, mm) → RGB uint8 frames (F×H×W×3).

    Lambertian response of each coloured light minus the flat-gel response, so an untouched gel
    shows just the background.
    """
    style = scene.style
    height = height.astype(np.float32, copy=False)
    gy, gx = np.gradient(height, style.mm_per_px, axis=(1, 2))
    inv = 1.0 / np.sqrt(1.0 + gx * gx + gy * gy)
    coef = _light_coefficients(style) * style.shading_gain
    img = np.empty((*height.shape, 3), np.float32)
    depth_term = style.depth_darkening * height
    # (z − a·gx − b·gy)·inv + (depth − z) + background, evaluated in that order into two reused buffers:
    # the same float32 operations as the plain expression, without five fresh frame-sized temporaries.
    channel, term = np.empty_like(height), np.empty_like(height)
    for c in range(3):
        a, b, z = coef[c]
        np.subtract(z, np.multiply(a, gx, out=channel), out=channel)
        channel -= np.multiply(b, gy, out=term)
        channel *= inv
        channel += np.subtract(depth_term, z, out=term)
        channel += scene.background[None, :, :, c]
        img[..., c] = channel
    if scene.markers_mm is not None:
        img = _draw_markers(img, gx, gy, traj, frame_ids, scene)
    _add_frame_noise(img, scene, frame_ids)
    img += 0.5
    np.clip(img, 0, 255, out=img)
    return img.astype(np.uint8)


def _add_frame_noise(img: np.ndarray, scene: RenderScene, frame_ids: np.ndarray) -> None:
    """Fresh-looking noise per frame from a small bank: a bank frame rolled by a frame-dependent offset.

    Added in place as the roll's two slices, so no rolled copy of the bank frame is ever made.
    """
    flat = scene.noise.reshape(len(scene.noise), -1)
    size = flat.shape[1]
    for j, i in enumerate(frame_ids):
        shift = (int(i) * 7919 + 104729) % size
        source = flat[int(i) % len(flat)]
        target = img[j].reshape(-1)
        target[shift:] += source[:size - shift]
        target[:shift] += source[size - shift:]


def _marker_positions(traj: ContactTrajectory, i: int, gx: np.ndarray, gy: np.ndarray,
                      scene: RenderScene) -> np.ndarray:
    """Marker centres (mm) in frame ``i``: dilation by the indentation, shear and twist of the stuck patch."""
    style = scene.style
    p = scene.markers_mm
    h, w = style.shape
    cols = np.clip(np.rint(p[:, 0] / style.mm_per_px + w / 2 - 0.5).astype(int), 0, w - 1)
    rows = np.clip(np.rint(p[:, 1] / style.mm_per_px + h / 2 - 0.5).astype(int), 0, h - 1)
    disp = -MARKER_DILATION_MM * np.stack([gx[rows, cols], gy[rows, cols]], 1)
    if traj.indent_gel[i] > 0:
        rel = p - traj.object_shift_mm[i]
        r = np.linalg.norm(rel, axis=1)
        weight = np.exp(-((r / (traj.contact_radius[i] + 1.0)) ** 2))[:, None]
        phi = traj.gel_twist[i]
        twist = np.stack([np.cos(phi) * rel[:, 0] - np.sin(phi) * rel[:, 1],
                          np.sin(phi) * rel[:, 0] + np.cos(phi) * rel[:, 1]], 1) - rel
        disp = disp + weight * (traj.gel_shift_mm[i][None, :] + twist)
    return p + disp


def _draw_markers(img: np.ndarray, gx: np.ndarray, gy: np.ndarray, traj: ContactTrajectory,
                  frame_ids: np.ndarray, scene: RenderScene) -> np.ndarray:
    style = scene.style
    h, w = style.shape
    radius_px = 0.22 / style.mm_per_px
    k = int(np.ceil(radius_px * 2))
    oy, ox = np.mgrid[-k:k + 1, -k:k + 1]
    for j, i in enumerate(frame_ids):
        pos = _marker_positions(traj, int(i), gx[j], gy[j], scene)
        px = pos[:, 0] / style.mm_per_px + w / 2 - 0.5
        py = pos[:, 1] / style.mm_per_px + h / 2 - 0.5
        cx, cy = np.rint(px).astype(int), np.rint(py).astype(int)
        xx = cx[:, None, None] + ox[None]
        yy = cy[:, None, None] + oy[None]
        d2 = (xx - px[:, None, None]) ** 2 + (yy - py[:, None, None]) ** 2
        weight = np.exp(-d2 / (2 * (radius_px / 1.5) ** 2))
        ok = (xx >= 0) & (xx < w) & (yy >= 0) & (yy < h)
        mask = np.bincount((yy[ok] * w + xx[ok]), weights=weight[ok], minlength=h * w).reshape(h, w)
        mask = np.minimum(mask, 1.0).astype(np.float32)[..., None]
        if style.marker_bright:
            img[j] = img[j] + (210.0 - img[j]) * mask
        else:
            img[j] = img[j] * (1.0 - 0.8 * mask)
    return img


def render_frames(traj: ContactTrajectory, scene: RenderScene, backend: str = "fft"):
    """Yield uint8 RGB frames in chunks (F×H×W×3) so a whole clip never has to sit in float memory."""
    if backend not in BACKENDS:
        raise ValueError(f"unknown render backend {backend!r}; choose from {BACKENDS}")
    style = scene.style
    n = len(traj)
    if backend == "fft":
        kernel = _spread_kernel(style)
        for start in range(0, n, CHUNK):
            idx = np.arange(start, min(start + CHUNK, n))
            yield _shade(_height_fft(traj, idx, scene, kernel), scene, idx, traj)
    else:
        for i in range(n):
            height = _height_scipy(traj, i, scene)
            yield _shade(height[None], scene, np.asarray([i]), traj)
