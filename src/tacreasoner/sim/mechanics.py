"""Contact mechanics: from commanded motion and material to what the gel feels, frame by frame.

Models (each deliberately simple, each producing a cue that is visible in the rendered video):
- Hertz-like normal contact, F = 4/3 E* √R δ^1.5, with gel and object compliances in series, so a
  soft object takes most of the approach (flat, wide imprint) and a hard one leaves it to the gel
  (deep, sharp imprint).
- Standard-linear-solid creep of the object under the constant hold force (contact area grows),
  delayed recovery plus a plastic set after unloading: a shallow, wide *residual imprint* when the
  sensor is released to a light touch (real fruit), absent for elastic foams and hard plastics.
- Shell buckling of hollow fakes: past a force threshold the shell's stiffness drops abruptly.
- Coulomb friction with a spring-block contact (gel + arm stiffness in series): μs > μk gives
  stick–slip (sawtooth shear), μs ≈ μk gives smooth sliding; Cattaneo–Mindlin stick-region ratio
  for partial slip; the same for torsion under rotation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tacreasoner.sim.materials import GEL_MODULUS_MPA, Material
from tacreasoner.sim.protocol import Protocol

GEL_SHEAR_MODULUS_MPA = GEL_MODULUS_MPA / 3.0
ARM_STIFFNESS_N_PER_MM = 4.0
ARM_TORSION_NMM_PER_RAD = 300.0
SLIP_OVERSHOOT = 0.8
"""Fraction of the static–kinetic force gap lost past the kinetic level on each slip (dynamic drop)."""
SUBSTEPS = 10
CYLINDER_ELONGATION = 3.0
BUCKLE_SOFTENING = 6.0


@dataclass
class ContactTrajectory:
    """Per-frame ground truth (all arrays of length T) plus what the renderer needs."""

    phase: np.ndarray
    normal_force: np.ndarray
    shear: np.ndarray
    """Tangential force on the gel, N (T×2)."""
    torque: np.ndarray
    indent_gel: np.ndarray
    indent_object: np.ndarray
    contact_radius: np.ndarray
    contact_area: np.ndarray
    stick_ratio: np.ndarray
    slip: np.ndarray
    """0 = stick, 1 = partial slip (stick region shrinking from the rim), 2 = gross slip this frame."""
    centre_mm: np.ndarray
    """Object contact centre in the sensor frame, mm (T×2), including the shear bulge shift."""
    object_shift_mm: np.ndarray
    """Object (texture) position in the sensor frame, mm (T×2)."""
    object_rotation: np.ndarray
    """Object rotation in the sensor frame, rad."""
    gel_shift_mm: np.ndarray
    """Lateral displacement of the stuck gel patch relative to the sensor base, mm (T×2)."""
    gel_twist: np.ndarray
    conform: np.ndarray
    """0 = Hertz profile; →1 = the gel rests in a wide, shallow residual dent."""
    elongation: float
    axis_angle: float

    def ground_truth(self, decimals: int = 4) -> dict[str, list]:
        """JSON-ready per-frame ground truth for the manifest."""
        out: dict[str, list] = {"phase": [str(p) for p in self.phase]}
        for name in ("normal_force", "torque", "indent_gel", "indent_object", "contact_radius", "contact_area",
                     "stick_ratio"):
            out[name] = np.round(getattr(self, name).astype(float), decimals).tolist()
        out["shear_x"] = np.round(self.shear[:, 0], decimals).tolist()
        out["shear_y"] = np.round(self.shear[:, 1], decimals).tolist()
        out["slip"] = self.slip.astype(int).tolist()
        return out

    def __len__(self) -> int:
        return len(self.phase)


def _hertz_approach(force: float, e_star: float, radius: float) -> float:
    if force <= 0.0:
        return 0.0
    return float((3.0 * force / (4.0 * e_star * np.sqrt(radius))) ** (2.0 / 3.0))


def _spring_slip(u: np.ndarray, base_step: np.ndarray, k: float, cap_s: float, cap_k: float) -> tuple:
    """One sub-step of a spring-block contact; returns new relative displacement and whether it slipped.

    ``u`` is the stuck patch's displacement relative to the moving base; a sticking patch keeps its
    world position, so u moves against the base step.
    """
    u = u - base_step
    load = k * float(np.linalg.norm(u))
    if load > cap_s:
        direction = u / max(np.linalg.norm(u), 1e-12)
        after = max(cap_k - SLIP_OVERSHOOT * (cap_s - cap_k), 0.0) / k
        return direction * after, True
    return u, False


def simulate_contact(material: Material, protocol: Protocol, rng: np.random.Generator) -> ContactTrajectory:
    """Integrate the contact over the protocol (sub-stepped so stick–slip resolves between frames)."""
    m = material
    n = protocol.n_frames
    dt = 1.0 / protocol.fps
    j0, j_inf = 1.0 / m.e0_mpa, 1.0 / m.e_inf_mpa
    radius = m.radius_mm
    elongation = CYLINDER_ELONGATION if m.shape == "cylinder" else 1.0
    axis_angle = float(rng.uniform(0.0, np.pi))

    arrays = {name: np.zeros(n) for name in ("normal_force", "torque", "indent_gel", "indent_object",
                                             "contact_radius", "contact_area", "stick_ratio", "conform",
                                             "object_rotation", "gel_twist")}
    slip = np.zeros(n, dtype=np.int64)
    shear = np.zeros((n, 2))
    centre = np.zeros((n, 2))
    obj_shift = np.zeros((n, 2))
    gel_shift = np.zeros((n, 2))
    phase = protocol.nominal_phase()
    offset = np.asarray(protocol.offset_mm)

    creep = 0.0  # 0 → instantaneous compliance, 1 → fully relaxed (long-term) compliance
    peak_obj = peak_gel = peak_radius = 0.0
    buckled = False
    unloading = False
    u = np.zeros(2)  # gel patch displacement relative to base (shear)
    phi = 0.0  # gel patch twist relative to base
    prev_slide = protocol.slide_mm[0].copy()
    prev_twist = float(protocol.twist_rad[0])
    force_jitter = rng.normal(0.0, 0.02, n)

    for i in range(n):
        force = float(protocol.force_cmd[i])
        if force > 0 and protocol.stage[i] in ("hold", "action"):
            force *= 1.0 + force_jitter[i]
        in_contact = force > 0.0
        stage = protocol.stage[i]
        unloading = unloading or stage in ("release", "retract")
        if in_contact and not unloading:
            creep += (1.0 - creep) * (1.0 - np.exp(-dt / m.creep_tau_s))
        else:
            creep *= np.exp(-dt / m.recovery_tau_s)

        if m.buckle_force_n is not None:
            if force > m.buckle_force_n:
                buckled = True
            elif force < 0.5 * m.buckle_force_n:
                buckled = False
        j_obj = (j0 + (j_inf - j0) * creep) * (BUCKLE_SOFTENING if buckled else 1.0)
        e_star = 1.0 / (1.0 / GEL_MODULUS_MPA + j_obj)
        delta = _hertz_approach(force, e_star, radius)
        d_gel = delta * e_star / GEL_MODULUS_MPA
        d_obj = delta - d_gel
        a_hertz = float(np.sqrt(radius * delta))
        if not unloading:
            peak_obj, peak_gel, peak_radius = max(peak_obj, d_obj), max(peak_gel, d_gel), max(peak_radius, a_hertz)

        conform = 0.0
        a = a_hertz
        if unloading and in_contact and peak_obj > 0:
            # Residual dent: plastic set + the part of the delayed (creep) deformation not yet recovered.
            residual = m.plasticity + 0.5 * (1.0 - m.e_inf_mpa / m.e0_mpa) * creep
            a_res = peak_radius * float(np.sqrt(min(residual, 1.0)))
            if a_res > a_hertz:
                conform = 1.0 - a_hertz / a_res
                a = a_res
                d_gel = max(d_gel, 0.5 * residual * peak_gel)

        # Tangential: spring-block contact, sub-stepped.
        k_t = 1.0 / (1.0 / (8.0 * GEL_SHEAR_MODULUS_MPA * max(a, 1e-3)) + 1.0 / ARM_STIFFNESS_N_PER_MM)
        k_r = 1.0 / (1.0 / (16.0 / 3.0 * GEL_SHEAR_MODULUS_MPA * max(a, 1e-3) ** 3) + 1.0 / ARM_TORSION_NMM_PER_RAD)
        slide_step = (protocol.slide_mm[i] - prev_slide) / SUBSTEPS
        twist_step = (float(protocol.twist_rad[i]) - prev_twist) / SUBSTEPS
        prev_slide, prev_twist = protocol.slide_mm[i].copy(), float(protocol.twist_rad[i])
        slipped = False
        if in_contact:
            torsion_arm = 3.0 * np.pi / 16.0 * a
            for _ in range(SUBSTEPS):
                u, s1 = _spring_slip(u, slide_step, k_t, m.mu_s * force, m.mu_k * force)
                phi_vec, s2 = _spring_slip(np.array([phi, 0.0]), np.array([twist_step, 0.0]), k_r,
                                           m.mu_s * force * torsion_arm, m.mu_k * force * torsion_arm)
                phi = float(phi_vec[0])
                slipped = slipped or s1 or s2
        else:
            u = np.zeros(2)
            phi = 0.0
        q = k_t * u
        torque = k_r * phi
        q_ratio = float(np.linalg.norm(q)) / max(m.mu_s * force, 1e-9)
        m_ratio = abs(torque) / max(m.mu_s * force * 3.0 * np.pi / 16.0 * max(a, 1e-3), 1e-9)
        load_ratio = min(max(q_ratio, m_ratio), 1.0)

        arrays["normal_force"][i] = force
        arrays["torque"][i] = torque
        arrays["indent_gel"][i] = d_gel
        arrays["indent_object"][i] = d_obj
        arrays["contact_radius"][i] = a
        arrays["contact_area"][i] = np.pi * a * a * elongation
        arrays["stick_ratio"][i] = 0.0 if slipped else (1.0 - load_ratio) ** (1.0 / 3.0) if in_contact else 0.0
        arrays["conform"][i] = conform
        arrays["gel_twist"][i] = phi
        slip[i] = 2 if slipped else (1 if in_contact and load_ratio > 0.05 else 0)
        shear[i] = q
        gel_shift[i] = u
        obj_shift[i] = offset - protocol.slide_mm[i]
        arrays["object_rotation"][i] = -float(protocol.twist_rad[i])
        # Shear traction makes the gel bulge ahead of the contact: to first order, the imprint shifts
        # along the traction. This is what makes stick–slip visible without markers.
        centre[i] = obj_shift[i] + 0.5 * u
        if not in_contact:
            phase[i] = "no_contact"

    return ContactTrajectory(phase=phase, shear=shear, slip=slip, centre_mm=centre, object_shift_mm=obj_shift,
                             gel_shift_mm=gel_shift, elongation=elongation, axis_angle=axis_angle, **arrays)

