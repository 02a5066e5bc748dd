"""The 6-UPS strut hexapod's calibration model as a discrepancy model.

The strut model is the strut-length form of the leg of Wang et al. 2018, "Improved cuckoo
calibration method of space telescope secondary mirror adjusting mechanism", Infrared and Laser
Engineering 47(5), eq. 2: strut ``i`` joins ``base_i`` (in B) to ``platform_i`` (in A), its length
is ``l_i = |T·platform_i + d + v0 − base_i|`` and the reading is ``q_i = l_i − lengths0_i``
(:class:`~stewart_jax.mechanism.UPSMechanism`). The same hexapod carries the feed of FAST (Yin,
Jiang, Chen, Yao, "Dynamic modeling of a cable-driven parallel robot with a Stewart platform for
use in FAST").

Observations are the strut readings (6 per pose); the base parameters are the 42 of
``UPSMechanism.params`` (platform joints, base joints, zero-reading lengths); the noise is on the
measured pose (σ per translation and angle) and reaches the readings through the pose
Jacobian, plus optional reading noise. Its candidate effects are in ``_ups_effects.py``.
"""

from __future__ import annotations

from typing import ClassVar, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._linalg import solve
from .._math import rotation_matrix
from .._units import ARCSEC, UM
from ..calibration._problem import CalibrationData
from ..mechanism._ups import UPSMechanism
from ._families import check_family, check_noise, register_model_family
from ._pose_noise import AbstractMechanismModel

MODEL_NAME = "6-ups"
UPS_MODEL_NAME = MODEL_NAME
"""Registry name of the 6-UPS model (its effects are registered under it)."""


class UPSState(NamedTuple):
    """What the effects of the 6-UPS model may change. Shapes for ``m`` poses:

    - ``poses``: ``Float[Array, "m 6"]``, the *true* poses in B (mm, rad); the measured poses
      until a measurement effect maps them.
    - ``platform``, ``base``: ``Float[Array, "6 3"]``, joint centres in A and in B (mm).
    - ``v0``: ``Float[Array, "3"]`` (mm).
    - ``lengths0``: ``Float[Array, "6"]``, strut lengths at zero reading (mm).
    - ``dlength``: ``Float[Array, "m 6"]``, change of each strut's length at zero reading from
      ``lengths0`` (mm): the true strut length is ``lengths0 + dlength + true length change``.
    - ``gain``, ``offset``: ``Float[Array, "m 6"]``, reading = ``gain · true length change + offset``.
    """

    poses: Float[Array, "m 6"]
    platform: Float[Array, "6 3"]
    base: Float[Array, "6 3"]
    v0: Float[Array, "3"]
    lengths0: Float[Array, "6"]
    dlength: Float[Array, "m 6"]
    gain: Float[Array, "m 6"]
    offset: Float[Array, "m 6"]


def ups_readings(state: UPSState) -> Float[Array, "m 6"]:
    """The strut readings of the mechanism described by ``state`` (mm).

    The true length change is ``q − dlength`` with ``q = l − lengths0`` the reading of the
    strut mechanism's inverse kinematics (evaluated there without cancellation:
    ``q = δ·(2e + δ) / (l + |e|) + (|e| − lengths0)``), so a reading of a few mm on a metre-long
    strut keeps full relative precision; ``dlength`` is a small correction added to it."""
    mechanism = UPSMechanism(state.base, state.platform, state.v0, state.lengths0)
    q = mechanism.solve_inverse_kinematics(state.poses).readings
    return state.gain * (q - state.dlength) + state.offset


def gravity_axial_loads(
    platform: Float[Array, "6 3"], base: Float[Array, "6 3"], v0: Float[Array, "3"], poses: Float[Array, "m 6"],
    wrench: Float[Array, "6"] | None = None,
) -> Float[Array, "m 6"]:
    """Axial force in each strut (tension > 0) per unit of a load ``wrench`` on the platform,
    ``[F; M]`` in B's axes with the moment about A's origin (default ``[0, 0, −1, 0, 0, 0]``: a
    payload's unit weight acting at A's origin along −z of B; dimensionless).

    With ``u_i`` the unit vector of strut ``i`` from its base joint to its platform joint and
    ``r_i = T·platform_i`` the platform joint relative to A's origin (B's axes), strut tension
    ``t_i`` pulls the platform with ``−t_i u_i``; the platform's equilibrium (force, and moment
    about A's origin) is ``Σ t_i [u_i; r_i × u_i] = wrench``, six equations for the six
    tensions."""
    rot = rotation_matrix(poses[:, 3:])
    r = jnp.einsum("mjk,ik->mij", rot, platform)
    strut = r + poses[:, None, :3] + v0 - base
    u = strut / jnp.linalg.norm(strut, axis=-1, keepdims=True)
    g = jnp.concatenate([u, jnp.cross(r, u)], axis=-1)  # (m, strut, 6): the columns of the statics matrix
    wrench = jnp.array([0.0, 0.0, -1.0, 0.0, 0.0, 0.0]) if wrench is None else wrench
    return solve(jnp.swapaxes(g, -1, -2), jnp.broadcast_to(wrench, poses.shape))  # not LAPACK: see stewart_jax._linalg


PAYLOAD_WRENCHES = (
    (0.0, 0.0, -1.0, 0.0, 0.0, 0.0),
    (1.0, 0.0, 0.0, 0.0, 0.0, 0.0),
    (0.0, 1.0, 0.0, 0.0, 0.0, 0.0),
    (0.0, 0.0, 0.0, 1000.0, 0.0, 0.0),
    (0.0, 0.0, 0.0, 0.0, 1000.0, 0.0),
    (0.0, 0.0, 0.0, 0.0, 0.0, 1000.0),
)
"""The load wrenches of ``gravity_sag``: a unit weight along −z at A's origin, unit forces along x
and y, unit moments about x, y, z (one weight × 1 m, in weight·mm)."""


# NOTE: the report's derived errors and factors are evaluated outside the fits; compiled, they
# cost one small compile each instead of one per primitive of an eager evaluation.
_gravity_axial_loads = jax.jit(gravity_axial_loads)


class UPSModel(AbstractMechanismModel):
    """The 42-parameter 6-UPS model with pose-measurement noise.

    **Fields:**

    - ``mechanism``: the starting :class:`~stewart_jax.mechanism.UPSMechanism` (its ``params`` are
      the starting base parameters; its ``v0`` is not calibrated).
    - ``sigma_mm``: σ of each measured translation (mm).
    - ``sigma_rad``: σ of each measured angle (rad).
    - ``sigma_stroke_mm``: σ of each strut reading (mm).

    There is no ``zero_offset`` effect: the zero-reading lengths ``lengths0`` are base
    parameters already.

    NOTE: as for the 6-PSS model, the residual of one pose, ``e = q' − IK(P')``, is driven by the
    pose noise ε through ``e ≈ −J ε`` (``J = ∂q/∂P``, here the strut mechanism's analytic
    Jacobian), so its covariance is ``J Σ_P Jᵀ + σ_q² I``; the whitener is ``L⁻¹`` with ``L Lᵀ``
    that covariance at the given parameters and the measured poses.
    """

    mechanism: UPSMechanism
    sigma_mm: float | Array
    sigma_rad: float | Array
    sigma_stroke_mm: float | Array = 0.0

    name: ClassVar[str] = MODEL_NAME
    output_names: ClassVar[tuple[str, ...]] = tuple(f"strut{i}" for i in range(1, 7))

    def initial_state(self, base: Float[Array, "42"], data: CalibrationData, control: bool) -> UPSState:
        m = self.mechanism.with_params(base)
        zeros = jnp.zeros((data.poses.shape[0], 6))
        return UPSState(data.poses, m.platform, m.base, m.v0, m.lengths0, zeros, zeros + 1.0, zeros)

    def finish(self, state: UPSState, data: CalibrationData) -> Float[Array, "m 6"]:
        return ups_readings(state)

    def factors(self, data: CalibrationData) -> dict[str, np.ndarray]:
        """Per strut: its own reading, the axial load a payload at A's origin puts on it (per
        unit weight, the factor of ``gravity_sag``) and its approach direction; per pose: the
        six pose components (µm and ″), temperature and time."""
        mech = self.mechanism
        return {
            "stroke_um": np.asarray(data.readings) / UM,
            "axial_load": np.asarray(_gravity_axial_loads(mech.platform, mech.base, mech.v0, data.poses)),
            **self.pose_factors(data),
        }


def ups_model(
    mechanism: UPSMechanism, sigma_um: float = 0.1, sigma_arcsec: float = 0.1, sigma_reading_um: float = 0.0
) -> UPSModel:
    """:class:`UPSModel` starting from the strut hexapod ``mechanism`` with pose noise σ (µm, ″)
    and optional reading noise (µm)."""
    check_family(mechanism, UPSMechanism, "ups_model")
    check_noise(sigma_um, sigma_arcsec, sigma_reading_um)
    return UPSModel(
        mechanism,
        jnp.asarray(float(sigma_um) * UM),
        jnp.asarray(float(sigma_arcsec) * ARCSEC),
        jnp.asarray(float(sigma_reading_um) * UM),
    )


register_model_family(UPSMechanism.family, MODEL_NAME, ups_model)
