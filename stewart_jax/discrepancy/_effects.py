"""The candidate effects of the 6-PSS model (the mechanism of Wang et al. 2018, "Improved
cuckoo calibration method of space telescope secondary mirror adjusting mechanism", Infrared
and Laser Engineering 47(5)): what the 36-parameter joint-centre model leaves out.

Each is the physics of the *true* mechanism written as a change of the model's
:class:`~stewart_jax.discrepancy._pss.PSSState`; ``theta = 0`` is the 36-parameter model.
Parameters are per leg (index ``i`` = leg ``i + 1``) unless stated. ``m`` is the number of
poses.
"""

from __future__ import annotations

import jax.numpy as jnp
from jaxtyping import Array, Float

from .._math import euler_angles, rotation_matrix
from .._units import ARCSEC, UM
from ..calibration._problem import CalibrationData
from ..mechanism._pss import _tilted
from ._pss import MODEL_NAME, PSSState
from ._registry import register_effect

T_REF_C = 20.0
"""Reference temperature of ``thermal_expansion`` (°C): the rod lengths of the geometry hold
at this temperature."""

DRIFT_TIME_UNIT_S = 3600.0
"""Drift rates are reported per hour."""


@register_effect(MODEL_NAME, "zero_offset", n_params=6, scale=UM, unit="µm", report_factor=1 / UM)
def zero_offset(theta: Float[Array, "6"], data: CalibrationData, state: PSSState) -> PSSState:
    """Encoder zero not at the zero pose: reading = true stroke + ``c_i`` (mm). Equivalent to
    rod lengths that differ from the zero-pose geometry (the 6 extra parameters of the
    42-parameter model)."""
    return state._replace(offset=state.offset + theta)


@register_effect(MODEL_NAME, "stroke_scale", n_params=6, scale=1e-4, unit="ppm", report_factor=1e6)
def stroke_scale(theta: Float[Array, "6"], data: CalibrationData, state: PSSState) -> PSSState:
    """Lead-screw pitch / encoder scale error: true stroke = ``(1 + k_i)`` · reading
    (``k_i`` dimensionless)."""
    return state._replace(gain=state.gain / (1.0 + theta))


@register_effect(MODEL_NAME, "actuator_tilt", n_params=12, scale=1e-4, unit="µrad", report_factor=1e6)
def actuator_tilt(theta: Float[Array, "12"], data: CalibrationData, state: PSSState) -> PSSState:
    """Slider axes not along the model's: leg i's slider moves along
    ``cos α_i·cos β_i·n_i + cos α_i·sin β_i·u_i − sin α_i·v_i`` with ``(u_i, v_i, n_i)`` the right-handed
    frame of the model's axis ``n_i`` (``Ry(β_i)·Rx(α_i)·e_z`` for the paper's vertical sliders);
    ``theta = [α_1..α_6, β_1..β_6]`` (rad). The lower joint at zero stroke stays at ``Bc_i``."""
    return state._replace(axes=_tilted(state.axes, theta))


@register_effect(
    MODEL_NAME, "backlash", n_params=6, scale=UM, unit="µm", report_factor=1 / UM, requires=("directions",)
)
def backlash(theta: Float[Array, "6"], data: CalibrationData, state: PSSState) -> PSSState:
    """Lost motion of width ``b_i`` (mm): approached from direction ``dir_i = ±1`` the reading
    is offset by ``b_i·dir_i/2`` from the true stroke."""
    return state._replace(offset=state.offset + 0.5 * theta * data.directions)


@register_effect(
    MODEL_NAME,
    "thermal_expansion",
    n_params=6,
    scale=1e-6,
    unit="ppm/K",
    report_factor=1e6,
    requires=("temperature",),
)
def thermal_expansion(theta: Float[Array, "6"], data: CalibrationData, state: PSSState) -> PSSState:
    """Rod lengths change with temperature: ``L_i(T) = L_i·(1 + α_i·(T − 20 °C))``, ``α_i`` in
    1/K (one coefficient per rod: rods of one material share it, but their temperatures need
    not); ``L_i`` the base model's rod length."""
    length0 = (jnp.linalg.norm(state.upper + state.v0 - state.lower, axis=-1) if state.rod_lengths is None
               else state.rod_lengths)
    return state._replace(dlength=state.dlength + length0 * theta * (data.temperature[:, None] - T_REF_C))


@register_effect(
    MODEL_NAME,
    "drift",
    n_params=6,
    scale=UM / DRIFT_TIME_UNIT_S,
    unit="µm/h",
    report_factor=DRIFT_TIME_UNIT_S / UM,
    requires=("time",),
)
def drift(theta: Float[Array, "6"], data: CalibrationData, state: PSSState) -> PSSState:
    """Readings drift linearly during the run: reading = true stroke + ``c_i·t`` (``c_i`` in
    mm/s, ``t`` the ``time`` column)."""
    return state._replace(offset=state.offset + theta * data.time[:, None])


@register_effect(
    MODEL_NAME,
    "tracker_misalignment",
    n_params=6,
    scale=(10 * ARCSEC,) * 3 + (UM,) * 3,
    unit="″,″,″,µm,µm,µm",
    report_factor=(1 / ARCSEC,) * 3 + (1 / UM,) * 3,
    acts_on="measurement",
)
def tracker_misalignment(theta: Float[Array, "6"], data: CalibrationData, state: PSSState) -> PSSState:
    """The instrument frame M is rotated by ``R(ρ)`` (``ρ = theta[:3]``, rad, the Euler
    convention of Wang et al. 2018, eq. 1) and shifted by ``τ = theta[3:]`` (mm) relative to B: a point is
    ``x_B = R(ρ)·x_M + τ``. The measured pose is the platform pose in M, so the true pose is
    ``R = R(ρ)·R'``, ``d + v0 = R(ρ)·(d' + v0) + τ``. Acts on the measurement only: for control
    the targets are already in B."""
    rho = rotation_matrix(theta[:3])
    rot = jnp.einsum("jk,mkl->mjl", rho, rotation_matrix(state.poses[:, 3:]))
    d = (state.poses[:, :3] + state.v0) @ rho.T + theta[3:] - state.v0
    return state._replace(poses=jnp.concatenate([d, euler_angles(rot)], axis=-1))


@register_effect(
    MODEL_NAME,
    "tracker_scale",
    n_params=1,
    scale=1e-4,
    unit="ppm",
    report_factor=1e6,
    acts_on="measurement",
)
def tracker_scale(theta: Float[Array, "1"], data: CalibrationData, state: PSSState) -> PSSState:
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
