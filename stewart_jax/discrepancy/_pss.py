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
from .._units import ARCSEC, COMPONENTS, UM
from ..calibration._problem import CalibrationData
from ..mechanism._pss import Geometry, geometry_from_params
from ._registry import AbstractDiscrepancyModel

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


class PSSModel(AbstractDiscrepancyModel):
    """The 36-parameter 6-PSS model with pose-measurement noise.

    **Fields:**

    - ``nominal``: ``Float[Array, "36"]``, starting parameters (mm).
    - ``v0``: ``Float[Array, "3"]`` (mm).
    - ``sigma_mm``: σ of each measured translation (mm).
    - ``sigma_rad``: σ of each measured angle (rad).
    - ``sigma_stroke_mm``: σ of each encoder reading (mm); 0 in the paper's setting.

    NOTE: the residual of one pose, ``e = q' − IK(P')``, is driven by the pose noise ε through
    ``e ≈ −J ε`` (``J = ∂q/∂P``), so its covariance is ``J Σ_P Jᵀ + σ_q² I`` — correlated across
    the six legs and varying with the pose. The whitener is ``L⁻¹`` with ``L Lᵀ`` that
    covariance, evaluated at the given parameters and the measured poses.
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

    def observed(self, data: CalibrationData) -> Float[Array, "m 6"]:
        return data.strokes

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
        """``∂q/∂P`` of the base model at each pose."""
        state = self.initial_state(base, CalibrationData(poses, poses), False)

        def one(p):
            return pss_strokes(state.upper, state.lower, state.v0, state.axes, state.dlength[:1], p[None])[0]

        return jax.vmap(jax.jacfwd(one))(poses)

    def noise_covariance(self, base: Float[Array, "36"], data: CalibrationData) -> Float[Array, "m 6 6"]:
        """``J Σ_P Jᵀ + σ_q² I`` per pose (mm²): the calibration package's
        :func:`~stewart_jax.stroke_noise_covariance` plus the reading noise.

        NOTE: ``J`` here is the forward-mode derivative of :func:`pss_strokes`, not the analytic
        :func:`~stewart_jax.kinematic_jacobian` that ``stroke_noise_covariance`` uses: equal to
        rounding, but the whitened fits are ill-conditioned enough (cond ~1e5) that switching
        moves reported statistics by up to ~1e-6 relative, so the published numbers keep
        this Jacobian (see ``tests/test_discrepancy.py`` for the agreement of the two)."""
        var = jnp.concatenate([jnp.full(3, self.sigma_mm**2), jnp.full(3, self.sigma_rad**2)])
        jac = self.pose_jacobians(base, data.poses)
        cov = jnp.einsum("mik,k,mjk->mij", jac, var, jac)
        return cov + self.sigma_stroke_mm**2 * jnp.eye(6)

    def whitener(self, base: Float[Array, "36"], data: CalibrationData) -> Float[Array, "m 6 6"]:
        chol = jnp.linalg.cholesky(self.noise_covariance(base, data))
        return jax.vmap(lambda c: jax.scipy.linalg.solve_triangular(c, jnp.eye(6), lower=True))(chol)

    def derived_errors(
        self, base: Float[Array, "36"], data: CalibrationData, residuals: np.ndarray
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
        return frozenset(
            name for name in ("directions", "temperature", "time") if getattr(data, name) is not None
        )

    def n_rows(self, data: CalibrationData) -> int:
        return data.n_poses

    def take(self, data: CalibrationData, index) -> CalibrationData:
        return data.take(index)

    def factors(self, data: CalibrationData) -> dict[str, np.ndarray]:
        """Per leg: its own reading and approach direction; per pose: the six pose components
        (µm and ″), temperature and time."""
        m = data.n_poses
        out: dict[str, np.ndarray] = {"stroke_um": np.asarray(data.strokes) / UM}
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


def pss_model(
    geometry: Geometry, sigma_um: float = 0.1, sigma_arcsec: float = 0.1, sigma_stroke_um: float = 0.0
) -> PSSModel:
    """:class:`PSSModel` starting from ``geometry`` with pose noise σ (µm, ″) and optional
    reading noise (µm)."""
    for name, s in (("sigma_um", sigma_um), ("sigma_arcsec", sigma_arcsec), ("sigma_stroke_um", sigma_stroke_um)):
        if not (np.isfinite(s) and s >= 0):
            raise ValueError(f"{name} must be a finite number ≥ 0, got {s}")
    if sigma_stroke_um == 0 and (sigma_um == 0 or sigma_arcsec == 0):
        raise ValueError(
            "the stroke-residual covariance J·Σ·Jᵀ is singular unless both pose sigmas are > 0 "
            f"(got sigma_um={sigma_um}, sigma_arcsec={sigma_arcsec}); give both, or sigma_stroke_um > 0"
        )
    return PSSModel(
        geometry.params,
        geometry.v0,
        jnp.asarray(float(sigma_um) * UM),
        jnp.asarray(float(sigma_arcsec) * ARCSEC),
        jnp.asarray(float(sigma_stroke_um) * UM),
    )


def save_fitted_model(fitted, path) -> None:
    """Write a fitted (augmented) 6-PSS model as JSON: the 36 parameters and ``v0`` (mm), the
    noise model, and each effect's name and parameters (library units: mm, rad, 1/K, mm/s)."""
    import json

    m = fitted.model
    out = {
        "model": MODEL_NAME,
        "units": "mm",
        "params": np.asarray(fitted.base).tolist(),
        "v0": np.asarray(m.v0).tolist(),
        "sigma_um": float(m.sigma_mm) / UM,
        "sigma_arcsec": float(m.sigma_rad) / ARCSEC,
        "sigma_stroke_um": float(m.sigma_stroke_mm) / UM,
        "effects": [
            {"effect": e.name, "params": np.asarray(t).tolist(), "report_params": r["params"], "report_unit": e.unit}
            for e, t, r in zip(fitted.effects, fitted.thetas, fitted.effect_report(), strict=True)
        ],
    }
    with open(path, "w") as f:
        json.dump(out, f, indent=2)
        f.write("\n")


def load_fitted_model(path):
    """Inverse of :func:`save_fitted_model`: a :class:`~stewart_jax.discrepancy.FittedModel`
    whose :meth:`commanded` gives the readings to command for target poses."""
    import json

    from ._registry import get_effect
    from ._report import FittedModel

    with open(path) as f:
        d = json.load(f)
    if d.get("model") != MODEL_NAME:
        raise ValueError(f"{path}: not a {MODEL_NAME} model file (model={d.get('model')!r})")
    g = geometry_from_params(np.asarray(d["params"], dtype=np.float64), d.get("v0", (0.0, 0.0, 0.0)))
    model = pss_model(g, d.get("sigma_um", 0.1), d.get("sigma_arcsec", 0.1), d.get("sigma_stroke_um", 0.0))
    effects = tuple(get_effect(MODEL_NAME, e["effect"]) for e in d.get("effects", []))
    thetas = tuple(jnp.asarray(e["params"], dtype=jnp.float64) for e in d.get("effects", []))
    for e, t in zip(effects, thetas, strict=True):
        if t.shape != (e.n_params,):
            raise ValueError(f"{path}: effect {e.name!r} needs {e.n_params} parameters, got {t.shape}")
    return FittedModel(model, effects, g.params, thetas)
