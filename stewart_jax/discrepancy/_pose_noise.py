"""What the hexapod discrepancy models share: readings of six actuators per measured pose, with
the noise on the measured pose (σ per translation and angle) reaching the readings through the
kinematic Jacobian, plus optional reading noise.

The residual of one pose, ``e = q' − IK(P')``, is driven by the pose noise ε through
``e ≈ −J ε`` (``J = ∂q/∂P``), so its covariance is ``J Σ_P Jᵀ + σ_q² I`` — correlated across the
six legs and varying with the pose. A family's model (6-PSS: the mechanism of Wang et al. 2018,
"Improved cuckoo calibration method of space telescope secondary mirror adjusting mechanism",
Infrared and Laser Engineering 47(5); 6-UPS strut hexapods) supplies ``pose_jacobians`` and its
own state, effects and factors.
"""

from __future__ import annotations

import abc

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._linalg import cholesky, lower_inverse
from .._units import ARCSEC, COMPONENTS, UM
from ..calibration._problem import CalibrationData
from ._registry import AbstractDiscrepancyModel

CONDITION_NAMES = ("directions", "temperature", "time")
"""The optional per-pose data columns an effect may require."""


class AbstractPoseNoiseModel(AbstractDiscrepancyModel):
    """A six-actuator model whose data are :class:`~stewart_jax.calibration.CalibrationData` and
    whose noise is on the measured pose. Subclasses have the fields ``sigma_mm``, ``sigma_rad`` and
    ``sigma_stroke_mm`` and implement :meth:`pose_jacobians`."""

    @abc.abstractmethod
    def pose_jacobians(self, base: Float[Array, " p"], poses: Float[Array, "m 6"]) -> Float[Array, "m 6 6"]:
        """``∂q/∂P`` of the base model at each pose."""

    def observed(self, data: CalibrationData) -> Float[Array, "m 6"]:
        return data.strokes

    def noise_covariance(self, base: Float[Array, " p"], data: CalibrationData) -> Float[Array, "m 6 6"]:
        """``J Σ_P Jᵀ + σ_q² I`` per pose (mm²)."""
        var = jnp.concatenate([jnp.full(3, self.sigma_mm**2), jnp.full(3, self.sigma_rad**2)])
        jac = self.pose_jacobians(base, data.poses)
        cov = jnp.einsum("mik,k,mjk->mij", jac, var, jac)
        return cov + self.sigma_stroke_mm**2 * jnp.eye(6)

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
