"""An independent NumPy simulator of a measurement session on a hexapod, for the hidden-effect
tests and the benchmark of the discrepancy workflow (written from the physics, not from the
library's effect registry or its ``_hidden.py``).

A session, as on a real machine: ``n`` poses drawn uniformly in the travel box and visited in
that (random) order over about two hours (``time``, s); each actuator's approach direction is
the sign of its last move (``dir``, recorded); the temperature drifts (a settling exponential,
a slow oscillation and sensor noise: recorded, °C); the pose is measured with Gaussian noise
σ (µm, ″ per component).

The true machine is a perturbed copy of the nominal geometry (joints and, for struts, the
zero-reading lengths moved by tens of µm) with one hidden effect. Effects that the library
registers (its candidate list) and effects it does not:

- ``cyclic_screw``: a ball-screw / encoder cyclic error of each actuator's reading,
  ``A·sin(2π q / lead + φ_i)`` (amplitude ``A`` µm, lead mm, a random phase per actuator);
- ``quadratic_reading``: a reading error ``c_i q²`` (``|c_i| q²`` = 0.5–1 µm at 5 mm);
- ``strut_thermal_scale``: the encoder scale of one actuator only changes with temperature,
  reading = true change · ``(1 + κ (T − 20 °C))``.

Near-equivalent and instrument effects (6-UPS; ``NEAR_EQUIVALENT``):

- ``load_compliance``: each strut stretches by its axial compliance (struts of one design: one
  value, 60–120 µm per payload weight, ±5 % from strut to strut) times its axial force from a
  heavy payload whose centre of mass is off A's origin (``com`` mm in A), at a telescope
  elevation (gravity along ``(0, −cos e, −sin e)`` in B): close to, not the same as, the
  registered weight at A's origin along −z;
- ``tracker_scale``: the instrument's distances are scaled by ``1 + s`` (``s`` = 270 ppm, the
  refractive index of air not applied): exactly a strut scale equal on every strut plus a scaled
  geometry;
- ``blend``: a strut scale plus a reading error orthogonal (over the session's readings) to the
  span of the geometry's and the strut scale's signatures, of a chosen size ``f`` relative to
  the strut scale's signature outside the geometry's span (the size curve of the naming rule).

The same three in crank form for the rotary hexapod (6-RUS, readings in rad): ``cyclic_crank``, a
gear-tooth / encoder cyclic error of each crank reading ``A·sin(2π q / P + φ_i)`` (``A`` = 20 µrad,
``P`` = 4°, the tooth pitch of a 90-tooth gear); ``quadratic_reading``, ``c_i q²`` (10–20 µrad at
0.25 rad); ``crank_thermal_gain``, one crank's reading gain changing with temperature.

The 6-RUS leg (a crank of length ``a`` turning about a horizontal axis at the motor ``b`` in the
vertical plane along ``u = (cos β, sin β, 0)``; a rod of length ``s`` to the platform joint): with
``l`` the platform joint minus the motor, ``|l − a (cos α u + sin α e_z)| = s`` is
``E cos α + F sin α = G`` (``E = u·l``, ``F = l_z``, ``G = (|l|² + a² − s²) / 2a``), i.e.
``√(E² + F²) cos(α − atan2(F, E)) = G``; the crank end below the motor-to-joint line is
``α = atan2(F, E) − arccos(G / √(E² + F²))``.

Rotations: ``Rz(ψ)·Ry(θ)·Rx(φ)`` (Wang et al. 2018, "Improved cuckoo calibration method of
space telescope secondary mirror adjusting mechanism", Infrared and Laser Engineering 47(5),
eq. 1), angles in rad; lengths in mm.
"""

from __future__ import annotations

import dataclasses

import numpy as np

UM = 1e-3
ARCSEC = np.pi / (180 * 3600)
T_REF = 20.0

REGISTERED = {
    "6-RUS": ("crank_offset", "gear_ratio", "backlash", "thermal_expansion", "drift", "tracker_misalignment"),
    "6-UPS": ("strut_scale", "thermal_expansion", "gravity_sag", "backlash", "drift", "tracker_misalignment"),
    "6-PSS": ("zero_offset", "stroke_scale", "actuator_tilt", "backlash", "thermal_expansion", "drift",
              "tracker_misalignment"),
}
UNREGISTERED = ("cyclic_screw", "quadratic_reading", "strut_thermal_scale")
NEAR_EQUIVALENT = ("load_compliance", "tracker_scale")
"""6-UPS effects close to, or exactly equivalent to, a registered one up to the geometry."""
"""The strut families' effects that the registry lacks."""
UNREGISTERED_ROTARY = ("cyclic_crank", "quadratic_reading", "crank_thermal_gain")
"""The same three ideas in crank form (6-RUS)."""
URAD = 1e-6
CRANK_PERIOD_DEG = 4.0
"""The cyclic crank error's period: the tooth pitch of a 90-tooth gear (deg of crank angle)."""


def unregistered(family: str) -> tuple[str, ...]:
    """The hidden effects of ``family`` that its registry lacks."""
    return UNREGISTERED_ROTARY if family == "6-RUS" else UNREGISTERED


def rotation(a):
    """``(..., 3)`` angles ``[φ, θ, ψ]`` → ``(..., 3, 3)`` ``Rz(ψ)·Ry(θ)·Rx(φ)``."""
    f, t, p = a[..., 0], a[..., 1], a[..., 2]
    cf, sf, ct, st, cp, sp = np.cos(f), np.sin(f), np.cos(t), np.sin(t), np.cos(p), np.sin(p)
    return np.stack([
        np.stack([cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf], -1),
        np.stack([sp * ct, sp * st * sf + cp * cf, sp * st * cf - cp * sf], -1),
        np.stack([-st, ct * sf, ct * cf], -1),
    ], -2)


def angles(r):
    """Inverse of :func:`rotation` (|θ| < 90°)."""
    return np.stack([np.arctan2(r[..., 2, 1], r[..., 2, 2]), -np.arcsin(r[..., 2, 0]),
                     np.arctan2(r[..., 1, 0], r[..., 0, 0])], -1)


@dataclasses.dataclass(frozen=True)
class Session:
    """Measured columns (``readings``: mm, or rad for cranks; ``poses`` measured, mm
    and rad; ``directions`` ±1; ``temperature`` °C; ``time`` s) and the truth (``effect``, its
    parameters ``truth``, ``period_mm`` or ``period_deg`` of a cyclic error, ``leg`` of a
    one-actuator effect)."""

    readings: np.ndarray
    poses: np.ndarray
    directions: np.ndarray
    temperature: np.ndarray
    time: np.ndarray
    effect: str | None
    truth: dict


def _conditions(rng, n):
    t = np.cumsum(rng.uniform(25.0, 55.0, n))  # ~2 h for 180 poses
    tau, amp = rng.uniform(1500, 4000), rng.uniform(1.0, 2.5) * rng.choice([-1, 1])
    temp = (T_REF + rng.uniform(-1, 1) + amp * (1 - np.exp(-t / tau))
            + 0.4 * np.sin(2 * np.pi * t / rng.uniform(1800, 3600) + rng.uniform(0, 2 * np.pi))
            + 0.02 * rng.standard_normal(n))
    return t, temp


def _directions(q):
    """Sign of each actuator's last move (the first pose: approached from below)."""
    d = np.sign(np.diff(np.concatenate([q[:1] - 1.0, q]), axis=0))
    return np.where(d == 0, 1.0, d)


def _strut_statics(rot, d, v0, platform, base):
    """Axial tension per unit payload weight (weight along −z at A's origin)."""
    r = np.einsum("mjk,ik->mij", rot, platform)
    s = r + d[:, None] + v0 - base
    u = s / np.linalg.norm(s, axis=-1, keepdims=True)
    g = np.concatenate([u, np.cross(r, u)], -1)
    wrench = np.broadcast_to([0, 0, -1.0, 0, 0, 0], d.shape[:1] + (6,))
    return np.linalg.solve(np.swapaxes(g, -1, -2), wrench[..., None])[..., 0]


def _loads(rot, d, v0, platform, base, com, elevation_rad):
    """Axial tension per unit payload weight: the weight at ``com`` (mm in A) along
    ``(0, −cos e, −sin e)`` in B (``e`` the elevation; 90°: along −z)."""
    r = np.einsum("mjk,ik->mij", rot, platform)
    s = r + d[:, None] + v0 - base
    u = s / np.linalg.norm(s, axis=-1, keepdims=True)
    g = np.concatenate([u, np.cross(r, u)], -1)
    down = np.array([0.0, -np.cos(elevation_rad), -np.sin(elevation_rad)])
    arm = np.einsum("mjk,k->mj", rot, com)
    wrench = np.concatenate([np.broadcast_to(down, arm.shape), np.cross(arm, down)], -1)
    return np.linalg.solve(np.swapaxes(g, -1, -2), wrench[..., None])[..., 0]


def _draw(rng, effect, family, n_legs=6):
    """True parameters of ``effect`` (physical units: mm, 1/K, rad, mm/s, dimensionless)."""
    sgn = rng.choice([-1.0, 1.0], n_legs)
    if effect == "load_compliance":
        return {"c": rng.uniform(60, 120) * rng.uniform(0.95, 1.05, n_legs) * UM,
                "com": rng.uniform(150, 300, 3) * rng.choice([-1, 1], 3),
                "elevation_deg": float(rng.uniform(30, 60))}
    if effect == "tracker_scale":
        return {"s": 270e-6}
    if effect == "blend":
        return {"k": sgn * rng.uniform(300e-6, 600e-6, n_legs)}
    if effect == "strut_scale_2000ppm":
        return {"k": np.full(n_legs, 2000e-6) + rng.uniform(-200e-6, 200e-6, n_legs)}
    if family == "6-RUS":
        p = _draw_rotary(rng, effect, sgn, n_legs)
        if p is not None:
            return p
    if effect in ("strut_scale", "stroke_scale"):
        return {"k": sgn * rng.uniform(300e-6, 600e-6, n_legs)}
    if effect == "thermal_expansion":
        return {"alpha": sgn * rng.uniform(1e-6, 2e-6, n_legs) * (1.0 if family == "6-UPS" else 4.0)}
    if effect == "gravity_sag":
        return {"c": sgn * rng.uniform(60, 120, n_legs) * UM}
    if effect == "backlash":
        return {"b": rng.uniform(1.0, 2.0, n_legs) * UM}
    if effect == "drift":
        return {"rate": sgn * rng.uniform(0.5, 1.0, n_legs) * UM / 3600}
    if effect == "tracker_misalignment":
        return {"rho": rng.uniform(10, 20, 3) * ARCSEC * rng.choice([-1, 1], 3),
                "tau": rng.uniform(5, 10, 3) * UM * rng.choice([-1, 1], 3)}
    if effect == "zero_offset":
        return {"c": sgn * rng.uniform(2, 4, n_legs) * UM}
    if effect == "actuator_tilt":
        return {"alpha": rng.uniform(300, 600, n_legs) * 1e-6 * sgn,
                "beta": rng.uniform(300, 600, n_legs) * 1e-6 * rng.choice([-1, 1], n_legs)}
    if effect == "cyclic_screw":
        return {"amp": 1.0 * UM, "lead": 1.0, "phase": rng.uniform(0, 2 * np.pi, n_legs)}
    if effect == "quadratic_reading":
        return {"c": sgn * rng.uniform(0.5, 1.0, n_legs) * UM / 25.0}
    if effect == "strut_thermal_scale":
        return {"leg": int(rng.integers(n_legs)), "kappa": float(rng.choice([-1, 1]) * rng.uniform(150e-6, 250e-6))}
    if effect is None:
        return {}
    raise ValueError(f"unknown effect {effect!r}")


def _draw_rotary(rng, effect, sgn, n_legs):
    """The crank effects (rad, rad/s, 1/K, dimensionless), or ``None`` for the shared ones.

    Magnitudes: the pose noise (0.1 µm, 0.1″) reaches a 50 mm crank's reading as ~2.2 µrad, so
    the effects are a few to ten times that, as the strut families' are to theirs — a homing
    error of 50–100 µrad, a gain error of 0.3–0.6 % (a servo's pulse-width-to-angle gain, a gear
    ratio off by a tooth in 200: the joints, cranks and rods absorb 99 % of a gain error over
    this ±0.3 rad of crank travel, so 500 ppm leaves 0.5 µrad), gearbox lost motion of 20–40 µrad
    (4–8″: a precision gearhead), an encoder zero drift of 10–20 µrad/h, rods whose expansion
    differs from the nominal by 2–4 ppm/K, an encoder cyclic error of 20 µrad (4″), and one
    crank's reading gain drifting by 40–60 ppm/K."""
    if effect == "crank_offset":
        return {"c": sgn * rng.uniform(50, 100, n_legs) * URAD}
    if effect == "gear_ratio":
        return {"k": sgn * rng.uniform(3e-3, 6e-3, n_legs)}
    if effect == "backlash":
        return {"b": rng.uniform(20, 40, n_legs) * URAD}
    if effect == "drift":
        return {"rate": sgn * rng.uniform(10, 20, n_legs) * URAD / 3600}
    if effect == "thermal_expansion":
        return {"alpha": sgn * rng.uniform(2e-6, 4e-6, n_legs)}
    if effect == "cyclic_crank":
        return {"amp": 20 * URAD, "period": np.deg2rad(CRANK_PERIOD_DEG), "phase": rng.uniform(0, 2 * np.pi, n_legs)}
    if effect == "quadratic_reading":
        return {"c": sgn * rng.uniform(10, 20, n_legs) * URAD / 0.25**2}
    if effect == "crank_thermal_gain":
        return {"leg": int(rng.integers(n_legs)), "kappa": float(rng.choice([-1, 1]) * rng.uniform(40e-6, 60e-6))}
    return None


def crank_angles(leg, azimuth, crank, rod):
    """Absolute crank angles (rad) of legs whose platform joint minus motor is ``leg`` (``(..., 6, 3)``,
    mm), from the closed form of the module docstring."""
    e = np.cos(azimuth) * leg[..., 0] + np.sin(azimuth) * leg[..., 1]
    f = leg[..., 2]
    g = (np.sum(leg**2, -1) + crank**2 - rod**2) / (2 * crank)
    rho = np.hypot(e, f)
    if np.any(np.abs(g) > rho):
        raise ValueError("a rod does not reach its crank's circle")
    return np.arctan2(f, e) - np.arccos(g / rho)


def _reading_error(effect, p, q, temp):
    """Reading-side errors: what the encoder shows minus the true length change ``q``."""
    if effect == "cyclic_screw":
        return p["amp"] * np.sin(2 * np.pi * q / p["lead"] + p["phase"])
    if effect == "cyclic_crank":
        return p["amp"] * np.sin(2 * np.pi * q / p["period"] + p["phase"])
    if effect == "quadratic_reading":
        return p["c"] * q**2
    if effect in ("strut_thermal_scale", "crank_thermal_gain"):
        e = np.zeros_like(q)
        e[:, p["leg"]] = q[:, p["leg"]] * p["kappa"] * (temp - T_REF)
        return e
    return np.zeros_like(q)


def session(family: str, geometry: dict, effect: str | None, rng: np.random.Generator, *, half: np.ndarray,
            n: int = 180, sigma_um: float = 0.1, sigma_arcsec: float = 0.1,
            perturb_um: float = 30.0, temp_noise_K: float | None = None, blend: float | None = None) -> Session:
    """Simulate one session of ``family`` (``"6-UPS"``: ``geometry`` has ``base``, ``platform``,
    ``v0``, ``lengths0``; ``"6-PSS"``: ``upper``, ``lower``, ``v0``, vertical sliders;
    ``"6-RUS"``: ``base`` (motors), ``platform``, ``v0``, ``crank_lengths``, ``rod_lengths``,
    ``azimuth`` (rad), ``crank_zero`` (rad)) with ``effect`` hidden; poses uniform in ``±half``
    (mm, rad). The perturbation moves joints and lengths by ``perturb_um`` and a crank zero by
    ``perturb_um`` of arc at the crank's end; azimuths and ``v0`` stay nominal (not calibrated).
    ``temp_noise_K``: the recorded temperature is the one the struts see plus Gaussian noise of
    this σ (K). ``blend``: the size ``f`` of the orthogonal part of effect ``"blend"`` (6-UPS)."""
    g = {k: np.array(v, dtype=float) for k, v in geometry.items()}
    for k in ("base", "platform", "upper", "lower"):
        if k in g:
            g[k] = g[k] + perturb_um * UM * rng.standard_normal(g[k].shape)
    for k in ("lengths0", "crank_lengths", "rod_lengths"):
        if k in g:
            g[k] = g[k] + perturb_um * UM * rng.standard_normal(6)
    if "crank_zero" in g:
        g["crank_zero"] = g["crank_zero"] + perturb_um * UM / g["crank_lengths"] * rng.standard_normal(6)
    p = _draw(rng, effect, family)
    true = rng.uniform(-half, half, (n, 6))
    t, temp = _conditions(rng, n)
    rot = rotation(true[:, 3:])
    dt = temp - T_REF
    if family == "6-UPS":
        s = np.einsum("mjk,ik->mij", rot, g["platform"]) + true[:, None, :3] + g["v0"] - g["base"]
        length = np.linalg.norm(s, axis=-1)
        if effect == "gravity_sag":
            length = length - p["c"] * _strut_statics(rot, true[:, :3], g["v0"], g["platform"], g["base"])
        if effect == "load_compliance":
            length = length - p["c"] * _loads(rot, true[:, :3], g["v0"], g["platform"], g["base"], p["com"],
                                              np.deg2rad(p["elevation_deg"]))
        if effect == "thermal_expansion":
            length = length / (1 + p["alpha"] * dt[:, None])  # the strut is longer: less extension needed
        q = length - g["lengths0"]
    elif family == "6-RUS":
        rod = g["rod_lengths"] * (1 + p["alpha"] * dt[:, None]) if effect == "thermal_expansion" else g["rod_lengths"]
        joint = np.einsum("mjk,ik->mij", rot, g["platform"]) + true[:, None, :3] + g["v0"]
        q = crank_angles(joint - g["base"], g["azimuth"], g["crank_lengths"], rod) - g["crank_zero"]
    else:
        w = np.einsum("mjk,ik->mij", rot, g["upper"]) + true[:, None, :3] + g["v0"] - g["lower"]
        rod = np.linalg.norm(g["upper"] + g["v0"] - g["lower"], axis=-1)
        if effect == "thermal_expansion":
            rod = rod * (1 + p["alpha"] * dt[:, None])
        axis = np.broadcast_to([0.0, 0.0, 1.0], (6, 3))
        if effect == "actuator_tilt":
            a, b = p["alpha"], p["beta"]
            axis = np.stack([np.cos(a) * np.sin(b), -np.sin(a), np.cos(a) * np.cos(b)], -1)
        wn = np.einsum("mij,ij->mi", w, axis)
        q = wn - np.sqrt(rod**2 - np.sum(w**2, -1) + wn**2)
    reading = q.copy()
    if effect in ("strut_scale", "stroke_scale", "gear_ratio", "strut_scale_2000ppm", "blend"):
        reading = q / (1 + p["k"])  # the actuator moves (1 + k) × what its encoder reads
    directions = _directions(q)
    if effect == "backlash":
        reading = reading + 0.5 * p["b"] * directions
    if effect == "drift":
        reading = reading + p["rate"] * t[:, None]
    if effect in ("zero_offset", "crank_offset"):
        reading = reading + p["c"]
    reading = reading + _reading_error(effect, p, q, temp)
    if effect == "blend":
        p = {**p, "f": blend}
        reading = reading + _orthogonal_part(g, rot, true, q, p["k"], blend, rng)
    measured = true.copy()
    if effect == "tracker_misalignment":
        r_m = rotation(p["rho"])
        measured[:, 3:] = angles(np.einsum("kj,mkl->mjl", r_m, rot))
        measured[:, :3] = (true[:, :3] + g["v0"] - p["tau"]) @ r_m - g["v0"]
    if effect == "tracker_scale":
        measured[:, :3] = (true[:, :3] + g["v0"]) * (1 + p["s"]) - g["v0"]
    measured[:, :3] += sigma_um * UM * rng.standard_normal((n, 3))
    measured[:, 3:] += sigma_arcsec * ARCSEC * rng.standard_normal((n, 3))
    if temp_noise_K is not None:
        temp = temp + temp_noise_K * rng.standard_normal(n)
    if effect == "cyclic_screw":
        p = {**p, "period_mm": p["lead"]}
    if effect == "cyclic_crank":
        p = {**p, "period_deg": CRANK_PERIOD_DEG}
    return Session(reading, measured, directions, temp, t, effect, p)


def _orthogonal_part(g, rot, true, q, k, f, rng):
    """A reading error orthogonal, per strut over the session's poses, to the span of the strut's
    geometry signatures (its platform joint, base joint and zero-reading length: the reading's
    derivatives) and its scale signature ``q``, of RMS ``f`` × the RMS of the scale error's part
    outside the geometry's span. Its shape: a random quadratic form of the pose, a smooth
    error no registered effect has."""
    s = np.einsum("mjk,ik->mij", rot, g["platform"]) + true[:, None, :3] + g["v0"] - g["base"]
    u = s / np.linalg.norm(s, axis=-1, keepdims=True)
    x = true / np.maximum(np.ptp(true, axis=0), 1e-12)
    out = np.zeros_like(q)
    for i in range(q.shape[1]):
        geo = np.concatenate([np.einsum("mk,mkj->mj", u[:, i], rot), -u[:, i], -np.ones((len(q), 1))], -1)
        qg, _ = np.linalg.qr(geo)
        scale_err = -k[i] * q[:, i]
        outside = scale_err - qg @ (qg.T @ scale_err)
        qa, _ = np.linalg.qr(np.concatenate([geo, q[:, i : i + 1]], -1))
        v = np.einsum("mj,jk,mk->m", x, rng.standard_normal((6, 6)), x)
        v = v - qa @ (qa.T @ v)
        out[:, i] = f * np.linalg.norm(outside) * v / np.linalg.norm(v)
    return out
