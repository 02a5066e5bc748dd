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

from .._units import UM
from ..calibration._problem import CalibrationData
from ..mechanism._pss import _tilted
from ._pss import MODEL_NAME, PSSState
from ._registry import register_effect
from ._shared_effects import T_REF_C, register_shared


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


backlash = register_shared("backlash", MODEL_NAME, "mm")


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


drift = register_shared("drift", MODEL_NAME, "mm")
tracker_misalignment = register_shared("tracker_misalignment", MODEL_NAME, "mm")
tracker_scale = register_shared("tracker_scale", MODEL_NAME, "mm")
