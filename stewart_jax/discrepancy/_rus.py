"""The 6-RUS rotary hexapod's calibration model as a discrepancy model, and its candidate effects.

The crank-and-rod leg of Eisele (2019), "Inverse Kinematics of a Stewart Platform", and of
Szufnarowski (2013), "Stewart platform with fixed rotary actuators: a low cost design study"
(:class:`~stewart_jax.mechanism.RUSMechanism`). Observations are the crank readings (rad, 6 per
pose, reported in µrad); the base parameters are the mechanism's (54 or 48); the noise is on the
measured pose and reaches the readings through the mechanism's pose Jacobian. The model wraps the
mechanism: its state holds the mechanism itself, whose leaves an effect may give a per-pose axis
(a rod length that changes with temperature), and the map from crank angle to reading.

Each effect is the physics of the *true* mechanism; ``theta = 0`` is the base model. Parameters
are per leg (index ``i`` = leg ``i + 1``) unless stated; ``m`` is the number of poses.
"""

from __future__ import annotations

from typing import ClassVar, NamedTuple

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._units import ARCSEC, UM
from ..calibration._problem import CalibrationData
from ..mechanism._rus import RUSMechanism
from ._families import check_family, check_noise, register_model_family
from ._pose_noise import AbstractMechanismModel
from ._registry import register_effect
from ._shared_effects import T_REF_C, register_shared

MODEL_NAME = "6-rus"
URAD = 1e-6
"""One microradian in rad."""


class RUSState(NamedTuple):
    """What the effects of the 6-RUS model may change. Shapes for ``m`` poses:

    - ``poses``: ``Float[Array, "m 6"]``, the *true* poses in B (mm, rad); the measured poses
      until a measurement effect maps them.
    - ``mechanism``: the :class:`~stewart_jax.mechanism.RUSMechanism` at the base parameters; a
      leaf may take a per-pose shape ``(m, 6)`` (its inverse kinematics broadcasts).
    - ``gain``, ``offset``: ``Float[Array, "m 6"]``, reading = ``gain · crank angle from zero + offset``.
    """

    poses: Float[Array, "m 6"]
    mechanism: RUSMechanism
    gain: Float[Array, "m 6"]
    offset: Float[Array, "m 6"]

    @property
    def v0(self) -> Float[Array, "3"]:
        return self.mechanism.v0


class RUSModel(AbstractMechanismModel):
    """The 6-RUS model with pose-measurement noise.

    **Fields:**

    - ``mechanism``: the starting :class:`~stewart_jax.mechanism.RUSMechanism`.
    - ``sigma_mm``, ``sigma_rad``: σ of each measured translation (mm) and angle (rad).
    - ``sigma_reading_rad``: σ of each crank reading (rad).
    """

    mechanism: RUSMechanism
    sigma_mm: float | Array
    sigma_rad: float | Array
    sigma_reading_rad: float | Array = 0.0

    name: ClassVar[str] = MODEL_NAME
    output_names: ClassVar[tuple[str, ...]] = tuple(f"crank{i}" for i in range(1, 7))

    @property
    def reading_sigma(self) -> float | Array:
        return self.sigma_reading_rad

    def initial_state(self, base: Float[Array, " n"], data: CalibrationData, control: bool) -> RUSState:
        ones = jnp.ones((data.poses.shape[0], 6))
        return RUSState(data.poses, self.mechanism.with_params(base), ones, 0.0 * ones)

    def finish(self, state: RUSState, data: CalibrationData) -> Float[Array, "m 6"]:
        return state.gain * state.mechanism.solve_inverse_kinematics(state.poses).readings + state.offset


def rus_model(
    mechanism: RUSMechanism, sigma_um: float = 0.1, sigma_arcsec: float = 0.1, sigma_reading_urad: float = 0.0
) -> RUSModel:
    """:class:`RUSModel` starting from the rotary hexapod ``mechanism`` with pose noise σ (µm, ″)
    and optional crank-reading noise (µrad)."""
    check_family(mechanism, RUSMechanism, "rus_model")
    check_noise(sigma_um, sigma_arcsec, sigma_reading_urad, "sigma_reading_urad")
    return RUSModel(mechanism, jnp.asarray(float(sigma_um) * UM), jnp.asarray(float(sigma_arcsec) * ARCSEC),
                    jnp.asarray(float(sigma_reading_urad) * URAD))


register_model_family(RUSMechanism.family, MODEL_NAME, rus_model)


# ---- candidate effects ------------------------------------------------------------------------


@register_effect(MODEL_NAME, "crank_offset", n_params=6, scale=1e-5, unit="µrad", report_factor=1 / URAD)
def crank_offset(theta: Float[Array, "6"], data: CalibrationData, state: RUSState) -> RUSState:
    """Crank-angle encoder offset (a homing error): reading = crank angle from the model's zero +
    ``c_i`` (rad). Identifiable with the 48-parameter set; the 54-parameter set's crank zeros absorb it."""
    return state._replace(offset=state.offset + theta)


@register_effect(MODEL_NAME, "gear_ratio", n_params=6, scale=1e-4, unit="ppm", report_factor=1e6)
def gear_ratio(theta: Float[Array, "6"], data: CalibrationData, state: RUSState) -> RUSState:
    """Gear-ratio error between the encoder and the crank (a motor-side encoder read through a
    gearbox whose ratio differs from the nominal): crank angle from zero = ``(1 + k_i)`` · reading
    (``k_i`` dimensionless)."""
    return state._replace(gain=state.gain / (1.0 + theta))


backlash = register_shared("backlash", MODEL_NAME, "rad")
drift = register_shared("drift", MODEL_NAME, "rad")


@register_effect(MODEL_NAME, "thermal_expansion", n_params=6, scale=1e-6, unit="ppm/K", report_factor=1e6,
                 requires=("temperature",))
def thermal_expansion(theta: Float[Array, "6"], data: CalibrationData, state: RUSState) -> RUSState:
    """Rods change length with temperature: ``s_i(T) = s_i·(1 + α_i·(T − 20 °C))`` (``α_i`` in 1/K):
    the mechanism's rod lengths take a per-pose axis."""
    m = state.mechanism
    rods = m.rod_lengths * (1.0 + theta * (data.temperature[:, None] - T_REF_C))
    return state._replace(mechanism=eqx.tree_at(lambda x: x.rod_lengths, m, rods))


tracker_misalignment = register_shared("tracker_misalignment", MODEL_NAME, "rad")
tracker_scale = register_shared("tracker_scale", MODEL_NAME, "rad")
