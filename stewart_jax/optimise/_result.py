"""The result type shared by every calibration optimiser."""

from __future__ import annotations

from typing import NamedTuple

from jaxtyping import Array, Float, Int

SUCCESS = 0
"""Converged (LM: tolerance met; metaheuristics: ``S(u_best) < ε``)."""
MAX_STEPS = 1
"""The step or evaluation budget ran out before convergence; ``params`` is the best found."""
NONFINITE = 2
"""The best cost is not finite: no feasible point was found."""

STATUS_NAMES = {SUCCESS: "success", MAX_STEPS: "max_steps", NONFINITE: "nonfinite"}


class OptimiseResult(NamedTuple):
    """What every optimiser returns; a pytree, so a batch of trials is one result with a
    leading trial axis.

    - ``params``: ``Float[Array, "n"]``, the best parameters found.
    - ``cost``: ``Float[Array, ""]``, the objective at ``params`` (S of eq. 9 for calibration).
    - ``n_evaluations``: ``Int[Array, ""]``, objective (or residual-vector) evaluations used.
    - ``status``: ``Int[Array, ""]``, one of :data:`SUCCESS`, :data:`MAX_STEPS`,
      :data:`NONFINITE`.
    - ``history_cost``: ``Float[Array, "steps"]``, best cost after each generation/step.
    - ``history_evaluations``: ``Int[Array, "steps"]``, cumulative evaluations at each entry.
    """

    params: Float[Array, " n"]
    cost: Float[Array, ""]
    n_evaluations: Int[Array, ""]
    status: Int[Array, ""]
    history_cost: Float[Array, " steps"]
    history_evaluations: Int[Array, " steps"]
