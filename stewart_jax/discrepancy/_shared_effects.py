"""The candidate effects whose physics does not depend on the leg, for every mechanism's model.

``backlash`` and ``drift`` change only the readings' ``offset`` (the actuator's lost motion, a
reading that creeps during the run); ``tracker_misalignment`` changes only the measured poses
(the instrument frame's rotation and shift) and ``tracker_scale`` only their positions (the
instrument's distance scale). Each is written once here, on a model state with
``offset`` (``(m, 6)``, the reading's unit), ``poses`` (``(m, 6)``, mm, rad) and ``v0`` (mm), and a
family's model registers it with :func:`register_shared` at the place in its list of effects
where it belongs, in the unit of its readings (µm for a stroke, µrad for a crank angle).
"""

from __future__ import annotations

from typing import Any

import jax.numpy as jnp
from jaxtyping import Array, Float

from .._math import euler_angles, rotation_matrix
from .._units import ARCSEC, UM
from ..calibration._problem import CalibrationData
from ._registry import Effect, register_effect

T_REF_C = 20.0
"""Reference temperature of ``thermal_expansion`` (°C): the geometry's lengths hold at this
temperature."""

DRIFT_TIME_UNIT_S = 3600.0
"""Drift rates are reported per hour."""

URAD = 1e-6
"""One µrad in rad."""


def backlash(theta: Float[Array, "6"], data: CalibrationData, state: Any) -> Any:
    """Lost motion of width ``b_i`` (the reading's unit: mm for a stroke, rad for a crank angle):
    approached from direction ``dir_i = ±1`` the reading is offset by ``b_i·dir_i/2`` from the
    true one."""
    return state._replace(offset=state.offset + 0.5 * theta * data.directions)


def drift(theta: Float[Array, "6"], data: CalibrationData, state: Any) -> Any:
    """Readings drift linearly during the run: reading = true reading + ``c_i·t`` (``c_i`` in the
    reading's unit per second, ``t`` the ``time`` column)."""
    return state._replace(offset=state.offset + theta * data.time[:, None])


def tracker_misalignment(theta: Float[Array, "6"], data: CalibrationData, state: Any) -> Any:
    """The instrument frame M is rotated by ``R(ρ)`` (``ρ = theta[:3]``, rad, the Euler
    convention of Wang et al. 2018, eq. 1) and shifted by ``τ = theta[3:]`` (mm) relative to B: a point is
    ``x_B = R(ρ)·x_M + τ``. The measured pose is the platform pose in M, so the true pose is
    ``R = R(ρ)·R'``, ``d + v0 = R(ρ)·(d' + v0) + τ``. Acts on the measurement only: for control
    the targets are already in B."""
    rho = rotation_matrix(theta[:3])
    rot = jnp.einsum("jk,mkl->mjl", rho, rotation_matrix(state.poses[:, 3:]))
    d = (state.poses[:, :3] + state.v0) @ rho.T + theta[3:] - state.v0
    return state._replace(poses=jnp.concatenate([d, euler_angles(rot)], axis=-1))


def tracker_scale(theta: Float[Array, "1"], data: CalibrationData, state: Any) -> Any:
    """The instrument's distances are scaled by ``1 + s`` (``s = theta[0]``, dimensionless; e.g.
    the refractive index of air not applied to a laser tracker's interferometer, ~270 ppm at
    sea level): a measured position is ``x_M = (1 + s)·x`` about the instrument frame's origin,
    so the true platform position is ``d + v0 = (d' + v0) / (1 + s)``; angles are not scaled.
    A shift of the scaling's centre is a shift of the frame (``tracker_misalignment``). Acts on
    the measurement only.

    Exact equivalence: for a strut hexapod a common scale of every position is a scale of the
    geometry times one scale of every strut length, so ``tracker_scale`` ≡ ``strut_scale`` with
    equal ``k_i`` + geometry; only a reference length measured by the tracker (a calibrated
    scale bar) or by the struts separates them."""
    d = (state.poses[:, :3] + state.v0) / (1.0 + theta[0]) - state.v0
    return state._replace(poses=jnp.concatenate([d, state.poses[:, 3:]], axis=-1))


def register_shared(name: str, model: str, reading_unit: str) -> Effect:
    """Register the shared effect ``name`` (``"backlash"``, ``"drift"``, ``"tracker_misalignment"``,
    ``"tracker_scale"``)
    for ``model``, whose readings are in ``reading_unit`` (``"mm"``: parameters reported in µm,
    µm/h; ``"rad"``: in µrad, µrad/h)."""
    size, unit, per = (UM, "µm", UM) if reading_unit == "mm" else (1e-5, "µrad", URAD)  # scale, report unit
    if name == "backlash":
        return register_effect(model, name, n_params=6, scale=size, unit=unit, report_factor=1 / per,
                               requires=("directions",))(backlash)
    if name == "drift":
        return register_effect(model, name, n_params=6, scale=size / DRIFT_TIME_UNIT_S, unit=f"{unit}/h",
                               report_factor=DRIFT_TIME_UNIT_S / per, requires=("time",))(drift)
    if name == "tracker_misalignment":
        return register_effect(model, name, n_params=6, scale=(10 * ARCSEC,) * 3 + (UM,) * 3, unit="″,″,″,µm,µm,µm",
                               report_factor=(1 / ARCSEC,) * 3 + (1 / UM,) * 3, acts_on="measurement",
                               )(tracker_misalignment)
    if name == "tracker_scale":
        return register_effect(model, name, n_params=1, scale=1e-4, unit="ppm", report_factor=1e6,
                               acts_on="measurement")(tracker_scale)
    raise ValueError(f"no shared effect {name!r}; shared: backlash, drift, tracker_misalignment, tracker_scale")
