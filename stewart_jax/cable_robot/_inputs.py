"""Physical checks of the FAST feed-support inputs, made before any work (Yin et al., "Dynamic
modeling of a cable-driven parallel robot with a Stewart platform for use in FAST", Table 1 and §6).

- Material and mass: ``EA``, the cable density ``ρ``, the cabin mass and gravity must be
  positive (gravity pointing down: Table 1's signed ``g = −9.8 m/s²``).
- Position: a cabin above the tower tops (the cables pull it up from below them), below the
  reflector's surface or outside the towers' circle is named for what it is; one off the focal
  surface (where the feed works, radius 160 m about the centre of curvature) is simulated with a
  warning.
- Time step: the integrator must resolve both the forcing and the highest natural frequency of
  the cabin on its cables. A step with fewer than :data:`MIN_STEPS_PER_PERIOD` steps per period of
  the faster of the two is refused; fewer than :data:`WARN_STEPS_PER_PERIOD` is warned with the
  expected error.

  NOTE: the highest mode is bounded from above by the rigid cabin on six straight elastic
  cables, stiffness ``EA/L`` along each chord: sag only softens a cable (the catenary's
  stiffness is below the chord's), so the bound is safe. With Table 1 it is 1.6–1.8 Hz at the
  paper's positions, below the 5 Hz forcing.
"""

from __future__ import annotations

import warnings

import jax
import numpy as np

MIN_STEPS_PER_PERIOD = 10
"""Fewer steps per period of the fastest motion than this are refused: a sine sampled 2× per
period (0.1 s at 5 Hz) loses its amplitude, and velocity Verlet is unstable at ω·dt ≥ 2."""
WARN_STEPS_PER_PERIOD = 50
"""Fewer steps per period than this (but at least :data:`MIN_STEPS_PER_PERIOD`) are warned with
the expected error."""


def _concrete(*xs) -> bool:
    return not any(isinstance(x, jax.core.Tracer) for x in jax.tree_util.tree_leaves(xs))


def check_cable_material(EA, rho, g) -> None:
    """``EA > 0`` (N), ``ρ > 0`` (kg/m) and ``g < 0`` (m/s², signed along +z); no-op on tracers."""
    if not _concrete(EA, rho, g):
        return
    for name, value, unit in (("EA", EA, "N"), ("rho", rho, "kg/m")):
        v = np.asarray(value, np.float64)
        if not np.all(np.isfinite(v) & (v > 0)):
            raise ValueError(f"cable {name} must be a positive number ({unit}), got {v.tolist()}")
    v = np.asarray(g, np.float64)
    if not np.all(np.isfinite(v) & (v < 0)):
        raise ValueError(f"cable g is the signed gravitational acceleration along +z and must be < 0 "
                         f"(-9.8 m/s² on Earth), got {v.tolist()}: zero gravity, or gravity pointing up?")


def check_fast_params(params) -> None:
    """The cabin's mass and inertia and the gravity of :class:`FastParams` are physical."""
    if not _concrete(params.m_CB, params.I_CB, params.gravity):
        return
    m = np.asarray(params.m_CB, np.float64)
    if not np.all(np.isfinite(m) & (m > 0)):
        raise ValueError(f"the cabin mass m_CB must be positive (kg), got {m.tolist()}")
    inertia = np.asarray(params.I_CB, np.float64)
    if inertia.shape == (3, 3) and not (np.all(np.isfinite(inertia)) and np.all(np.linalg.eigvalsh(
            0.5 * (inertia + inertia.T)) > 0)):
        raise ValueError(f"the cabin inertia I_CB must be symmetric positive definite (kg·m²), got {inertia.tolist()}")
    gravity = np.asarray(params.gravity, np.float64)
    if gravity.shape[-1:] == (3,) and not np.all(gravity[..., 2] < 0):
        raise ValueError(f"gravity must point down (negative z, m/s²), got {gravity.tolist()}")


def position_problem(position, towers) -> str | None:
    """Why a cabin cannot be at ``position`` (m), or ``None``: above the tower tops, outside the
    towers' circle, below the reflector's surface or the ground."""
    from ._workspace import APERTURE_RADIUS, reflector_clearance

    p = np.asarray(position, np.float64)
    t = np.asarray(towers, np.float64)
    top = float(np.min(t[:, 2]))
    radius = float(np.min(np.linalg.norm(t[:, :2], axis=-1)))
    r = float(np.hypot(p[0], p[1]))
    where = f"cabin position {p.tolist()} m"
    if p[2] >= top:
        return (f"{where} is above the tower tops ({top:g} m): the cables hang from the towers and can only hold "
                "the cabin below them (is the position in metres?)")
    if r >= radius:
        return f"{where} lies {r:.4g} m from the axis, outside the towers' circle ({radius:g} m)"
    if float(reflector_clearance(p)) <= 0.0:
        surface = "the ground outside the aperture" if r > APERTURE_RADIUS else "the reflector's surface"
        return (f"{where} is at or below {surface} (sphere of radius 300 m through the origin, aperture "
                f"{APERTURE_RADIUS:g} m)")
    return None


def focal_surface_warning(position) -> str | None:
    """A sentence when ``position`` lies more than 1 m off the focal surface (the feed's working
    surface: radius 160 m about the centre of curvature)."""
    from ._workspace import CURVATURE_CENTRE, FOCAL_RADIUS

    d = float(np.linalg.norm(np.asarray(position, np.float64) - np.asarray(CURVATURE_CENTRE)))
    if abs(d - FOCAL_RADIUS) <= 1.0:
        return None
    side = "inside" if d < FOCAL_RADIUS else "outside"
    return (f"cabin position {np.asarray(position).tolist()} m lies {abs(d - FOCAL_RADIUS):.3g} m {side} the focal "
            f"surface (radius {FOCAL_RADIUS:g} m about the centre of curvature), where the feed works; Table 2's "
            "positions lie on it")


def highest_mode_bound_hz(params, position, R=None) -> float:
    """An upper bound (Hz) of the cabin's natural frequencies at ``position`` on its cables: the
    rigid cabin on six straight springs ``EA/L_i`` along the chords (see the module's NOTE)."""
    p = np.asarray(position, np.float64)
    R = np.eye(3) if R is None else np.asarray(R, np.float64)
    anchors = np.asarray(params.anchors) @ R.T
    chord = np.asarray(params.towers) - (p + anchors)
    length = np.linalg.norm(chord, axis=-1)
    u = chord / length[:, None]
    rows = np.concatenate([u, np.cross(anchors, u)], axis=1)  # (6, 6): force and moment of a unit pull
    k = float(np.asarray(params.cable.EA)) / length
    stiffness = (rows.T * k) @ rows
    inertia = R @ np.asarray(params.I_CB) @ R.T
    mass = np.zeros((6, 6))
    mass[:3, :3] = np.eye(3) * float(np.asarray(params.m_CB))
    mass[3:, 3:] = inertia
    eig = np.linalg.eigvals(np.linalg.solve(mass, stiffness)).real
    return float(np.sqrt(max(float(np.max(eig)), 0.0)) / (2 * np.pi))


def check_time_step(dt: float, forcing_hz: float, highest_mode_hz: float | None = None) -> str | None:
    """Refuse (``ValueError``) a time step with fewer than :data:`MIN_STEPS_PER_PERIOD` steps per
    period of the forcing or the highest mode; return a warning with the expected error below
    :data:`WARN_STEPS_PER_PERIOD`, else ``None``."""
    if not _concrete(dt, forcing_hz, highest_mode_hz):
        return None
    f_force = abs(float(forcing_hz))
    cases = [("the forcing", f_force)] if f_force > 0 else []
    if highest_mode_hz is not None and highest_mode_hz > 0:
        cases.append(("the cabin's highest natural frequency (an upper bound)", float(highest_mode_hz)))
    if not cases:
        return None
    what, f = max(cases, key=lambda c: c[1])
    steps = 1.0 / (f * float(dt))
    if steps < MIN_STEPS_PER_PERIOD:
        raise ValueError(
            f"time step dt = {dt:g} s is too coarse: {steps:.3g} steps per period of {what} ({f:.3g} Hz); at least "
            f"{MIN_STEPS_PER_PERIOD} are needed (dt <= {1.0 / (MIN_STEPS_PER_PERIOD * f):.3g} s), "
            f"{WARN_STEPS_PER_PERIOD} for errors below 0.2% (dt <= {1.0 / (WARN_STEPS_PER_PERIOD * f):.3g} s)")
    if steps < WARN_STEPS_PER_PERIOD:
        sampled = 1.0 - np.cos(np.pi / steps)
        phase = (2 * np.pi / steps) ** 2 / 24
        return (f"time step dt = {dt:g} s gives {steps:.3g} steps per period of {what} ({f:.3g} Hz): expect "
                f"amplitudes low by up to {100 * sampled:.2g}% (a sampled sine's peak) and a relative frequency "
                f"error of about {100 * phase:.2g}% (velocity Verlet, (ω·dt)²/24); dt <= "
                f"{1.0 / (WARN_STEPS_PER_PERIOD * f):.3g} s keeps both below 0.2%")
    return None


def warn_time_step(dt, forcing_hz, highest_mode_hz=None) -> None:
    """:func:`check_time_step`, its warning issued as a ``UserWarning``."""
    message = check_time_step(dt, forcing_hz, highest_mode_hz)
    if message:
        warnings.warn(message, UserWarning, stacklevel=3)
