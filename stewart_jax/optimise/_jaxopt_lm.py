"""Cross-check of the LM baseline with jaxopt's Levenberg–Marquardt.

Levenberg K., Quart. Appl. Math. 2 (1944) 164–168; Marquardt D. W., J. SIAM 11 (1963)
431–441; damping update of Madsen K., Nielsen H. B., Tingleff O., *Methods for non-linear
least squares problems* (2004) — as implemented by ``jaxopt.LevenbergMarquardt``.

jaxopt is no longer developed upstream (its solvers moved to optax/optimistix): this module is
its only user in the package, it imports jaxopt lazily, and nothing else depends on it. The
reference baseline is :mod:`.levenberg_marquardt` (optimistix).
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from ..calibration._problem import CalibrationProblem
from ._result import MAX_STEPS, NONFINITE, SUCCESS, OptimiseResult


class JaxoptLevenbergMarquardt(eqx.Module):
    """Hyper-parameters of the jaxopt LM cross-check.

    - ``max_steps``: iteration budget (each iteration: one residual vector and one Jacobian).
    - ``xtol``, ``gtol``: Madsen–Nielsen stopping (``‖Δu‖ ≤ xtol·(‖u‖ + xtol)`` or
      ``‖∇S‖_∞ ≤ gtol``); 1e-14 and 1e-14 so that it stops at the same noise floor the
      optimistix baseline reaches.
    - ``linear_solver``: ``"cholesky"`` on the materialised normal equations (36 × 36;
      jaxopt's default conjugate gradient stops early on this ill-conditioned problem).
    """

    max_steps: int = 200
    xtol: float = 1e-14
    gtol: float = 1e-14
    linear_solver: str = "cholesky"

    def run(self, problem: CalibrationProblem, initial: Float[Array, "36"] | None = None
            ) -> OptimiseResult:
        """Minimise ``S(u)`` from ``initial`` (default: nominal). Pure and jittable."""
        import jaxopt  # arm's length: only this adapter imports jaxopt

        y0 = problem.initial if initial is None else initial
        solver = jaxopt.LevenbergMarquardt(
            residual_fun=lambda u, p: p.residuals(u),
            maxiter=self.max_steps,
            stop_criterion="madsen-nielsen",
            xtol=self.xtol,
            gtol=self.gtol,
            solver=self.linear_solver,
            materialize_jac=True,
            implicit_diff=False,
            jit=True,
        )
        params, state = solver.run(y0, problem)
        cost = problem.cost(params)
        steps = jnp.asarray(state.iter_num)
        status = jnp.where(~jnp.isfinite(cost), NONFINITE,
                           jnp.where(steps < self.max_steps, SUCCESS, MAX_STEPS))
        n = jnp.asarray(steps + 1, jnp.int32)
        return OptimiseResult(params, cost, n, jnp.asarray(status, jnp.int32), cost[None], n[None])
