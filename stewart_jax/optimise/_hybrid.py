"""``vsa-smcs+lm``: VSA-SMCS for the global phase, Levenberg–Marquardt to polish its best nest.

Global phase: Wang H., Cao X. et al., "Improved cuckoo calibration method of space telescope
secondary mirror adjusting mechanism", Infrared and Laser Engineering 47(5), 2018, §2.2–2.3,
:mod:`.vsa_smcs`. Local phase: Levenberg K. (1944), Marquardt D. W. (1963), started from the best nest: the
batched LM of :mod:`._batched_lm` by default (so that a batch of hybrid calibrations polishes all
its best nests in one batched solve, finished trials dropping out), or optimistix's
(:mod:`._levenberg_marquardt`). The usual
memetic pattern (a population method to find the basin, a Newton-type method for the last
digits) — e.g. Moscato P., Cotta C., "A gentle introduction to memetic algorithms",
Handbook of Metaheuristics (2003).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jaxtyping import PRNGKeyArray

from ._batched_lm import BatchedLevenbergMarquardt
from ._driver import minimise
from ._levenberg_marquardt import LevenbergMarquardt, sum_of_squares
from ._objective import AbstractOptimiser, Objective
from ._result import RESULTS, OptimiseResult
from ._vsa_smcs import VSASMCS


class VSASMCSThenLM(AbstractOptimiser):
    """VSA-SMCS (``global_phase``) within ``max_evaluations`` cost evaluations, then LM
    (``local_phase``: :class:`BatchedLevenbergMarquardt` or optimistix's
    :class:`LevenbergMarquardt`) from its best nest.

    The result's ``n_evaluations`` adds LM's residual-vector evaluations (each with a
    Jacobian) to VSA-SMCS's cost evaluations; the history is VSA-SMCS's, with LM's final
    cost appended. LM's result is kept only where it improves on the best nest (LM is
    unbounded; it is not clipped to Ω).

    A batch (:meth:`solve_batch`) runs :meth:`explore` per problem (vmapped), the local phase's
    own batched solve from the best nests (for the batched LM,
    :func:`~stewart_jax.optimise.least_squares_batch`), and :meth:`combine` per problem.
    """

    global_phase: VSASMCS = VSASMCS()
    local_phase: BatchedLevenbergMarquardt | LevenbergMarquardt = BatchedLevenbergMarquardt()

    def explore(self, cost_fn, lower, upper, key: PRNGKeyArray, max_evaluations: int, args=None) -> OptimiseResult:
        """The global phase: VSA-SMCS on ``cost_fn(y, args)`` over ``[lower, upper]``."""
        return minimise(cost_fn, self.global_phase, lower, upper, key, max_evaluations=max_evaluations, args=args)

    def combine(self, g: OptimiseResult, lm: OptimiseResult) -> OptimiseResult:
        """One problem's result from its global phase ``g`` and its local phase ``lm``."""
        better = jnp.isfinite(lm.cost) & (lm.cost <= g.cost)
        params = jnp.where(better, lm.params, g.params)
        cost = jnp.where(better, lm.cost, g.cost)
        n = g.n_evaluations + lm.n_evaluations
        status = RESULTS.where(better, lm.status,
                               RESULTS.where(jnp.isfinite(g.cost), g.status, RESULTS.nonfinite))
        return OptimiseResult(
            params=params,
            cost=cost,
            n_evaluations=n,
            status=status,
            history_cost=jnp.concatenate([g.history_cost, cost[None]]),
            history_evaluations=jnp.concatenate([g.history_evaluations, n[None]]),
        )

    def min_evaluations(self, n_dim: int) -> int:
        return self.global_phase.min_evaluations(n_dim)

    def solve(self, objective: Objective, y0, lower, upper, key, args, max_evaluations: int) -> OptimiseResult:
        """The protocol: VSA-SMCS on ``objective.cost`` within ``max_evaluations``, then the local
        phase's ``solve`` from its best nest."""
        del y0  # the global phase samples the box
        g = self.explore(objective.cost, lower, upper, key, max_evaluations, args)
        return self.combine(g, self.local_phase.solve(objective, g.params, lower, upper, key, args, max_evaluations))

    def solve_batch(self, objective: Objective, y0s, lowers, uppers, keys, args, max_evaluations: int
                    ) -> OptimiseResult:
        """The global phase per problem (vmapped), then one batched local solve of every best nest."""
        g = jax.vmap(lambda lo, hi, k, a: self.explore(objective.cost, lo, hi, k, max_evaluations, a))(
            lowers, uppers, keys, args)
        local = self.local_phase.solve_batch(objective, g.params, lowers, uppers, keys, args, max_evaluations)
        return jax.vmap(self.combine)(g, local)

    def run(self, fn, lower, upper, key: PRNGKeyArray, max_evaluations: int, args=None, cost=None, jac=None,
            blocks=None) -> OptimiseResult:
        """Residuals ``fn(y, args)`` over the box ``[lower, upper]`` (arrays); ``cost(y, args)``
        is the global phase's objective and the value reported (default ``Σ fn²``); ``jac`` and
        ``blocks`` go to a :class:`BatchedLevenbergMarquardt` local phase (see its ``run``)."""
        cost_fn = sum_of_squares(fn) if cost is None else cost
        return self.solve(Objective(cost_fn, fn, jac, blocks), None, lower, upper, key, args, max_evaluations)
