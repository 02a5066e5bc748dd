"""The 6-PSS calibration model as a discrepancy model (Wang et al. 2018, "Improved cuckoo
calibration method of space telescope secondary mirror adjusting mechanism", Infrared and Laser
Engineering 47(5), §1: the mechanism, eq. 4: the inverse kinematics, the 36 joint-centre
parameters).

Observations are the encoder readings ``q'`` (6 per pose); the base parameters are the 36
joint centres; the noise is on the measured pose (σ per translation and angle) and reaches the
readings through the kinematic Jacobian.
"""

from __future__ import annotations

from typing import ClassVar, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._math import rotation_matrix
from .._units import ARCSEC, UM
from ..calibration._problem import CalibrationData
from ..mechanism._pss import Geometry, geometry_from_params
from ._families import check_noise, register_model_family
from ._pose_noise import AbstractPoseNoiseModel

MODEL_NAME = "6-pss"
PSS_MODEL_NAME = MODEL_NAME
"""Registry name of the 6-PSS model (its effects are registered under it)."""


class PSSState(NamedTuple):
    """What the effects of the 6-PSS model may change. Shapes for ``m`` poses:

    - ``poses``: ``Float[Array, "m 6"]``, the *true* poses in B (mm, rad); the measured poses
      until a measurement effect maps them.
    - ``upper``, ``lower``: ``Float[Array, "6 3"]``, joint centres ``Ac_i`` (A) and ``Bc_i`` (B).
    - ``v0``: ``Float[Array, "3"]``.
    - ``axes``: ``Float[Array, "6 3"]``, unit slider axes in B (``e_z`` in the base model).
    - ``dlength``: ``Float[Array, "m 6"]``, change of each rod length from ``|Ac + v0 − Bc|``.
    - ``gain``, ``offset``: ``Float[Array, "m 6"]``, reading = ``gain · true stroke + offset``.
    """

    poses: Float[Array, "m 6"]
    upper: Float[Array, "6 3"]
    lower: Float[Array, "6 3"]
    v0: Float[Array, "3"]
    axes: Float[Array, "6 3"]
    dlength: Float[Array, "m 6"]
    gain: Float[Array, "m 6"]
    offset: Float[Array, "m 6"]


def pss_strokes(
    upper: Float[Array, "6 3"],
    lower: Float[Array, "6 3"],
    v0: Float[Array, "3"],
    axes: Float[Array, "6 3"],
    dlength: Float[Array, "m 6"],
    poses: Float[Array, "m 6"],
) -> Float[Array, "m 6"]:
    """True slider strokes of a 6-PSS mechanism with general slider axes ``n_i`` and rod
    lengths ``L_i = |Ac_i + v0 − Bc_i| + dlength``: the root of
    ``|a_i − Bc_i − q·n_i| = L_i`` with the slider below the upper joint.

    NOTE: with ``e = Ac + v0 − Bc`` (zero-pose leg), ``δ = T·Ac − Ac + d`` and ``w = e + δ``,
    the quadratic ``q² − 2q(n·w) + |w|² − L² = 0`` has the root
    ``q = c / (n·w + sqrt((n·w)² − c))`` with ``c = 2e·δ + |δ|² − ΔL(2|e| + ΔL)``: no
    cancellation, exactly 0 at the zero pose, and equal to Wang et al. (2018) eq. 4 for ``n = e_z``,
    ``ΔL = 0``.
    """
    rot = rotation_matrix(poses[:, 3:])
    delta = jnp.einsum("mjk,ik->mij", rot, upper) - upper + poses[:, None, :3]
    e = upper + v0 - lower
    length0 = jnp.linalg.norm(e, axis=-1)
    c = jnp.sum(delta * (2.0 * e + delta), axis=-1) - dlength * (2.0 * length0 + dlength)
    nw = jnp.sum(axes * (e + delta), axis=-1)
    root = jnp.sqrt(jnp.maximum(nw**2 - c, 0.0))
    return c / (nw + root)


class PSSModel(AbstractPoseNoiseModel):
    """The 36-parameter 6-PSS model with pose-measurement noise.

    **Fields:**

    - ``nominal``: ``Float[Array, "36"]``, starting parameters (mm).
    - ``v0``: ``Float[Array, "3"]`` (mm).
    - ``sigma_mm``: σ of each measured translation (mm).
    - ``sigma_rad``: σ of each measured angle (rad).
    - ``sigma_stroke_mm``: σ of each encoder reading (mm); 0 in the paper's setting.

    The whitener is ``L⁻¹`` with ``L Lᵀ = J Σ_P Jᵀ + σ_q² I`` (see
    :class:`~stewart_jax.discrepancy._pose_noise.AbstractPoseNoiseModel`), evaluated at the given
    parameters and the measured poses.
    """

    nominal: Float[Array, "36"]
    v0: Float[Array, "3"]
    sigma_mm: float | Array
    sigma_rad: float | Array
    sigma_stroke_mm: float | Array = 0.0

    name: ClassVar[str] = MODEL_NAME
    output_names: ClassVar[tuple[str, ...]] = tuple(f"leg{i}" for i in range(1, 7))
    report_unit: ClassVar[str] = "µm"
    report_factor: ClassVar[float] = 1.0 / UM

    @property
    def base_initial(self) -> Float[Array, "36"]:
        return self.nominal

    @property
    def base_scale(self) -> Float[Array, "36"]:
        return jnp.full(36, UM)

    def initial_state(self, base: Float[Array, "36"], data: CalibrationData, control: bool) -> PSSState:
        m = data.poses.shape[0]
        zeros = jnp.zeros((m, 6))
        axes = jnp.broadcast_to(jnp.array([0.0, 0.0, 1.0]), (6, 3))
        return PSSState(
            data.poses, base[:18].reshape(6, 3), base[18:].reshape(6, 3), self.v0, axes, zeros, zeros + 1.0, zeros
        )

    def finish(self, state: PSSState, data: CalibrationData) -> Float[Array, "m 6"]:
        s = pss_strokes(state.upper, state.lower, state.v0, state.axes, state.dlength, state.poses)
        return state.gain * s + state.offset

    def pose_jacobians(self, base: Float[Array, "36"], poses: Float[Array, "m 6"]) -> Float[Array, "m 6 6"]:
        """``∂q/∂P`` of the base model at each pose.

        NOTE: the forward-mode derivative of :func:`pss_strokes`, not the analytic
        :func:`~stewart_jax.kinematic_jacobian`: equal to rounding, but the whitened fits are
        ill-conditioned enough (cond ~1e5) that switching moves reported statistics by up to
        ~1e-6 relative, so the published numbers keep this Jacobian (see
        ``tests/test_discrepancy.py`` for the agreement of the two)."""
        state = self.initial_state(base, CalibrationData(poses, poses), False)

        def one(p):
            return pss_strokes(state.upper, state.lower, state.v0, state.axes, state.dlength[:1], p[None])[0]

        return jax.vmap(jax.jacfwd(one))(poses)

    def factors(self, data: CalibrationData) -> dict[str, np.ndarray]:
        """Per leg: its own reading and approach direction; per pose: the six pose components
        (µm and ″), temperature and time."""
        return {"stroke_um": np.asarray(data.strokes) / UM, **self.pose_factors(data)}


def pss_model(
    geometry: Geometry, sigma_um: float = 0.1, sigma_arcsec: float = 0.1, sigma_stroke_um: float = 0.0
) -> PSSModel:
    """:class:`PSSModel` starting from ``geometry`` (a 6-PSS with the paper's 36 parameters) with
    pose noise σ (µm, ″) and optional reading noise (µm)."""
    family = getattr(geometry, "family", type(geometry).__name__)
    if family != Geometry.family:
        raise ValueError(f"pss_model needs a 6-PSS mechanism, got a {family}; model_for(mechanism) picks the "
                         "model of its family")
    if geometry.n_params != 36 or not getattr(geometry, "is_paper_model", True):
        raise ValueError("the 6-PSS discrepancy model is Wang et al. (2018)'s mechanism: vertical sliders, rod "
                         "lengths from the zero pose, the 36 joint-centre parameters; this 6-PSS has "
                         f"{geometry.n_params} parameters{'' if geometry.is_paper_model else ', axes or rod lengths'} "
                         "(its slider tilts and rod lengths are the candidate effects actuator_tilt and zero_offset)")
    check_noise(sigma_um, sigma_arcsec, sigma_stroke_um)
    return PSSModel(
        geometry.params,
        geometry.v0,
        jnp.asarray(float(sigma_um) * UM),
        jnp.asarray(float(sigma_arcsec) * ARCSEC),
        jnp.asarray(float(sigma_stroke_um) * UM),
    )


register_model_family(Geometry.family, MODEL_NAME, pss_model, lambda model, base: geometry_from_params(base, model.v0))
