"""The reference baseline: Levenberg–Marquardt on the stroke residuals.

Levenberg K., Quart. Appl. Math. 2 (1944) 164–168; Marquardt D. W., J. SIAM 11 (1963)
431–441 — as implemented by optimistix (``optimistix.LevenbergMarquardt``), applied to the
residual vector E(u) of seed 000 eq. 8 from the nominal parameters (SPEC §4).

LM is unbounded: the result is reported whether or not it lies in Ω (from nominal it stays
within a few mm on the paper's problems; ``OptimiseResult.params`` can be checked against the
box by the caller).
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import optimistix as optx
from jaxtyping import Array, Float

from ..calibration._problem import CalibrationProblem
from ._result import MAX_STEPS, NONFINITE, SUCCESS, OptimiseResult


class LevenbergMarquardt(eqx.Module):
    """Hyper-parameters of the LM baseline.

    - ``rtol``, ``atol``: optimistix's step/cost tolerances (relative, absolute).
    - ``max_steps``: iteration budget; each step evaluates the residual once and its
      36-column Jacobian once (forward mode).
    """

    rtol: float = 1e-12
    atol: float = 1e-14
    max_steps: int = 200

    def run(self, problem: CalibrationProblem, initial: Float[Array, "36"] | None = None) -> OptimiseResult:
        """Minimise ``S(u)`` from ``initial`` (default: the problem's nominal parameters).

        Pure and jittable; vmap it over a batch of problems for Monte Carlo.
        """
        y0 = problem.initial if initial is None else initial
        sol = optx.least_squares(
            lambda u, p: p.residuals(u),
            optx.LevenbergMarquardt(rtol=self.rtol, atol=self.atol),
            y0,
            args=problem,
            max_steps=self.max_steps,
            throw=False,
        )
        cost = problem.cost(sol.value)
        steps = sol.stats["num_steps"]
        status = jnp.where(
            ~jnp.isfinite(cost),
            NONFINITE,
            jnp.where(sol.result == optx.RESULTS.successful, SUCCESS, MAX_STEPS),
        )
        return OptimiseResult(
            params=sol.value,
            cost=cost,
            n_evaluations=jnp.asarray(steps + 1),
            status=status,
            history_cost=cost[None],
            history_evaluations=jnp.asarray(steps + 1)[None],
        )


@jax.jit
def lm_calibrate(problem: CalibrationProblem) -> OptimiseResult:
    """:class:`LevenbergMarquardt` with its defaults, jitted."""
    return LevenbergMarquardt().run(problem)
