"""The one protocol every optimiser of the package implements, and the problem it is given.

A problem is an :class:`Objective` — the scalar ``cost`` every solver minimises and reports, and,
for the least-squares solvers, the ``residuals`` whose sum of squares it is, their Jacobian and
their separable ``blocks`` where the caller knows them — with a start ``y0``, a box
``[lower, upper]``, a PRNG key, the ``args`` of the functions and an evaluation budget.

Every solver is an immutable ``equinox.Module`` of hyper-parameters with
:meth:`AbstractOptimiser.solve` (one problem) and :meth:`AbstractOptimiser.solve_batch` (a batch of
independent problems; by default ``vmap`` of ``solve``, overridden where a solver batches better,
as the batched Levenberg–Marquardt does). How a solver iterates is its own: the population and
simplex methods are :class:`~stewart_jax.optimise.AbstractSolver` subclasses (``init`` / ``step`` /
``terminate → (bool, RESULTS)`` / ``postprocess``, run by the one driver
:func:`~stewart_jax.optimise.minimise`); the batched LM has the same ``init`` / ``step`` /
``terminate`` run by its own batched loop; the optimistix and jaxopt LMs are run by their
libraries' drivers, which is what makes them reference baselines. Callers (``calibrate``,
``calibrate_batch``, the study) only ever call ``solve`` / ``solve_batch``: a new optimiser of any
kind is one module and its registration.
"""

from __future__ import annotations

import abc
from collections.abc import Callable
from typing import Any, NamedTuple

import equinox as eqx
import jax

from ._result import OptimiseResult


class Objective(NamedTuple):
    """One problem's functions, all in the optimistix argument order ``f(y, args)``.

    - ``cost``: ``(y, args) -> Float[Array, ""]``, the value minimised and reported (a caller may
      return +inf for an infeasible point).
    - ``residuals``: ``(y, args) -> Float[Array, "m"]`` (any pytree), with ``cost = Σ residuals²``
      wherever both are finite; ``None`` where the problem is not a least-squares one.
    - ``jacobian``: ``(y, args) ->`` the ``(m, n)`` Jacobian of the raveled residual, or with
      ``blocks`` its ``(K, m_k, n_k)`` blocks; ``None``: autodiff.
    - ``blocks``: a :class:`~stewart_jax.optimise.Blocks` where the residual is separable, or ``None``.
    """

    cost: Callable[..., Any]
    residuals: Callable[..., Any] | None = None
    jacobian: Callable[..., Any] | None = None
    blocks: Any = None


def needs_residuals(solver, objective: Objective) -> Callable[..., Any]:
    """The objective's residual function; a clear error for a least-squares solver given none."""
    if objective.residuals is None:
        raise ValueError(f"{type(solver).__name__} is a least-squares solver: the objective needs `residuals` "
                         "(a vector whose sum of squares is the cost)")
    return objective.residuals


class AbstractOptimiser(eqx.Module):
    """An optimiser: hyper-parameters as fields, :meth:`solve` for one problem."""

    @abc.abstractmethod
    def solve(self, objective: Objective, y0, lower, upper, key, args, max_evaluations: int) -> OptimiseResult:
        """Minimise ``objective`` from ``y0`` (a solver that samples the box may ignore it) over
        ``[lower, upper]`` (a solver that is unbounded may ignore it), within ``max_evaluations``
        cost evaluations where the solver counts cost evaluations (the least-squares solvers'
        budget is their ``max_steps``). Pure and jittable."""

    def min_evaluations(self, n_dim: int) -> int:
        """The fewest cost evaluations a budget must allow on ``n_dim`` parameters (checked before
        any work); 0 for a solver whose budget is not counted in cost evaluations."""
        del n_dim
        return 0

    def solve_batch(self, objective: Objective, y0s, lowers, uppers, keys, args, max_evaluations: int
                    ) -> OptimiseResult:
        """:meth:`solve` over independent problems: every leaf of ``y0s``, ``lowers``, ``uppers``,
        ``keys`` and ``args`` has a leading batch axis; so has the result."""
        return jax.vmap(lambda y, lo, hi, k, a: self.solve(objective, y, lo, hi, k, a, max_evaluations))(
            y0s, lowers, uppers, keys, args)
