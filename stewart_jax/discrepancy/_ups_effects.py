"""The candidate effects of the 6-UPS strut model: what the 42-parameter strut model leaves out.

The strut hexapods that position telescope optics (and the Stewart platform in the FAST feed
cabin of Yin, Jiang, Chen, Yao, "Dynamic modeling of a cable-driven parallel robot with a Stewart
platform for use in FAST") have the same leg as Wang et al. 2018, "Improved cuckoo calibration
method of space telescope secondary mirror adjusting mechanism", Infrared and Laser Engineering
47(5), eq. 2, with a length-changing strut in place of the slider and fixed rod. Each effect is
the physics of the *true* strut written as a change of the model's
:class:`~stewart_jax.discrepancy._ups.UPSState`; ``theta = 0`` is the 42-parameter model. Parameters
are per strut (index ``i`` = strut ``i + 1``) unless stated; ``m`` is the number of poses.

Effects are registered per model, so the 6-PSS's slider effects (``actuator_tilt``) are not
offered for struts; those whose physics does not depend on the leg (``backlash``, ``drift``,
``tracker_misalignment``, ``tracker_scale``) are the shared definitions of ``_shared_effects.py``. There
is no ``zero_offset``: the zero-reading lengths ``lengths0`` are base parameters of the strut
model already.
"""

from __future__ import annotations

import jax.numpy as jnp
from jaxtyping import Array, Float

from .._units import UM
from ..calibration._problem import CalibrationData
from ._registry import register_effect
from ._shared_effects import T_REF_C, register_shared
from ._ups import MODEL_NAME, PAYLOAD_WRENCHES, UPSState, gravity_axial_loads


@register_effect(MODEL_NAME, "strut_scale", n_params=6, scale=1e-4, unit="ppm", report_factor=1e6)
def strut_scale(theta: Float[Array, "6"], data: CalibrationData, state: UPSState) -> UPSState:
    """Encoder / ball-screw scale error: true length change = ``(1 + k_i)`` · reading
    (``k_i`` dimensionless)."""
    return state._replace(gain=state.gain / (1.0 + theta))


@register_effect(
    MODEL_NAME,
    "thermal_expansion",
    n_params=6,
    scale=1e-6,
    unit="ppm/K",
    report_factor=1e6,
    requires=("temperature",),
)
def thermal_expansion(theta: Float[Array, "6"], data: CalibrationData, state: UPSState) -> UPSState:
    """Struts change length with temperature: ``L_i(T) = L_i·(1 + α_i·(T − 20 °C))`` for the whole
    strut, ``L_i = lengths0_i + true length change`` (``α_i`` in 1/K, one per strut): the
    zero-reading length grows by ``lengths0_i·α_i·ΔT`` and the extension by the factor
    ``1 + α_i·ΔT``."""
    grow = theta * (data.temperature[:, None] - T_REF_C)
    return state._replace(dlength=state.dlength + state.lengths0 * grow, gain=state.gain / (1.0 + grow))


@register_effect(
    MODEL_NAME,
    "gravity_sag",
    n_params=11,
    scale=(UM,) * 8 + (10 * UM,) * 3,
    unit=",".join(("µm",) * 8 + ("µm·m",) * 3),
    report_factor=(1 / UM,) * 11,
)
def gravity_sag(theta: Float[Array, "11"], data: CalibrationData, state: UPSState) -> UPSState:
    """Load-dependent strut length: each strut stretches by its axial compliance times its axial
    force from the payload's weight (statics at the true pose, tension > 0). The weight ``W``
    acts at the payload's centre of mass ``r_c`` (in A) along the gravity direction ``ĝ`` in B
    (``(0, −cos e, −sin e)`` at a telescope elevation ``e``; ``−z`` at the zenith), i.e. the wrench
    ``W·[ĝ; (T·r_c) × ĝ]`` about A's origin; the strut forces are linear in it.

    Parameters (mm; the moment terms mm·m): ``theta[:6] = c_i``, strut ``i``'s stretch under a
    tension equal to the whole weight, times the weight's −z component at A's origin (the
    per-strut compliance: a weight at A's origin along −z is ``theta[6:] = 0``);
    ``theta[6:8]`` the common compliance times the weight's x and y components (a tilted gravity
    direction: an elevation below 90°); ``theta[8:11]`` the common compliance times the weight's
    moment about A's origin, per metre of arm (a centre of mass off A's origin). Struts of one
    design share their compliance, so the off-axis terms carry one compliance for all six. The
    pose-independent part of every load is absorbed by ``lengths0``; what remains is the loads'
    change over the travel."""
    loads = jnp.stack([gravity_axial_loads(state.platform, state.base, state.v0, state.poses, jnp.asarray(w))
                       for w in PAYLOAD_WRENCHES], axis=-1)
    dl = theta[:6] * loads[..., 0] + jnp.einsum("msw,w->ms", loads[..., 1:], theta[6:])
    return state._replace(dlength=state.dlength + dl)


backlash = register_shared("backlash", MODEL_NAME, "mm")
drift = register_shared("drift", MODEL_NAME, "mm")
tracker_misalignment = register_shared("tracker_misalignment", MODEL_NAME, "mm")
tracker_scale = register_shared("tracker_scale", MODEL_NAME, "mm")
