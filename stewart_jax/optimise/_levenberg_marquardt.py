"""The reference baseline: Levenberg–Marquardt for any least-squares problem.

Levenberg K., "A method for the solution of certain non-linear problems in least squares",
Quart. Appl. Math. 2 (1944) 164–168; Marquardt D. W., "An algorithm for least-squares estimation
of nonlinear parameters", J. SIAM 11 (1963) 431–441 — as implemented by optimistix
(``optimistix.LevenbergMarquardt``). For calibration it is applied to the residual vector E(u)
of Wang et al. (2018), eq. 8, from the nominal parameters.

LM is unbounded: the result is reported whether or not it lies in a box (from nominal it stays
within a few mm on the paper's problems; the caller can check ``OptimiseResult.params``).
"""

from __future__ import annotations

import jax.numpy as jnp
from jax.flatten_util import ravel_pytree

from ._objective import AbstractOptimiser, Objective, needs_residuals
from ._result import RESULTS, OptimiseResult


def sum_of_squares(fn):
    """``(y, args) -> Σ r²`` over every leaf of the residual pytree ``fn(y, args)``."""

    def cost(y, args):
        r, _ = ravel_pytree(fn(y, args))
        return jnp.sum(r**2)

    return cost


class LevenbergMarquardt(AbstractOptimiser):
    """Hyper-parameters of the LM baseline.

    - ``rtol``, ``atol``: optimistix's step/cost tolerances (relative, absolute).
    - ``max_steps``: iteration budget; each step evaluates the residual once and its
      Jacobian once (forward mode).
    """

    rtol: float = 1e-12
    atol: float = 1e-14
    max_steps: int = 200

    def __check_init__(self):
        if not (self.rtol >= 0 and self.atol >= 0):
            raise ValueError(f"LevenbergMarquardt tolerances must be >= 0, got rtol={self.rtol}, atol={self.atol}")
        if not (int(self.max_steps) == self.max_steps and self.max_steps >= 1):
            raise ValueError(f"LevenbergMarquardt.max_steps must be a positive integer, got {self.max_steps!r}")

    def solve(self, objective: Objective, y0, lower, upper, key, args, max_evaluations: int) -> OptimiseResult:
        """The protocol: :meth:`run` on ``objective.residuals`` from ``y0`` (unbounded; the budget is
        ``max_steps``)."""
        del lower, upper, key, max_evaluations
        return self.run(needs_residuals(self, objective), y0, args, objective.cost)

    def run(self, fn, y0, args=None, cost=None) -> OptimiseResult:
        """Minimise ``Σ fn(y, args)²`` from ``y0`` (any pytree). ``cost(y, args)`` is the value
        reported (default the sum of squares; a caller may mark infeasible points +inf).

        Pure and jittable; vmap it over ``args`` for Monte Carlo.
        """
        import optimistix as optx  # here, not at the top: the batched LM of every command loads without it

        cost_fn = sum_of_squares(fn) if cost is None else cost
        sol = optx.least_squares(
            fn,
            optx.LevenbergMarquardt(rtol=self.rtol, atol=self.atol),
            y0,
            args=args,
            max_steps=self.max_steps,
            throw=False,
        )
        cost = cost_fn(sol.value, args)
        steps = sol.stats["num_steps"]
        status = RESULTS.where(
            ~jnp.isfinite(cost),
            RESULTS.nonfinite,
            RESULTS.where(sol.result == optx.RESULTS.successful, RESULTS.successful, RESULTS.max_steps_reached),
        )
        return OptimiseResult(
            params=sol.value,
            cost=cost,
            n_evaluations=jnp.asarray(steps + 1),
            status=status,
            history_cost=cost[None],
            history_evaluations=jnp.asarray(steps + 1)[None],
        )


def least_squares(fn, solver, y0, *, args=None, cost=None) -> OptimiseResult:
    """Minimise ``Σ fn(y, args)²`` from ``y0`` with a least-squares ``solver``
    (:class:`LevenbergMarquardt` or :class:`JaxoptLevenbergMarquardt`); the optimistix
    argument order."""
    return solver.run(fn, y0, args, cost)
