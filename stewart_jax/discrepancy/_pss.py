"""The 6-PSS calibration model as a discrepancy model (Wang et al. 2018, "Improved cuckoo
calibration method of space telescope secondary mirror adjusting mechanism", Infrared and Laser
Engineering 47(5), §1: the mechanism, eq. 4: the inverse kinematics, the 36 joint-centre
parameters; and the generalised mechanism's 42 and 54 parameters).

Observations are the encoder readings ``q'`` (6 per pose); the base parameters are the
mechanism's calibration parameters (any of its parameter sets); the noise is on the measured pose
(σ per translation and angle) and reaches the readings through the kinematic Jacobian. The
readings are the mechanism's generalised leg,
:func:`~stewart_jax.mechanism._pss.slider_leg`, with what the effects change (slider axes, rod
lengths per pose, the reading's gain and offset) in between.
"""

from __future__ import annotations

from typing import ClassVar, NamedTuple

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._units import ARCSEC, UM
from ..calibration._problem import CalibrationData
from ..mechanism._pss import Geometry, PSSMechanism, rod_lengths, slider_leg_arrays
from ._families import check_family, check_noise, register_model_family
from ._pose_noise import AbstractMechanismModel

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
    - ``rod_lengths``: ``Float[Array, "6"]``, the base model's rod lengths (``|Ac + v0 − Bc|``
      for the paper's 36 parameters).
    """

    poses: Float[Array, "m 6"]
    upper: Float[Array, "6 3"]
    lower: Float[Array, "6 3"]
    v0: Float[Array, "3"]
    axes: Float[Array, "6 3"]
    dlength: Float[Array, "m 6"]
    gain: Float[Array, "m 6"]
    offset: Float[Array, "m 6"]
    rod_lengths: Float[Array, "6"] | None = None


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
    ``|a_i − Bc_i − q·n_i| = L_i`` with the slider below the upper joint — the mechanism's own
    generalised leg (:func:`~stewart_jax.mechanism._pss.slider_leg`, cancellation-free, exactly 0
    at the zero pose, Wang et al. (2018) eq. 4 for ``n = e_z``, ``ΔL = 0``) on poses by legs."""
    return slider_leg_arrays(poses, upper, upper + v0 - lower, axes, dlength).readings


class PSSModel(AbstractMechanismModel):
    """The 6-PSS model with pose-measurement noise, for any of the mechanism's parameter sets.

    **Fields:**

    - ``mechanism``: the starting :class:`~stewart_jax.mechanism.PSSMechanism` (its ``params`` are
      the starting base parameters: 36, 42 or 54; its ``v0`` is not calibrated).
    - ``sigma_mm``: σ of each measured translation (mm).
    - ``sigma_rad``: σ of each measured angle (rad).
    - ``sigma_stroke_mm``: σ of each encoder reading (mm); 0 in the paper's setting.

    The whitener is ``L⁻¹`` with ``L Lᵀ = J Σ_P Jᵀ + σ_q² I`` (see
    :class:`~stewart_jax.discrepancy._pose_noise.AbstractPoseNoiseModel`), evaluated at the given
    parameters and the measured poses.
    """

    mechanism: PSSMechanism
    sigma_mm: float | Array
    sigma_rad: float | Array
    sigma_stroke_mm: float | Array = 0.0

    name: ClassVar[str] = MODEL_NAME
    output_names: ClassVar[tuple[str, ...]] = tuple(f"leg{i}" for i in range(1, 7))

    def initial_state(self, base: Float[Array, " n"], data: CalibrationData, control: bool) -> PSSState:
        g = self.mechanism.with_params(base)
        zeros = jnp.zeros((data.poses.shape[0], 6))
        lengths = rod_lengths(g)
        dlength = zeros  # the 36-parameter model's rods follow the joints (ΔL = 0 exactly)
        if g.lengths is not None:  # given rod lengths differ from the zero-pose legs
            dlength = zeros + (g.lengths - jnp.linalg.norm(g.upper + g.v0 - g.lower, axis=-1))
        return PSSState(data.poses, g.upper, g.lower, g.v0, g.slider_axes, dlength, zeros + 1.0, zeros, lengths)

    def finish(self, state: PSSState, data: CalibrationData) -> Float[Array, "m 6"]:
        s = pss_strokes(state.upper, state.lower, state.v0, state.axes, state.dlength, state.poses)
        return state.gain * s + state.offset

    def pose_jacobians(self, base: Float[Array, " n"], poses: Float[Array, "m 6"]) -> Float[Array, "m 6 6"]:
        """``∂q/∂P`` of the base model at each pose.

        NOTE: the forward-mode derivative of :func:`pss_strokes`, not the analytic
        closed-form ``ik_and_jacobian`` of the mechanism: equal to rounding, but the whitened fits are
        ill-conditioned enough (cond ~1e5) that switching moves reported statistics by up to
        ~1e-6 relative, so the published numbers keep this Jacobian (see
        ``tests/test_discrepancy.py`` for the agreement of the two)."""
        state = self.initial_state(base, CalibrationData(poses, poses), False)

        def one(p):
            return pss_strokes(state.upper, state.lower, state.v0, state.axes, state.dlength[:1], p[None])[0]

        return jax.vmap(jax.jacfwd(one))(poses)


def pss_model(
    geometry: Geometry, sigma_um: float = 0.1, sigma_arcsec: float = 0.1, sigma_reading_um: float = 0.0
) -> PSSModel:
    """:class:`PSSModel` starting from ``geometry`` (a 6-PSS, any parameter set) with pose noise σ
    (µm, ″) and optional reading noise (µm)."""
    check_family(geometry, PSSMechanism, "pss_model")
    check_noise(sigma_um, sigma_arcsec, sigma_reading_um)
    return PSSModel(
        geometry,
        jnp.asarray(float(sigma_um) * UM),
        jnp.asarray(float(sigma_arcsec) * ARCSEC),
        jnp.asarray(float(sigma_reading_um) * UM),
    )


register_model_family(Geometry.family, MODEL_NAME, pss_model)
