"""One entry point for every calibration optimiser of seed 000 §2 (and the baselines).

``calibrate(problem, method, key, ...)`` runs one trial; ``calibrate_batch(problems, method,
keys, ...)`` vmaps over independent trials (a :class:`CalibrationProblem` whose arrays have a
leading trial axis, and one PRNG key per trial) in a single compiled call. Both are jitted
with the method, its options and the budget static: repeated calls with the same settings
and shapes reuse the compiled code.

Methods (module: citation):

- ``"lm"``: :mod:`.levenberg_marquardt` (optimistix), from the nominal parameters; the baseline.
- ``"lm-jaxopt"``: :mod:`.jaxopt_lm`, the same from jaxopt, a cross-check.
- ``"cs"``: :mod:`.cuckoo` (Yang & Deb 2009).
- ``"smcs"``: :mod:`.smcs` (seed 000 §2.1; unbounded simplex steps).
- ``"vsa-smcs"``: :mod:`.vsa_smcs` (seed 000 §2.2–2.3).
- ``"vsa-smcs+lm"``: :mod:`.hybrid`.
- ``"nelder-mead"``: :mod:`.simplex` (bounded Nelder–Mead from the nominal parameters).

Budgets: ``max_evaluations`` (cost evaluations) for the metaheuristics and Nelder–Mead, so
that methods compare at the same number of evaluations; ``max_steps`` (LM iterations, each one
residual vector and one Jacobian) for the LM methods. The hybrid takes both.
"""

from __future__ import annotations

from typing import Any

import equinox as eqx
import jax
from jaxtyping import PRNGKeyArray

from ._problem import CalibrationProblem
from ..optimise._driver import minimise
from ..optimise._result import OptimiseResult
from ..optimise._cuckoo import CuckooSearch
from ..optimise._hybrid import VSASMCSThenLM
from ..optimise._jaxopt_lm import JaxoptLevenbergMarquardt
from ..optimise._levenberg_marquardt import LevenbergMarquardt
from ..optimise._simplex import NelderMead
from ..optimise._smcs import SMCS
from ..optimise._vsa_smcs import VSASMCS

METHODS = ("lm", "lm-jaxopt", "cs", "smcs", "vsa-smcs", "vsa-smcs+lm", "nelder-mead")
"""The method names :func:`calibrate` accepts."""

DEFAULT_MAX_EVALUATIONS = 100_000
"""Default cost-evaluation budget of the metaheuristics (≈ 0.2 s of vmapped cost evaluations
on one CPU core for the 8-pose problem)."""

_POPULATION = {"cs": CuckooSearch, "smcs": SMCS, "vsa-smcs": VSASMCS}


def make_solver(method: str, max_steps: int | None = None, **options: Any) -> eqx.Module:
    """The solver object of ``method`` with its hyper-parameters set from ``options``
    (field names of the solver class; for ``"vsa-smcs+lm"`` the fields of :class:`VSASMCS`,
    and ``max_steps`` for its LM phase)."""
    if method in ("lm", "lm-jaxopt"):
        cls = LevenbergMarquardt if method == "lm" else JaxoptLevenbergMarquardt
        if max_steps is not None:
            options["max_steps"] = max_steps
        return cls(**options)
    if method in _POPULATION:
        return _POPULATION[method](**options)
    if method == "nelder-mead":
        return NelderMead(**options)
    if method == "vsa-smcs+lm":
        local = LevenbergMarquardt() if max_steps is None else LevenbergMarquardt(max_steps=max_steps)
        return VSASMCSThenLM(VSASMCS(**options), local)
    raise ValueError(f"unknown method {method!r}; expected one of {METHODS}")


def _run(solver, problem: CalibrationProblem, key, max_evaluations: int) -> OptimiseResult:
    if isinstance(solver, (LevenbergMarquardt, JaxoptLevenbergMarquardt)):
        return solver.run(problem)
    if isinstance(solver, VSASMCSThenLM):
        return solver.run(problem, key, max_evaluations)
    if isinstance(solver, NelderMead) and solver.x0 is None:
        solver = eqx.tree_at(lambda s: s.x0, solver, problem.initial,
                             is_leaf=lambda x: x is None)
    return minimise(solver, problem.cost, problem.lower, problem.upper, key, max_evaluations)


@eqx.filter_jit
def _run_one(solver, problem, key, max_evaluations):
    return _run(solver, problem, key, max_evaluations)


@eqx.filter_jit
def _run_batch(solver, problems, keys, max_evaluations):
    return jax.vmap(lambda p, k: _run(solver, p, k, max_evaluations))(problems, keys)


def _check_budget(max_evaluations: int) -> int:
    if int(max_evaluations) != max_evaluations or max_evaluations < 1:
        raise ValueError(f"max_evaluations must be a positive integer, got {max_evaluations}")
    return int(max_evaluations)


def calibrate(
    problem: CalibrationProblem,
    method: str = "lm",
    key: PRNGKeyArray | None = None,
    *,
    max_evaluations: int = DEFAULT_MAX_EVALUATIONS,
    max_steps: int | None = None,
    **options: Any,
) -> OptimiseResult:
    """Calibrate: minimise ``S(u)`` (seed 000 eq. 9) over Ω with ``method`` (one of
    :data:`METHODS`). ``key`` seeds the stochastic methods (default ``jax.random.key(0)``);
    the result is deterministic for a given key. ``options`` are the solver's
    hyper-parameters (see :func:`make_solver`)."""
    solver = make_solver(method, max_steps, **options)
    key = jax.random.key(0) if key is None else key
    return _run_one(solver, problem, key, _check_budget(max_evaluations))


def calibrate_batch(
    problems: CalibrationProblem,
    method: str,
    keys: PRNGKeyArray,
    *,
    max_evaluations: int = DEFAULT_MAX_EVALUATIONS,
    max_steps: int | None = None,
    **options: Any,
) -> OptimiseResult:
    """:func:`calibrate` over independent trials: ``problems`` has a leading trial axis on
    every array (e.g. ``jax.vmap(calibration_problem-like builder)`` or
    ``jax.tree.map(lambda *a: jnp.stack(a), *problems)``), ``keys`` one key per trial. One
    compilation for the whole batch; the result has the same leading axis."""
    solver = make_solver(method, max_steps, **options)
    return _run_batch(solver, problems, keys, _check_budget(max_evaluations))
