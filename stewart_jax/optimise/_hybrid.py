"""``vsa-smcs+lm``: VSA-SMCS for the global phase, Levenberg–Marquardt to polish its best nest.

Global phase: seed 000 §2.2–2.3 (Wang H., Cao X. et al., Infrared and Laser Engineering
47(5), 2018), :mod:`.vsa_smcs`. Local phase: Levenberg K. (1944), Marquardt D. W. (1963) via
optimistix, :mod:`.levenberg_marquardt`, started from the best nest. The usual
memetic pattern (a population method to find the basin, a Newton-type method for the last
digits) — e.g. Moscato P., Cotta C., "A gentle introduction to memetic algorithms",
Handbook of Metaheuristics (2003).
"""

from __future__ import annotations

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import PRNGKeyArray

from ..calibration._problem import CalibrationProblem
from ._driver import minimise
from ._result import NONFINITE, OptimiseResult
from ._levenberg_marquardt import LevenbergMarquardt
from ._vsa_smcs import VSASMCS


class VSASMCSThenLM(eqx.Module):
    """VSA-SMCS (``global_phase``) within ``max_evaluations`` cost evaluations, then LM
    (``local_phase``) from its best nest.

    The result's ``n_evaluations`` adds LM's residual-vector evaluations (each with a
    Jacobian) to VSA-SMCS's cost evaluations; the history is VSA-SMCS's, with LM's final
    cost appended. LM's result is kept only where it improves on the best nest (LM is
    unbounded; it is not clipped to Ω).
    """

    global_phase: VSASMCS = VSASMCS()
    local_phase: LevenbergMarquardt = LevenbergMarquardt()

    def run(self, problem: CalibrationProblem, key: PRNGKeyArray, max_evaluations: int
            ) -> OptimiseResult:
        g = minimise(self.global_phase, problem.cost, problem.lower, problem.upper, key,
                     max_evaluations)
        lm = self.local_phase.run(problem, g.params)
        better = jnp.isfinite(lm.cost) & (lm.cost <= g.cost)
        params = jnp.where(better, lm.params, g.params)
        cost = jnp.where(better, lm.cost, g.cost)
        n = g.n_evaluations + lm.n_evaluations
        status = jnp.where(better, lm.status, jnp.where(jnp.isfinite(g.cost), g.status, NONFINITE))
        return OptimiseResult(
            params=params,
            cost=cost,
            n_evaluations=n,
            status=jnp.asarray(status, jnp.int32),
            history_cost=jnp.concatenate([g.history_cost, cost[None]]),
            history_evaluations=jnp.concatenate([g.history_evaluations, n[None]]),
        )
