"""Object and material catalogue for DynTAC-Sim, with labels derived from physical parameters.

Labels are *derived* from the parameters (never hand-assigned) so that every label is, by
construction, a consequence of something the simulator renders. Moduli are plane-strain moduli
in MPa (N/mm²), lengths in mm, times in s.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from tacreasoner.fields import reject_unknown_fields

GEL_MODULUS_MPA = 1.0
"""Effective plane-strain modulus of the sensor elastomer: objects far stiffer than this look rigid."""

SHAPES = ("sphere", "cylinder", "flat")
FRUITS = ("apple", "orange", "banana", "peach", "strawberry")
EVERYDAY = ("sponge", "rubber", "fabric", "wood", "metal")

# Thresholds mapping parameters to 3-level ranks (0 = low, 1 = moderate, 2 = high).
HARDNESS_E0_MPA = (0.6, 10.0)
ELASTICITY_SCORE = (0.12, 0.4)
FRICTION_MU_K = (0.3, 0.6)
BUMP_HEIGHT_MM = (0.04, 0.15)
ROUGHNESS_MM = (0.008, 0.025)


@dataclass(frozen=True)
class Material:
    """Everything the simulator needs to know about one object."""

    name: str
    display_name: str
    category: str
    material: str
    shape: str
    radius_mm: float
    e0_mpa: float
    e_inf_mpa: float
    creep_tau_s: float
    plasticity: float
    recovery_tau_s: float
    mu_s: float
    mu_k: float
    roughness_mm: float
    roughness_wavelength_mm: float
    bump_height_mm: float = 0.0
    bump_spacing_mm: float = 1.5
    bump_radius_mm: float = 0.3
    buckle_force_n: float | None = None
    is_fake: bool | None = None
    procedural: bool = False

    def __post_init__(self) -> None:
        if self.shape not in SHAPES:
            raise ValueError(f"{self.name}: shape must be one of {SHAPES}, got {self.shape!r}")
        if not (0 < self.e_inf_mpa <= self.e0_mpa):
            raise ValueError(f"{self.name}: need 0 < e_inf_mpa <= e0_mpa (standard linear solid)")
        if not (0 <= self.plasticity < 1):
            raise ValueError(f"{self.name}: plasticity must be in [0, 1)")
        if not (0 < self.mu_k <= self.mu_s):
            raise ValueError(f"{self.name}: need 0 < mu_k <= mu_s (Coulomb friction)")

    @property
    def fruit(self) -> str | None:
        return self.category if self.category in FRUITS else None

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> Material:
        reject_unknown_fields(cls, data, "unknown material fields:")
        return cls(**data)


def _rank(value: float, thresholds: tuple[float, float]) -> int:
    return int(value >= thresholds[0]) + int(value >= thresholds[1])


def object_compliance_share(m: Material) -> float:
    """Fraction of the total Hertz approach taken up by the object (0 = rigid, →1 = much softer than gel)."""
    return (1.0 / m.e0_mpa) / (1.0 / m.e0_mpa + 1.0 / GEL_MODULUS_MPA)


def elasticity_score(m: Material) -> float:
    """Deforms visibly *and* springs back: deformability × resilience (no plastic set, little creep loss)."""
    resilience = (1.0 - m.plasticity) * float(np.sqrt(m.e_inf_mpa / m.e0_mpa))
    return object_compliance_share(m) * resilience


def derive_labels(m: Material) -> dict:
    """3-level ranks in both vocabularies (VTV-150K and PhysiCLeAR) plus real/fake for fruit."""
    hardness = _rank(m.e0_mpa, HARDNESS_E0_MPA)
    bumps = _rank(m.bump_height_mm, BUMP_HEIGHT_MM)
    return {
        "vtv150k": {
            "hardness": hardness,
            "protrusion": bumps,
            "elasticity": _rank(elasticity_score(m), ELASTICITY_SCORE),
            "friction": _rank(m.mu_k, FRICTION_MU_K),
        },
        "physiclear": {
            "hardness": hardness,
            "roughness": _rank(m.roughness_mm, ROUGHNESS_MM),
            "bumpiness": bumps,
        },
        "real": None if m.is_fake is None else (not m.is_fake),
    }


def _fruit(name: str, fake: bool, **kw) -> Material:
    kind = "fake" if fake else "real"
    display = f"a {kind} {name}"
    return Material(name=f"{name}_{kind}", display_name=display, category=name, is_fake=fake, **kw)


# The five real/fake pairs share shape and surface look; they differ in bulk mechanics.
_CATALOGUE: tuple[Material, ...] = (
    _fruit("apple", False, material="fruit flesh", shape="sphere", radius_mm=38, e0_mpa=3.0, e_inf_mpa=1.5,
           creep_tau_s=1.6, plasticity=0.2, recovery_tau_s=3.0, mu_s=0.55, mu_k=0.45,
           roughness_mm=0.004, roughness_wavelength_mm=0.5),
    _fruit("apple", True, material="hollow plastic", shape="sphere", radius_mm=38, e0_mpa=40.0, e_inf_mpa=40.0,
           creep_tau_s=0.05, plasticity=0.0, recovery_tau_s=0.05, mu_s=0.36, mu_k=0.32,
           roughness_mm=0.003, roughness_wavelength_mm=0.5, buckle_force_n=3.5),
    _fruit("orange", False, material="fruit peel", shape="sphere", radius_mm=35, e0_mpa=1.2, e_inf_mpa=0.55,
           creep_tau_s=1.8, plasticity=0.15, recovery_tau_s=2.5, mu_s=0.75, mu_k=0.55,
           roughness_mm=0.012, roughness_wavelength_mm=0.4, bump_height_mm=0.09, bump_spacing_mm=1.2,
           bump_radius_mm=0.35),
    _fruit("orange", True, material="foam", shape="sphere", radius_mm=35, e0_mpa=0.9, e_inf_mpa=0.88,
           creep_tau_s=0.05, plasticity=0.0, recovery_tau_s=0.05, mu_s=0.6, mu_k=0.56,
           roughness_mm=0.01, roughness_wavelength_mm=0.4, bump_height_mm=0.08, bump_spacing_mm=1.3,
           bump_radius_mm=0.35),
    _fruit("banana", False, material="fruit flesh", shape="cylinder", radius_mm=17, e0_mpa=0.8, e_inf_mpa=0.35,
           creep_tau_s=2.0, plasticity=0.25, recovery_tau_s=4.0, mu_s=0.5, mu_k=0.4,
           roughness_mm=0.003, roughness_wavelength_mm=0.6),
    _fruit("banana", True, material="foam", shape="cylinder", radius_mm=17, e0_mpa=0.7, e_inf_mpa=0.68,
           creep_tau_s=0.05, plasticity=0.0, recovery_tau_s=0.05, mu_s=0.55, mu_k=0.5,
           roughness_mm=0.003, roughness_wavelength_mm=0.6),
    _fruit("peach", False, material="fuzzy fruit skin", shape="sphere", radius_mm=32, e0_mpa=0.5,
           e_inf_mpa=0.22, creep_tau_s=2.2, plasticity=0.3, recovery_tau_s=5.0, mu_s=0.95, mu_k=0.6,
           roughness_mm=0.03, roughness_wavelength_mm=0.15),
    _fruit("peach", True, material="flocked plastic", shape="sphere", radius_mm=32, e0_mpa=25.0, e_inf_mpa=25.0,
           creep_tau_s=0.05, plasticity=0.0, recovery_tau_s=0.05, mu_s=0.75, mu_k=0.62,
           roughness_mm=0.028, roughness_wavelength_mm=0.15, buckle_force_n=4.5),
    _fruit("strawberry", False, material="fruit flesh", shape="sphere", radius_mm=14, e0_mpa=0.4,
           e_inf_mpa=0.18, creep_tau_s=1.7, plasticity=0.35, recovery_tau_s=4.0, mu_s=0.65, mu_k=0.5,
           roughness_mm=0.006, roughness_wavelength_mm=0.5, bump_height_mm=0.2, bump_spacing_mm=2.0,
           bump_radius_mm=0.3),
    _fruit("strawberry", True, material="solid plastic", shape="sphere", radius_mm=14, e0_mpa=20.0,
           e_inf_mpa=20.0, creep_tau_s=0.05, plasticity=0.0, recovery_tau_s=0.05, mu_s=0.4, mu_k=0.36,
           roughness_mm=0.004, roughness_wavelength_mm=0.5, bump_height_mm=0.18, bump_spacing_mm=2.0,
           bump_radius_mm=0.3),
    Material(name="sponge", display_name="a kitchen sponge", category="sponge", material="foam", shape="flat",
             radius_mm=150, e0_mpa=0.06, e_inf_mpa=0.055, creep_tau_s=0.1, plasticity=0.0, recovery_tau_s=0.2,
             mu_s=0.95, mu_k=0.8, roughness_mm=0.05, roughness_wavelength_mm=0.6),
    Material(name="rubber", display_name="a rubber ball", category="rubber", material="rubber", shape="sphere",
             radius_mm=30, e0_mpa=2.0, e_inf_mpa=1.9, creep_tau_s=0.05, plasticity=0.0, recovery_tau_s=0.05,
             mu_s=1.2, mu_k=0.85, roughness_mm=0.003, roughness_wavelength_mm=0.4),
    Material(name="fabric", display_name="a folded towel", category="fabric", material="cotton", shape="flat",
             radius_mm=120, e0_mpa=0.15, e_inf_mpa=0.1, creep_tau_s=0.6, plasticity=0.1, recovery_tau_s=1.5,
             mu_s=0.75, mu_k=0.6, roughness_mm=0.06, roughness_wavelength_mm=0.4, bump_height_mm=0.05,
             bump_spacing_mm=1.0, bump_radius_mm=0.3),
    Material(name="wood", display_name="a wooden block", category="wood", material="wood", shape="flat",
             radius_mm=150, e0_mpa=1.0e4, e_inf_mpa=1.0e4, creep_tau_s=0.05, plasticity=0.0,
             recovery_tau_s=0.05, mu_s=0.45, mu_k=0.38, roughness_mm=0.015, roughness_wavelength_mm=0.8),
    Material(name="metal", display_name="a steel block", category="metal", material="steel", shape="flat",
             radius_mm=150, e0_mpa=2.0e5, e_inf_mpa=2.0e5, creep_tau_s=0.05, plasticity=0.0,
             recovery_tau_s=0.05, mu_s=0.22, mu_k=0.2, roughness_mm=0.001, roughness_wavelength_mm=0.3),
)


def catalogue() -> tuple[Material, ...]:
    """The 15 named objects: 5 real/fake fruit pairs and 5 everyday categories."""
    return _CATALOGUE


def get_material(name: str) -> Material:
    for m in _CATALOGUE:
        if m.name == name:
            return m
    raise KeyError(f"unknown object {name!r}; known: {', '.join(m.name for m in _CATALOGUE)}")


def _log_uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(np.exp(rng.uniform(np.log(lo), np.log(hi))))


def sample_procedural(rng: np.random.Generator, index: int) -> Material:
    """A new object: a catalogue template with every parameter re-drawn over a wide range.

    Ranges are wide enough that every label level occurs within each family, so a model cannot
    read a property off the family name.
    """
    base = _CATALOGUE[int(rng.integers(len(_CATALOGUE)))]
    stiff_scale = _log_uniform(rng, 0.3, 3.0)
    e0 = float(np.clip(base.e0_mpa * stiff_scale, 0.03, 3.0e5))
    real_fruit = base.is_fake is False
    e_inf = e0 * (rng.uniform(0.35, 0.65) if real_fruit else rng.uniform(0.85, 1.0))
    plasticity = rng.uniform(0.1, 0.4) if real_fruit else (rng.uniform(0.0, 0.15) if base.plasticity else 0.0)
    mu_k = float(np.clip(base.mu_k * _log_uniform(rng, 0.5, 2.0), 0.08, 1.4))
    stick_excess = rng.uniform(0.25, 0.6) if rng.random() < 0.5 else rng.uniform(0.0, 0.06)
    bump_h = base.bump_height_mm * _log_uniform(rng, 0.5, 2.0) if base.bump_height_mm else 0.0
    if rng.random() < 0.3:
        bump_h = _log_uniform(rng, 0.02, 0.35)
    buckle = base.buckle_force_n
    if buckle is not None:
        buckle = float(rng.uniform(2.5, 6.0))
    return dataclasses.replace(
        base,
        name=f"{base.name}_{index:04d}",
        display_name=f"{base.display_name} (variant {index})",
        radius_mm=float(base.radius_mm * rng.uniform(0.7, 1.4)),
        e0_mpa=e0,
        e_inf_mpa=float(e_inf),
        creep_tau_s=float(base.creep_tau_s * rng.uniform(0.6, 1.6)),
        plasticity=float(plasticity),
        recovery_tau_s=float(base.recovery_tau_s * rng.uniform(0.6, 1.6)),
        mu_k=mu_k,
        mu_s=float(mu_k * (1.0 + stick_excess)),
        roughness_mm=float(base.roughness_mm * _log_uniform(rng, 0.3, 3.5)),
        roughness_wavelength_mm=float(base.roughness_wavelength_mm * rng.uniform(0.7, 1.4)),
        bump_height_mm=float(bump_h),
        bump_spacing_mm=float(rng.uniform(0.9, 2.4)),
        bump_radius_mm=float(rng.uniform(0.2, 0.45)),
        buckle_force_n=buckle,
        procedural=True,
    )


def build_object_set(n_objects: int, seed: int) -> list[Material]:
    """The first ``n_objects`` of: the named catalogue, then procedural objects (deterministic in ``seed``)."""
    if n_objects < 0:
        raise ValueError(f"number of objects must be >= 0, got {n_objects}")
    objects = list(_CATALOGUE[:n_objects])
    for i in range(len(objects), n_objects):
        rng = np.random.default_rng(np.random.SeedSequence([seed, 0x0B1EC7, i]))
        objects.append(sample_procedural(rng, i))
    return objects
