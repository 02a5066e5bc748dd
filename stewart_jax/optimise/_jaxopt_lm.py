"""Cross-check of the LM baseline with jaxopt's Levenberg–Marquardt.

Levenberg K., Quart. Appl. Math. 2 (1944) 164–168; Marquardt D. W., J. SIAM 11 (1963)
431–441; damping update of Madsen K., Nielsen H. B., Tingleff O., *Methods for non-linear
least squares problems* (2004) — as implemented by ``jaxopt.LevenbergMarquardt``.

jaxopt is no longer developed upstream (its solvers moved to optax/optimistix): this module is
its only user in the package, it imports jaxopt lazily, and nothing else depends on it. The
reference baseline is :mod:`.levenberg_marquardt` (optimistix).
"""

from __future__ import annotations

import jax.numpy as jnp

from ._levenberg_marquardt import sum_of_squares
from ._objective import AbstractOptimiser, Objective, needs_residuals
from ._result import RESULTS, OptimiseResult


class JaxoptLevenbergMarquardt(AbstractOptimiser):
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

    def __check_init__(self):
        if not (int(self.max_steps) == self.max_steps and self.max_steps >= 1):
            raise ValueError(f"JaxoptLevenbergMarquardt.max_steps must be a positive integer, got {self.max_steps!r}")
        if not (self.xtol >= 0 and self.gtol >= 0):
            raise ValueError(
                f"JaxoptLevenbergMarquardt tolerances must be >= 0, got xtol={self.xtol}, gtol={self.gtol}"
            )
        if self.linear_solver not in ("cholesky", "inv", "cg", "lu", "qr"):
            raise ValueError(f"JaxoptLevenbergMarquardt.linear_solver {self.linear_solver!r} is not a jaxopt solver")

    def solve(self, objective: Objective, y0, lower, upper, key, args, max_evaluations: int) -> OptimiseResult:
        """The protocol: :meth:`run` on ``objective.residuals`` from ``y0`` (unbounded; the budget is
        ``max_steps``)."""
        del lower, upper, key, max_evaluations
        return self.run(needs_residuals(self, objective), y0, args, objective.cost)

    def run(self, fn, y0, args=None, cost=None) -> OptimiseResult:
        """Minimise ``Σ fn(y, args)²`` from ``y0``; ``cost(y, args)`` is the value reported
        (default the sum of squares). Pure and jittable."""
        import jaxopt  # arm's length: only this adapter imports jaxopt

        cost_fn = sum_of_squares(fn) if cost is None else cost
        solver = jaxopt.LevenbergMarquardt(
            residual_fun=fn,
            maxiter=self.max_steps,
            stop_criterion="madsen-nielsen",
            xtol=self.xtol,
            gtol=self.gtol,
            solver=self.linear_solver,
            materialize_jac=True,
            implicit_diff=False,
            jit=True,
        )
        params, state = solver.run(y0, args)
        cost = cost_fn(params, args)
        steps = jnp.asarray(state.iter_num)
        status = RESULTS.where(~jnp.isfinite(cost), RESULTS.nonfinite,
                               RESULTS.where(steps < self.max_steps, RESULTS.successful, RESULTS.max_steps_reached))
        n = jnp.asarray(steps + 1, jnp.int32)
        return OptimiseResult(params, cost, n, status, cost[None], n[None])
