"""The 36-parameter calibration model and the control-error criterion.

Wang H., Cao X. et al., Infrared and Laser Engineering 47(5), 2018, §1.2: stroke residual
(eq. 7), stacked residual vector (eq. 8), least-squares objective S (eq. 9); §3: accuracy
judged by the control error after calibration. SPEC §3 fixes the feasible box Ω and the
control-error definition.

Every function here is pure and written for one parameter vector and one data set, so that
``jax.vmap`` batches it over a population of parameter vectors (the optimisers) and over
independent trials (Monte Carlo).
"""

from __future__ import annotations

from typing import NamedTuple

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float

from .._units import (
    ARCSEC as ARCSEC,
    COMPONENTS as COMPONENTS,
    UM as UM,
    error_in_report_units as error_in_report_units,
)
from ..mechanism._kinematics import check_array, check_poses, forward_kinematics, solve_inverse_kinematics
from ..mechanism._pss import N_PARAMS, Geometry, geometry_from_params


class CalibrationData(NamedTuple):
    """Measured data of ``m`` poses (seed 000 eqs. 7–8; SPEC §6 columns).

    - ``strokes``: ``Float[Array, "m 6"]``, measured slider strokes ``q'`` (mm).
    - ``poses``: ``Float[Array, "m 6"]``, measured poses ``P'_a`` (mm, rad).
    - ``directions``: ``Float[Array, "m 6"] | None``, approach direction (+1/−1) per slider.
    - ``temperature``: ``Float[Array, "m"] | None``, °C.
    - ``time``: ``Float[Array, "m"] | None``, s since the start of the run.
    """

    strokes: Float[Array, "m 6"]
    poses: Float[Array, "m 6"]
    directions: Float[Array, "m 6"] | None = None
    temperature: Float[Array, " m"] | None = None
    time: Float[Array, " m"] | None = None

    @property
    def n_poses(self) -> int:
        return self.strokes.shape[-2]

    def take(self, index: ArrayLike) -> CalibrationData:
        """The rows ``index`` of every field (e.g. a train/test split)."""
        idx = np.asarray(index)
        return CalibrationData(*(None if f is None else f[idx] for f in self))


def make_calibration_data(
    strokes: ArrayLike,
    poses: ArrayLike,
    directions: ArrayLike | None = None,
    temperature: ArrayLike | None = None,
    time: ArrayLike | None = None,
) -> CalibrationData:
    """Validated :class:`CalibrationData` (shapes, finiteness, angles in radians)."""
    q = check_array(strokes, "strokes", last_dim=6)
    p = check_poses(poses, "poses")
    if q.shape != p.shape:
        raise ValueError(f"strokes {q.shape} and poses {p.shape} must have the same shape (m, 6)")
    m = q.shape[0]
    extras = []
    for name, x, shape in (("directions", directions, (m, 6)), ("temperature", temperature, (m,)),
                           ("time", time, (m,))):
        if x is None:
            extras.append(None)
            continue
        a = np.asarray(x, dtype=np.float64)
        if a.shape != shape:
            raise ValueError(f"{name} must have shape {shape}, got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name} contains NaN or inf")
        if name == "directions" and not np.all(np.isin(a, (-1.0, 1.0))):
            raise ValueError("directions must be +1 or -1")
        extras.append(jnp.asarray(a))
    return CalibrationData(q, p, *extras)


def stroke_residuals(
    params: Float[Array, "36"], data: CalibrationData, v0: Float[Array, "3"]
) -> Float[Array, "6m"]:
    """``E(u) = [e_11 … e_6m]``, ``e_j = q'_j − IK(P'_aj, u)`` (eqs. 7–8), in mm.

    NOTE: where a parameter vector makes a measured pose unreachable the square root of eq. 4
    is taken of 0, which keeps the residual finite and continuous for least-squares solvers;
    :func:`calibration_cost` reports such a vector as +inf.
    """
    sol = solve_inverse_kinematics(geometry_from_params(params, v0), data.poses)
    return (data.strokes - sol.strokes).reshape(-1)


def calibration_cost(
    params: Float[Array, "36"], data: CalibrationData, v0: Float[Array, "3"]
) -> Float[Array, ""]:
    """``S(u) = Σ_j Σ_i e_ij²`` (eq. 9), mm²; +inf where a measured pose is unreachable
    under ``u`` or the value is not finite (so that optimisers reject it)."""
    sol = solve_inverse_kinematics(geometry_from_params(params, v0), data.poses)
    s = jnp.sum((data.strokes - sol.strokes) ** 2)
    ok = jnp.all(sol.reachable) & jnp.isfinite(s)
    return jnp.where(ok, s, jnp.inf)


class CalibrationProblem(eqx.Module):
    """A calibration problem: data, the frame offset ``v0``, the feasible box Ω and the
    starting (nominal) parameters.

    - ``data``: :class:`CalibrationData` of ``m`` poses.
    - ``v0``: ``Float[Array, "3"]`` (mm).
    - ``lower``, ``upper``: ``Float[Array, "36"]``, the box Ω (mm).
    - ``initial``: ``Float[Array, "36"]``, the nominal parameters (mm).
    """

    data: CalibrationData
    v0: Float[Array, "3"]
    lower: Float[Array, "36"]
    upper: Float[Array, "36"]
    initial: Float[Array, "36"]

    def residuals(self, params: Float[Array, "36"]) -> Float[Array, "6m"]:
        return stroke_residuals(params, self.data, self.v0)

    def cost(self, params: Float[Array, "36"]) -> Float[Array, ""]:
        return calibration_cost(params, self.data, self.v0)


def feasible_box(
    nominal: Geometry, half_width: float = 10.0
) -> tuple[Float[Array, "36"], Float[Array, "36"]]:
    """Ω = nominal ± ``half_width`` (mm) per parameter. SPEC §3: the paper's experiment uses
    2.5 mm; the simulation study needs ≥ 7 mm (Table 1's actual values lie up to 6.9 mm from
    nominal) and uses 10 mm."""
    if not half_width > 0:
        raise ValueError(f"half_width must be positive (mm), got {half_width}")
    u = nominal.params
    return u - half_width, u + half_width


def calibration_problem(
    data: CalibrationData, nominal: Geometry, half_width: float = 10.0
) -> CalibrationProblem:
    """The problem of seed 000 §1.2 with Ω = nominal ± ``half_width`` mm."""
    if data.n_poses * 6 < N_PARAMS:
        raise ValueError(
            f"{data.n_poses} poses give {6 * data.n_poses} residuals for {N_PARAMS} parameters: "
            "at least 6 poses are needed (the paper uses 8 in simulation, 120 in the experiment)"
        )
    lo, hi = feasible_box(nominal, half_width)
    return CalibrationProblem(data, nominal.v0, lo, hi, nominal.params)


class ControlError(NamedTuple):
    """Control error at target poses (SPEC §3).

    - ``errors``: ``Float[Array, "n 6"]``, achieved minus target pose (mm, rad).
    - ``converged``: ``Bool[Array, "n"]``, forward kinematics of the true mechanism converged.
    """

    errors: Float[Array, "n 6"]
    converged: Bool[Array, " n"]


def control_error(
    calibrated: Geometry, true: Geometry, targets: Float[Array, "n 6"]
) -> ControlError:
    """Command each target with the calibrated model, ``q = IK(P, u_cal)``, move the true
    mechanism, ``FK(q, u_true)``, and return the pose error (seed 000 §3, SPEC §3)."""
    q = solve_inverse_kinematics(calibrated, targets)
    fk = forward_kinematics(true, q.strokes, targets)
    return ControlError(fk.poses - targets, fk.converged & q.reachable)


def summarize_control_error(err: ControlError) -> dict[str, list[float]]:
    """Per component (dx, dy, dz in µm; φ, θ, ψ in ″): maximum absolute error (the paper's
    tables) and RMS. Raises if forward kinematics failed at any pose."""
    if not np.all(np.asarray(err.converged)):
        raise ValueError("control error: forward kinematics of the true mechanism failed at "
                         f"{int(np.sum(~np.asarray(err.converged)))} pose(s)")
    e = error_in_report_units(err.errors)
    return {
        "max_abs": np.max(np.abs(e), axis=-2).tolist(),
        "rms": np.sqrt(np.mean(e**2, axis=-2)).tolist(),
    }

