"""The result type and the status enumeration shared by every optimiser."""

from __future__ import annotations

from typing import NamedTuple

import equinox as eqx
import jax
import numpy as np
from jaxtyping import Array, Float, Int


class RESULTS(eqx.Enumeration):
    """How an optimiser stopped. Compare with ``==`` (elementwise for a batch of results):
    ``result.status == RESULTS.successful``."""

    successful = ""
    max_steps_reached = (
        "The step or evaluation budget ran out before any convergence test held; `params` is the "
        "best point found."
    )
    nonfinite = "The best cost is not finite: no feasible point was found."
    target_reached = "The best value reached the caller's `target`."
    stalled = (
        "The budget ran out with the search settled: the best value improved by at most `stall_rtol` "
        "(relative) over the last `stall_generations` generations."
    )


# ``successful`` is the solver's own convergence test: LM's step/cost tolerances, CMA-ES's step
# size collapse (``tolx``) or flat fitness (``tolfun``), Nelder–Mead's simplex size. Codes are the
# positions here: new statuses are appended, so that the codes in existing files keep their meaning.
_NAMES = (("success", RESULTS.successful), ("max_steps", RESULTS.max_steps_reached),
          ("nonfinite", RESULTS.nonfinite), ("target", RESULTS.target_reached), ("stall", RESULTS.stalled))
STATUS_NAMES = tuple(name for name, _ in _NAMES)
"""The stable names of the statuses in files and on the command line, in code order."""


def _code(status) -> np.ndarray:
    """The integer code(s) of a status on the host (an enumeration item is a pytree of one leaf):
    comparing there compiles nothing, where ``==`` on the item runs an eager JAX program."""
    return np.asarray(jax.tree_util.tree_leaves(status)[0])


def status_name(status) -> str | np.ndarray:
    """The stable name of a status (an array of names for a batch), as written to JSON:
    ``"success"`` (the solver's own convergence test held), ``"max_steps"``, ``"nonfinite"``,
    ``"target"`` (the caller's target was reached) or ``"stall"`` (the search settled)."""
    codes = _code(status)
    out = np.full(codes.shape, "", dtype=object)
    for name, item in _NAMES:
        out[codes == _code(item)] = name
    return str(out) if out.ndim == 0 else out


def status_code(status) -> np.ndarray:
    """The statuses as integers 0 … 4 (order of :data:`STATUS_NAMES`), e.g. for counting."""
    codes = np.zeros(np.shape(np.asarray(status == RESULTS.successful)), dtype=np.int64)
    for i, (_, item) in enumerate(_NAMES):
        codes[np.asarray(status == item)] = i
    return codes


class OptimiseResult(NamedTuple):
    """What every optimiser returns; a pytree, so a batch of trials is one result with a
    leading trial axis.

    - ``params``: the best parameters found (the structure of the start point or bounds:
      an array ``Float[Array, "n"]`` or any pytree).
    - ``cost``: ``Float[Array, ""]``, the objective at ``params`` (for least squares ``Σ r²``).
    - ``n_evaluations``: ``Int[Array, ""]``, objective (or residual-vector) evaluations used.
    - ``status``: a :class:`RESULTS` item.
    - ``history_cost``: ``Float[Array, "steps"]``, best cost after each generation/step.
    - ``history_evaluations``: ``Int[Array, "steps"]``, cumulative evaluations at each entry.
    """

    params: Float[Array, " n"]
    cost: Float[Array, ""]
    n_evaluations: Int[Array, ""]
    status: RESULTS
    history_cost: Float[Array, " steps"]
    history_evaluations: Int[Array, " steps"]
