"""The calibration model and the control-error criterion, for any mechanism family.

Wang H., Cao X. et al., "Improved cuckoo calibration method of space telescope secondary mirror
adjusting mechanism", Infrared and Laser Engineering 47(5), 2018, §1.2: reading residual
(eq. 7), stacked residual vector (eq. 8), least-squares objective S (eq. 9); §3: accuracy
judged by the control error after calibration. The feasible box Ω is the nominal parameters
± a half-width (the paper's experiment: 2.5 mm).

Every function here is pure and written for one parameter vector and one data set, so that
``jax.vmap`` batches it over a population of parameter vectors (the optimisers) and over
independent trials (Monte Carlo).
"""

from __future__ import annotations

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float

from .._checks import check_array, check_poses, on_host, to_device
from .._units import (
    ARCSEC as ARCSEC,
    COMPONENTS as COMPONENTS,
    UM as UM,
    error_in_report_units as error_in_report_units,
)
from ..mechanism._abstract import AbstractMechanism
from ..mechanism._kinematics import forward_kinematics


class CalibrationData(NamedTuple):
    """Measured data of ``m`` poses (Wang et al. 2018, eqs. 7–8; the measurement CSV's columns).

    - ``readings``: ``Float[Array, "m 6"]``, measured actuator readings ``q'`` (the mechanism's
      reading unit: mm for a stroke, rad for a crank angle).
    - ``poses``: ``Float[Array, "m 6"]``, measured poses ``P'_a`` (mm, rad).
    - ``directions``: ``Float[Array, "m 6"] | None``, approach direction (+1/−1) per slider.
    - ``temperature``: ``Float[Array, "m"] | None``, °C.
    - ``time``: ``Float[Array, "m"] | None``, s since the start of the run.
    """

    readings: Float[Array, "m 6"]
    poses: Float[Array, "m 6"]
    directions: Float[Array, "m 6"] | None = None
    temperature: Float[Array, " m"] | None = None
    time: Float[Array, " m"] | None = None

    time_unit = ("h", 3600.0)
    """The discrepancy search's ``time`` factor: hours (a session lasts hours)."""

    @property
    def n_poses(self) -> int:
        return self.readings.shape[-2]

    def take(self, index: ArrayLike) -> CalibrationData:
        """The rows ``index`` of every field (e.g. a train/test split)."""
        idx = np.asarray(index)
        if any(isinstance(f, jax.core.Tracer) for f in self):
            return CalibrationData(*(None if f is None else f[idx] for f in self))
        # concrete rows are copied on the host: a device gather would compile one program per
        # field shape and index count (a dozen per discrepancy fit)
        return CalibrationData(*(None if f is None else jnp.asarray(np.asarray(f)[idx]) for f in self))


def make_calibration_data(
    readings: ArrayLike,
    poses: ArrayLike,
    directions: ArrayLike | None = None,
    temperature: ArrayLike | None = None,
    time: ArrayLike | None = None,
) -> CalibrationData:
    """Validated :class:`CalibrationData` (shapes, finiteness, angles in radians)."""
    q = check_array(readings, "readings", last_dim=6)
    p = check_poses(poses, "poses")
    if q.shape != p.shape:
        raise ValueError(f"readings {q.shape} and poses {p.shape} must have the same shape (m, 6)")
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


def reading_residuals(
    params: Float[Array, " n"], data: CalibrationData, mechanism: AbstractMechanism
) -> Float[Array, "6m"]:
    """``E(u) = [e_11 … e_6m]``, ``e_j = q'_j − IK(P'_aj, u)`` (eqs. 7–8), in the reading unit
    (mm, or rad for a rotary family), where
    ``IK(·, u)`` is ``mechanism.with_params(u)`` (``mechanism`` supplies everything that is not
    calibrated, e.g. the 6-PSS's ``v0``).

    NOTE: where a parameter vector makes a measured pose unreachable the family's inverse
    kinematics keeps the reading finite (for the 6-PSS the square root of eq. 4 is taken of 0),
    which keeps the residual continuous for least-squares solvers; :func:`calibration_cost`
    reports such a vector as +inf.
    """
    sol = mechanism.with_params(params).solve_inverse_kinematics(data.poses)
    return (data.readings - sol.readings).reshape(-1)


reading_residuals_compiled = eqx.filter_jit(reading_residuals)
""":func:`reading_residuals` as one compiled program (per mechanism type and pose count), for the
host-side steps that evaluate it at a few parameter vectors."""


def calibration_cost(
    params: Float[Array, " n"], data: CalibrationData, mechanism: AbstractMechanism
) -> Float[Array, ""]:
    """``S(u) = Σ_j Σ_i e_ij²`` (eq. 9), the reading unit squared (mm²); +inf where a measured pose is unreachable
    under ``u`` or the value is not finite (so that optimisers reject it)."""
    sol = mechanism.with_params(params).solve_inverse_kinematics(data.poses)
    s = jnp.sum((data.readings - sol.readings) ** 2)
    ok = jnp.all(sol.reachable) & jnp.isfinite(s)
    return jnp.where(ok, s, jnp.inf)


class CalibrationProblem(eqx.Module):
    """A calibration problem: data, the nominal mechanism, the feasible box Ω and the
    starting (nominal) parameters.

    - ``data``: :class:`CalibrationData` of ``m`` poses.
    - ``mechanism``: the nominal :class:`~stewart_jax.mechanism.AbstractMechanism`; its
      ``with_params(u)`` is the model being calibrated.
    - ``lower``, ``upper``: ``Float[Array, " n"]``, the box Ω (each parameter in its unit).
    - ``initial``: ``Float[Array, " n"]``, the nominal parameters.
    - ``weights``: ``Float[Array, " m"] | None``, 1 for a measured pose and 0 for a row that pads
      the pose count to a size shared by several problems (``calibrate`` pads the least-squares
      methods' problems to a few sizes, so that they share compiled programs); ``None``: every
      row is measured.
    """

    data: CalibrationData
    mechanism: AbstractMechanism
    lower: Float[Array, " n"]
    upper: Float[Array, " n"]
    initial: Float[Array, " n"]
    weights: Float[Array, " m"] | None = None

    def residuals(self, params: Float[Array, " n"]) -> Float[Array, "6m"]:
        r = reading_residuals(params, self.data, self.mechanism)
        return r if self.weights is None else r * jnp.repeat(self.weights, 6)

    def cost(self, params: Float[Array, " n"]) -> Float[Array, ""]:
        if self.weights is None:
            return calibration_cost(params, self.data, self.mechanism)
        sol = self.mechanism.with_params(params).solve_inverse_kinematics(self.data.poses)
        s = jnp.sum(((self.data.readings - sol.readings) * self.weights[:, None]) ** 2)
        ok = jnp.all(sol.reachable | (self.weights == 0)) & jnp.isfinite(s)
        return jnp.where(ok, s, jnp.inf)

    def population_cost(self, params: Float[Array, "k n"]) -> Float[Array, " k"]:
        """``S(u)`` (eq. 9) for every row of ``params``: ``jax.vmap(self.cost)(params)`` to
        rounding (+inf where a pose is unreachable or the value is not finite), through the
        family's population layout
        (:meth:`~stewart_jax.mechanism.AbstractMechanism.population_squared_residuals`).
        A population optimiser that vmaps :func:`population_objective` gets it."""
        if self.weights is not None:
            return jax.vmap(self.cost)(params)
        sse, ok = self.mechanism.population_squared_residuals(params, self.data.poses, self.data.readings)
        return jnp.where(ok & jnp.isfinite(sse), sse, jnp.inf)

    def calibrated(self, params: Float[Array, " n"]) -> AbstractMechanism:
        """The mechanism with the calibrated parameters ``params``."""
        return self.mechanism.with_params(params)


@jax.custom_jvp
def population_objective(params: Float[Array, " n"], problem: CalibrationProblem) -> Float[Array, ""]:
    """``problem.cost(params)`` as an objective ``fn(y, args)`` for the optimisers, whose
    ``jax.vmap`` over ``params`` is :meth:`CalibrationProblem.population_cost`.

    NOTE: population solvers are written per nest and evaluate a population with ``jax.vmap``
    (``evaluate`` in ``stewart_jax/optimise/_driver.py``), which keeps them generic; this function's batching
    rule (``jax.custom_batching.custom_vmap``) swaps the vmapped per-nest cost for the family's
    population layout whenever only ``params`` is batched (``problem`` batched too, e.g. one
    problem per trial on the same axis, falls back to ``vmap`` of the cost). Derivatives, in
    either mode, are those of :meth:`CalibrationProblem.cost` (a ``custom_jvp`` around the
    batching rule, which JAX cannot differentiate under ``vmap`` or in reverse mode).
    """
    return _batched_cost(params, problem)


@population_objective.defjvp
def _population_objective_jvp(primals, tangents):
    return jax.jvp(lambda u, p: p.cost(u), primals, tangents)


@jax.custom_batching.custom_vmap
def _batched_cost(params, problem):
    return _cost_in_own_program(params, problem)


@eqx.filter_jit
def _cost_in_own_program(params, problem):
    """``problem.cost(params)`` behind a ``jit`` boundary, so that ``_batched_cost`` closes over
    no constant.

    NOTE: jax 0.10's ``custom_vmap`` hoists every array constant its function creates while
    tracing (here: a family's NumPy constants, e.g. a slider axis) into constants of its call,
    and its batching rule asserts that none of them is batched
    (``assert not any(tree_leaves(consts_batched))`` in ``jax/_src/custom_batching.py``). But
    ``lax.cond`` under ``vmap`` with a batched predicate broadcasts *every* operand of its
    branches, those hoisted constants included — so an objective evaluated at one point inside
    a ``cond`` branch of a vmapped solver (Nelder–Mead's shrink-or-replace step, run over the
    trials of a study) failed with a bare ``AssertionError``. Behind ``jit`` the constants stay
    inside the jitted call's own closed jaxpr, which no batching rule rewrites. The reduction
    is ``benchmarks/jax_custom_vmap_cond_constants.py``; no upstream report was found for jax
    0.10.2. XLA inlines the call, so the compiled program is the same.
    """
    return problem.cost(params)


@_batched_cost.def_vmap
def _batched_cost_vmap(axis_size, in_batched, params, problem):
    params_batched, problem_batched = in_batched
    if params_batched and not any(jax.tree.leaves(problem_batched)):
        return problem.population_cost(params), True
    in_axes = (0 if params_batched else None, jax.tree.map(lambda b: 0 if b else None, problem_batched))
    return jax.vmap(lambda u, p: p.cost(u), in_axes=in_axes, axis_size=axis_size)(params, problem), True


def feasible_box(
    nominal: AbstractMechanism, half_width: float = 10.0, half_width_mrad: float | None = None
) -> tuple[Float[Array, " n"], Float[Array, " n"]]:
    """Ω = nominal ± ``half_width`` (mm) per length parameter and ± ``half_width_mrad`` (mrad;
    default the same number) per angle parameter, each in the parameter's own unit. The paper's
    experiment uses 2.5 mm; the simulation study needs ≥ 7 mm (Table 1's actual values lie up to
    6.9 mm from nominal) and uses 10 mm."""
    half_width_mrad = half_width if half_width_mrad is None else half_width_mrad
    if not (half_width > 0 and half_width_mrad > 0):
        raise ValueError(f"half_width must be positive (mm; mrad for angles), got {half_width}, {half_width_mrad}")
    xp, (u,) = on_host(nominal.params)
    half = xp.asarray(nominal.natural_scales(half_width, half_width_mrad))
    return to_device(u - half), to_device(u + half)


def calibration_problem(
    data: CalibrationData, nominal: AbstractMechanism, half_width: float = 10.0, half_width_mrad: float | None = None
) -> CalibrationProblem:
    """The problem of Wang et al. (2018) §1.2 with Ω = nominal ± ``half_width`` mm (±
    ``half_width_mrad`` mrad for angle parameters, default the same number)."""
    if not isinstance(nominal, AbstractMechanism):
        raise TypeError(
            f"nominal must be a mechanism (e.g. stewart_jax.nominal_geometry()), got {type(nominal).__name__}"
        )
    n_params = nominal.n_params
    if data.n_poses * 6 < n_params:
        raise ValueError(
            f"{data.n_poses} poses give {6 * data.n_poses} residuals for {n_params} parameters: "
            f"at least {-(-n_params // 6)} poses are needed (the paper uses 8 in simulation, 120 in the experiment)"
        )
    lo, hi = feasible_box(nominal, half_width, half_width_mrad)
    return CalibrationProblem(data, nominal, lo, hi, nominal.params)


class ControlError(NamedTuple):
    """Control error at target poses (Wang et al. 2018, §3).

    - ``errors``: ``Float[Array, "n 6"]``, achieved minus target pose (mm, rad).
    - ``converged``: ``Bool[Array, "n"]``, forward kinematics of the true mechanism converged.
    """

    errors: Float[Array, "n 6"]
    converged: Bool[Array, " n"]


def control_error(
    calibrated: AbstractMechanism, true: AbstractMechanism, targets: Float[Array, "n 6"]
) -> ControlError:
    """Command each target with the calibrated model, ``q = IK(P, u_cal)``, move the true
    mechanism, ``FK(q, u_true)``, and return the pose error (Wang et al. 2018, §3)."""
    q = calibrated.solve_inverse_kinematics(targets)
    fk = forward_kinematics(true, q.readings, targets)
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

