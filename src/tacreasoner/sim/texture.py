"""Object surface micro-texture: band-limited roughness plus discrete bumps, as a height map in mm."""

from __future__ import annotations

import numpy as np
from scipy import fft as sfft

from tacreasoner.sim.materials import Material


def _gaussian_lowpass(shape: tuple[int, int], sigma_px: float) -> np.ndarray:
    fy = sfft.fftfreq(shape[0])[:, None]
    fx = sfft.rfftfreq(shape[1])[None, :]
    return np.exp(-2.0 * (np.pi * sigma_px) ** 2 * (fx**2 + fy**2))


def texture_map(material: Material, size_px: int, mm_per_px: float, rng: np.random.Generator) -> np.ndarray:
    """A square height map (float32, mm, zero-mean roughness + non-negative bumps) in object coordinates.

    The object's texture is fixed to the object: the renderer samples it through the object's
    current pose, so sliding and twisting move the imprint exactly as the object moves.
    """
    shape = (size_px, size_px)
    out = np.zeros(shape, np.float32)
    if material.roughness_mm > 0:
        white = rng.standard_normal(shape)
        sigma = max(material.roughness_wavelength_mm / mm_per_px / (2.0 * np.pi), 0.5)
        rough = sfft.irfft2(sfft.rfft2(white) * _gaussian_lowpass(shape, sigma), s=shape)
        rough *= material.roughness_mm / max(float(rough.std()), 1e-12)
        out += rough.astype(np.float32)
    if material.bump_height_mm > 0:
        spacing = material.bump_spacing_mm / mm_per_px
        n = int(np.ceil(size_px / spacing))
        grid = (np.arange(n) + 0.5) * spacing
        gy, gx = np.meshgrid(grid, grid, indexing="ij")
        jitter = rng.uniform(-0.3, 0.3, (2, n, n)) * spacing
        ys = np.clip((gy + jitter[0]).astype(int), 0, size_px - 1).ravel()
        xs = np.clip((gx + jitter[1]).astype(int), 0, size_px - 1).ravel()
        heights = material.bump_height_mm * rng.uniform(0.6, 1.0, ys.size)
        impulses = np.zeros(shape)
        np.add.at(impulses, (ys, xs), heights)
        sigma = material.bump_radius_mm / mm_per_px
        bumps = sfft.irfft2(sfft.rfft2(impulses) * _gaussian_lowpass(shape, sigma), s=shape)
        bumps *= 2.0 * np.pi * sigma**2  # unit-height Gaussian bumps
        out += bumps.astype(np.float32)
    return out
