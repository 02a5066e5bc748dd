"""What the hexapod discrepancy models share: readings of six actuators per measured pose, with
the noise on the measured pose (σ per translation and angle) reaching the readings through the
kinematic Jacobian, plus optional reading noise.

The residual of one pose, ``e = q' − IK(P')``, is driven by the pose noise ε through
``e ≈ −J ε`` (``J = ∂q/∂P``), so its covariance is ``J Σ_P Jᵀ + σ_q² I`` — correlated across the
six legs and varying with the pose.

:class:`AbstractMechanismModel` wraps a mechanism of any family and any parameter set: the base
parameters are the mechanism's ``params`` (scaled by their units: 1 µm per length, 1 µrad per
angle), the prediction is the family's own leg function, the pose Jacobian the mechanism's, and the
readings are reported in µm (linear) or µrad (angular). A family's model (6-PSS: the mechanism of
Wang et al. 2018, "Improved cuckoo calibration method of space telescope secondary mirror adjusting
mechanism", Infrared and Laser Engineering 47(5); 6-UPS strut hexapods; 6-RUS rotary hexapods)
adds only its state — what its effects may change — and its effects.
"""

from __future__ import annotations

import abc
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._linalg import cholesky, lower_inverse
from .._units import ARCSEC, COMPONENTS, UM, ascii_unit, report_factor, report_unit
from ..calibration._problem import CalibrationData
from ..mechanism._abstract import AbstractMechanism
from ._registry import AbstractDiscrepancyModel

CONDITION_NAMES = ("directions", "temperature", "time")
"""The optional per-pose data columns an effect may require."""


class AbstractPoseNoiseModel(AbstractDiscrepancyModel):
    """A six-actuator model whose data are :class:`~stewart_jax.calibration.CalibrationData` and
    whose noise is on the measured pose. Subclasses have the fields ``sigma_mm`` and ``sigma_rad``
    and a reading noise :attr:`reading_sigma` (default: the field ``sigma_stroke_mm``), and
    implement :meth:`pose_jacobians`."""

    @property
    def reading_sigma(self) -> float | Array:
        """σ of each actuator reading, in the reading's unit (mm, or rad for a crank)."""
        return self.sigma_stroke_mm

    @abc.abstractmethod
    def pose_jacobians(self, base: Float[Array, " p"], poses: Float[Array, "m 6"]) -> Float[Array, "m 6 6"]:
        """``∂q/∂P`` of the base model at each pose."""

    def observed(self, data: CalibrationData) -> Float[Array, "m 6"]:
        return data.readings

    def noise_covariance(self, base: Float[Array, " p"], data: CalibrationData) -> Float[Array, "m 6 6"]:
        """``J Σ_P Jᵀ + σ_q² I`` per pose (the reading unit squared)."""
        var = jnp.concatenate([jnp.full(3, self.sigma_mm**2), jnp.full(3, self.sigma_rad**2)])
        jac = self.pose_jacobians(base, data.poses)
        cov = jnp.einsum("mik,k,mjk->mij", jac, var, jac)
        return cov + self.reading_sigma**2 * jnp.eye(6)

    def whitener(self, base: Float[Array, " p"], data: CalibrationData) -> Float[Array, "m 6 6"]:
        # element-wise, not LAPACK: see the NOTE of stewart_jax._linalg (a batched LAPACK call can
        # deadlock XLA's CPU thread pool with jaxlib 0.10)
        return lower_inverse(cholesky(self.noise_covariance(base, data)))

    def derived_errors(
        self, base: Float[Array, " p"], data: CalibrationData, residuals: np.ndarray
    ) -> dict[str, np.ndarray]:
        """Pose errors ``δP = J⁻¹·e`` (µm, ″): to first order, how far the pose the model
        predicts for the readings lies from the measured pose — the control error the
        residual implies."""
        jac = np.asarray(self.pose_jacobians(base, data.poses))
        dp = np.linalg.solve(jac, np.asarray(residuals)[..., None])[..., 0]
        # NOTE: × (1/UM) rather than error_in_report_units' ÷ UM: the published reports
        # round the same way as before (the two differ in the last bit).
        units = ("µm",) * 3 + ("″",) * 3
        scale = np.array([1 / UM] * 3 + [1 / ARCSEC] * 3)
        return {f"{n}_{u}": dp[:, k] * scale[k] for k, (n, u) in enumerate(zip(COMPONENTS, units, strict=True))}

    def columns(self, data: CalibrationData) -> frozenset[str]:
        return frozenset(name for name in CONDITION_NAMES if getattr(data, name) is not None)

    def n_rows(self, data: CalibrationData) -> int:
        return data.n_poses

    def take(self, data: CalibrationData, index) -> CalibrationData:
        return data.take(index)

    def pose_factors(self, data: CalibrationData) -> dict[str, np.ndarray]:
        """Per leg its approach direction; per pose the six pose components (µm and ″),
        temperature and time — each ``(m, 6)``. A model's ``factors`` adds its own."""
        m = data.n_poses
        out: dict[str, np.ndarray] = {}
        p = np.asarray(data.poses)
        for i, c in enumerate(("x_um", "y_um", "z_um")):
            out[c] = np.broadcast_to(p[:, i : i + 1] / UM, (m, 6))
        for i, c in enumerate(("rx_arcsec", "ry_arcsec", "rz_arcsec")):
            out[c] = np.broadcast_to(p[:, 3 + i : 4 + i] / ARCSEC, (m, 6))
        if data.directions is not None:
            out["direction"] = np.asarray(data.directions)
        if data.temperature is not None:
            out["temperature_C"] = np.broadcast_to(np.asarray(data.temperature)[:, None], (m, 6))
        if data.time is not None:
            out["time_s"] = np.broadcast_to(np.asarray(data.time)[:, None], (m, 6))
        return out


@eqx.filter_jit
def _mechanism_pose_jacobians(mechanism: AbstractMechanism, base: Float[Array, " p"], poses: Float[Array, "m 6"]):
    return mechanism.with_params(base).ik_and_jacobian(poses)[2]


class AbstractMechanismModel(AbstractPoseNoiseModel):
    """The discrepancy model of a mechanism, any family and any parameter set.

    Subclasses have the field ``mechanism`` (the starting mechanism: its ``params`` are the
    starting base parameters; what is not calibrated, e.g. ``v0``, is kept) and the noise fields,
    and define the state their effects change (``initial_state``) and the readings of a state
    (``finish``), through the family's own leg function. The base scale is 1 µm per length
    parameter and 1 µrad per angle (in each parameter's unit); readings are reported in µm for a
    linear family and µrad for a rotary one; the pose Jacobian is the mechanism's
    (:meth:`~stewart_jax.mechanism.AbstractMechanism.ik_and_jacobian`).
    """

    open_search: ClassVar[bool] = True

    mechanism: eqx.AbstractVar[AbstractMechanism]

    @property
    def reading_unit(self) -> str:
        return self.mechanism.reading_unit

    @property
    def base_names(self) -> tuple[str, ...]:
        return self.mechanism.param_names

    @property
    def base_initial(self) -> Float[Array, " p"]:
        return self.mechanism.params

    @property
    def base_scale(self) -> Float[Array, " p"]:
        return jnp.asarray(self.mechanism.natural_scales(UM))

    @property
    def report_unit(self) -> str:  # type: ignore[override]
        return report_unit(self.mechanism.reading_unit)

    @property
    def report_factor(self) -> float:  # type: ignore[override]
        return 1.0 / UM if self.mechanism.reading_unit == "mm" else report_factor(self.mechanism.reading_unit)

    def pose_jacobians(self, base: Float[Array, " p"], poses: Float[Array, "m 6"]) -> Float[Array, "m 6 6"]:
        """``∂q/∂P`` of the base model at each pose (the mechanism's pose Jacobian)."""
        return _mechanism_pose_jacobians(self.mechanism, base, poses)

    def reading_factor_name(self) -> str:
        """The factor of a leg's own reading: ``stroke_um`` (linear) or ``reading_urad`` (angular)."""
        unit = ascii_unit(self.report_unit)
        return f"stroke_{unit}" if self.mechanism.reading_unit == "mm" else f"reading_{unit}"

    def factors(self, data: CalibrationData) -> dict[str, np.ndarray]:
        """Per leg: its own reading (µm or µrad) and approach direction; per pose: the six pose
        components (µm and ″), temperature and time."""
        q = np.asarray(data.readings)
        q = q / UM if self.mechanism.reading_unit == "mm" else q * self.report_factor
        return {self.reading_factor_name(): q, **self.pose_factors(data)}
