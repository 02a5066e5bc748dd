"""One entry point for every calibration method, read from one registry.

``calibrate(problem, method, key, ...)`` runs one trial; ``calibrate_batch(problems, method,
keys, ...)`` vmaps over independent trials (a :class:`CalibrationProblem` whose arrays have a
leading trial axis, and one PRNG key per trial) in a single compiled call. Both are jitted
with the method, its options and the budget static: repeated calls with the same settings
and shapes reuse the compiled code.

The registry :data:`METHOD_REGISTRY` (name → :class:`Method`) is the only list of methods: the
CLI's ``--method`` choices, the study's labels, the tests and the Makefile's demo read it.
Adding an optimiser is one module in :mod:`stewart_jax.optimise` and one
:func:`register_method` call here. Every method runs through one protocol: the problem becomes an
:class:`~stewart_jax.optimise.Objective` (:func:`objective`) and the solver's ``solve`` (one trial)
or ``solve_batch`` (a batch) runs it; nothing here depends on what kind of solver it is.

``lm-batched`` (:class:`~stewart_jax.optimise.BatchedLevenbergMarquardt`) is the fast path of
``calibrate_batch``: its ``solve_batch``, instead of vmapping one solve per trial, runs
:func:`~stewart_jax.optimise.least_squares_batch` on the whole batch, with one least-squares
block per leg where the family declares its legs' parameters disjoint
(``mechanism.leg_parameters``) and the family's closed-form ``parameter_jacobian`` where it has
one. Like ``lm`` it is unbounded: it starts at the nominal parameters and reports its end point
in Ω or not (``cost`` is +inf, status ``nonfinite``, where a measured pose is unreachable there).

Budgets: ``max_evaluations`` (cost evaluations) for the metaheuristics and Nelder–Mead, so
that methods compare at the same number of evaluations; ``max_steps`` (LM iterations, each one
residual vector and one Jacobian) for the LM methods. The hybrid takes both.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator, Mapping
from typing import Any, Literal

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import PRNGKeyArray

from ..mechanism._abstract import AbstractMechanism
from ..optimise._batched_lm import BatchedLevenbergMarquardt, Blocks
from ..optimise._cma_es import CMAES
from ..optimise._cuckoo import CuckooSearch
from ..optimise._differential_evolution import DifferentialEvolution
from ..optimise._hybrid import VSASMCSThenLM
from ..optimise._jaxopt_lm import JaxoptLevenbergMarquardt
from ..optimise._levenberg_marquardt import LevenbergMarquardt
from ..optimise._objective import AbstractOptimiser, Objective
from ..optimise._pso import ParticleSwarm
from ..optimise._result import OptimiseResult
from ..optimise._simplex import NelderMead
from ..optimise._smcs import SMCS
from ..optimise._vsa_smcs import VSASMCS
from ._problem import CalibrationData, CalibrationProblem, population_objective

Kind = Literal["least_squares", "box", "hybrid"]


@dataclasses.dataclass(frozen=True)
class Method:
    """A calibration method.

    - ``name``: the CLI/JSON name (``"vsa-smcs"``).
    - ``label``: the name in tables and figures (``"VSA-SMCS"``).
    - ``factory``: ``(**options) -> solver``; options are the solver's hyper-parameters (a
      ``"least_squares"`` or ``"hybrid"`` factory takes ``max_steps``, the LM step budget).
    - ``kind``: which budget it takes, for listings and the command line's checks (it does not
      change how the method runs: every solver's ``solve`` does): ``"least_squares"`` (residual
      vector from the nominal parameters, budget ``max_steps``), ``"box"`` (cost over Ω within
      ``max_evaluations``, from the nominal parameters where the solver uses a start),
      ``"hybrid"`` (both budgets).
    - ``reference``: the citation shown in listings.
    """

    name: str
    label: str
    factory: Callable[..., eqx.Module]
    kind: Kind
    reference: str = ""


METHOD_REGISTRY: dict[str, Method] = {}


def register_method(name: str, label: str, factory: Callable[..., eqx.Module], kind: Kind,
                    reference: str = "") -> Method:
    """Add a method to the registry (and so to ``calibrate``, the CLI, the study and the tests)."""
    if name in METHOD_REGISTRY:
        raise ValueError(f"calibration method {name!r} is already registered")
    if kind not in ("least_squares", "box", "hybrid"):
        raise ValueError(f"kind must be 'least_squares', 'box' or 'hybrid', got {kind!r}")
    METHOD_REGISTRY[name] = m = Method(name, label, factory, kind, reference)
    return m


def _hybrid(max_steps: int | None = None, **options: Any) -> VSASMCSThenLM:
    local = BatchedLevenbergMarquardt() if max_steps is None else BatchedLevenbergMarquardt(max_steps=max_steps)
    return VSASMCSThenLM(VSASMCS(**options), local)


register_method("lm", "LM (optimistix)", LevenbergMarquardt, "least_squares",
                "Levenberg 1944, Marquardt 1963; optimistix")
register_method("lm-jaxopt", "LM (jaxopt)", JaxoptLevenbergMarquardt, "least_squares",
                "Levenberg–Marquardt as implemented by jaxopt (cross-check)")
register_method("lm-batched", "LM (batched)", BatchedLevenbergMarquardt, "least_squares",
                "Levenberg 1944, Marquardt 1963, Moré 1978, Nielsen 1999; one small problem per leg, batched")
register_method("cs", "CS", CuckooSearch, "box", "Yang & Deb 2009")
register_method("smcs", "SMCS", SMCS, "box", "Wang et al. 2018, §2.1")
register_method("vsa-smcs", "VSA-SMCS", VSASMCS, "box", "Wang et al. 2018, §2.2–2.3")
register_method("vsa-smcs+lm", "VSA-SMCS+LM", _hybrid, "hybrid", "VSA-SMCS, then the batched LM from its best nest")
register_method("nelder-mead", "Nelder-Mead (bounded)", NelderMead, "box",
                "Nelder & Mead 1965; Gao & Han 2012 coefficients; bounded by projection")
register_method("cma-es", "CMA-ES", CMAES, "box", "Hansen 2016, The CMA Evolution Strategy: A Tutorial")
register_method("de", "DE (rand/1/bin)", DifferentialEvolution, "box", "Storn & Price 1997")
register_method("pso", "PSO", ParticleSwarm, "box", "Kennedy & Eberhart 1995; Shi & Eberhart 1998 (inertia)")

DEFAULT_MAX_EVALUATIONS = 100_000
"""Default cost-evaluation budget of the metaheuristics (≈ 0.2 s of vmapped cost evaluations
on one CPU core for the 8-pose problem)."""


class _Labels(Mapping[str, str]):
    """A live read-only view name → label of the registry."""

    def __getitem__(self, name: str) -> str:
        return METHOD_REGISTRY[name].label

    def __iter__(self) -> Iterator[str]:
        return iter(METHOD_REGISTRY)

    def __len__(self) -> int:
        return len(METHOD_REGISTRY)


METHOD_LABELS: Mapping[str, str] = _Labels()
"""Table labels of the registered methods (name → label), read from the registry."""


def method(name: str) -> Method:
    """The registered :class:`Method` of ``name``."""
    try:
        return METHOD_REGISTRY[name]
    except KeyError:
        raise ValueError(f"unknown method {name!r}; expected one of {tuple(METHOD_REGISTRY)}") from None


def method_label(name: str) -> str:
    """The table label of a method (the name itself when it is not registered)."""
    return METHOD_REGISTRY[name].label if name in METHOD_REGISTRY else name


def make_solver(name: str, max_steps: int | None = None, **options: Any) -> AbstractOptimiser:
    """The solver object of method ``name`` with its hyper-parameters set from ``options``
    (field names of the solver class; for ``"vsa-smcs+lm"`` the fields of :class:`VSASMCS`,
    and ``max_steps`` for its LM phase). ``max_steps`` goes to the methods whose ``kind`` takes
    a step budget (``"least_squares"``, ``"hybrid"``) and is ignored by the others. ``epsilon``
    (the paper's ``ε``) is accepted as the population methods' ``target``."""
    m = method(name)
    if "epsilon" in options:
        options["target"] = options.pop("epsilon")
    if max_steps is not None and m.kind != "box":  # the kind declares the step budget
        options["max_steps"] = max_steps
    solver = m.factory(**options)
    if not isinstance(solver, AbstractOptimiser):
        raise TypeError(f"method {name!r}: its factory made a {type(solver).__name__}, not an optimiser with `solve`")
    return solver


def _residuals(u, problem):
    return problem.residuals(u)


_cost = population_objective


def _jacobian(mechanism: AbstractMechanism):
    """The residual's Jacobian, ``−∂q/∂u``, where the family has a closed-form
    ``parameter_jacobian``: its per-leg blocks (in :func:`_leg_blocks`' order) where the legs'
    parameters are disjoint, else dense; ``None`` (the solver's own column-compressed autodiff)
    where it has none."""
    if not mechanism.has_closed_form_parameter_jacobian:
        return None
    if mechanism.leg_parameters is not None:
        def legs(u, problem):
            jac = -problem.mechanism.with_params(u).leg_parameter_jacobian(problem.data.poses)  # (legs, m, k)
            return jac if problem.weights is None else jac * problem.weights[None, :, None]

        return legs

    def dense(u, problem):
        jac = -problem.mechanism.with_params(u).parameter_jacobian(problem.data.poses)  # (6m, n)
        return jac if problem.weights is None else jac * jnp.repeat(problem.weights, 6)[:, None]

    return dense


POSE_BUCKET_MIN = 8
"""The smallest padded pose count (the paper's simulation study measures 8 poses)."""


def pose_bucket(m: int) -> int:
    """The pose count a least-squares calibration of ``m`` poses is compiled for: the next power
    of two, at least :data:`POSE_BUCKET_MIN` (9 and 12 poses share the program of 16; 120 poses
    run as 128)."""
    return max(POSE_BUCKET_MIN, 1 << (int(m) - 1).bit_length())


def padded(problem: CalibrationProblem) -> CalibrationProblem:
    """``problem`` with its poses padded to :func:`pose_bucket` rows: copies of the first pose,
    weighted 0 (their residuals, Jacobian rows and cost terms are zero, and their reachability
    is not asked), so that the least-squares solution is the unpadded one, to rounding.

    NOTE: padding is for the least-squares methods, whose compilation dominates a command's
    time; the population methods keep the family's population layout, which has no weights."""
    m = problem.data.n_poses
    size = pose_bucket(m)
    if size == m or problem.weights is not None or problem.data.poses.ndim != 2:
        return problem
    rows = np.concatenate([np.arange(m), np.zeros(size - m, int)])
    data = CalibrationData(*(None if f is None else jnp.asarray(np.asarray(f)[rows]) for f in problem.data))
    weights = jnp.asarray(np.arange(size) < m, dtype=jnp.float64)
    return CalibrationProblem(data, problem.mechanism, problem.lower, problem.upper, problem.initial, weights)


def _leg_blocks(problem: CalibrationProblem) -> Blocks | None:
    """One least-squares block per leg (rows ``6j + i`` of leg ``i`` at pose ``j``, the leg's
    parameters) where the family declares its legs' parameters disjoint."""
    legs = problem.mechanism.leg_parameters
    if legs is None:
        return None
    m = problem.data.poses.shape[-2]
    rows = np.arange(m)[None, :] * len(legs) + np.arange(len(legs))[:, None]
    return Blocks(rows, np.asarray(legs))


def objective(problem: CalibrationProblem) -> Objective:
    """The calibration problem as every optimiser sees it: the cost ``S(u)`` (Wang et al. 2018,
    eq. 9; +inf where a pose is unreachable), the residual ``E(u)`` (eq. 8), the family's
    closed-form Jacobian where it has one, and one block per leg where its legs' parameters are
    disjoint. Built from static properties only (usable under ``jit``)."""
    return Objective(_cost, _residuals, _jacobian(problem.mechanism), _leg_blocks(problem))


@eqx.filter_jit
def _run_one(solver, problem, key, max_evaluations):
    return solver.solve(objective(problem), problem.initial, problem.lower, problem.upper, key, problem,
                        max_evaluations)


@eqx.filter_jit
def _run_batch(solver, problems, keys, max_evaluations):
    return solver.solve_batch(objective(problems), problems.initial, problems.lower, problems.upper, keys, problems,
                              max_evaluations)


def _check_budget(max_evaluations: int, solver=None, problem: CalibrationProblem | None = None) -> int:
    """The budget, checked before any work: a positive integer that covers the solver's
    initialisation (for the methods that count cost evaluations)."""
    if int(max_evaluations) != max_evaluations or max_evaluations < 1:
        raise ValueError(f"max_evaluations must be a positive integer, got {max_evaluations}")
    if solver is not None and problem is not None:
        n = problem.initial.shape[-1]
        fixed = solver.min_evaluations(n)
        if fixed > max_evaluations:
            raise ValueError(f"max_evaluations={max_evaluations} is below the {fixed} cost evaluations that "
                             f"{type(solver).__name__} needs to initialise on {n} parameters")
    return int(max_evaluations)


def calibrate(
    problem: CalibrationProblem,
    method: str = "lm-batched",
    key: PRNGKeyArray | None = None,
    *,
    max_evaluations: int = DEFAULT_MAX_EVALUATIONS,
    max_steps: int | None = None,
    **options: Any,
) -> OptimiseResult:
    """Calibrate: minimise ``S(u)`` (Wang et al. 2018, eq. 9) over Ω with ``method`` (a name in
    :data:`METHOD_REGISTRY`). ``key`` seeds the stochastic methods (default
    ``jax.random.key(0)``); the result is deterministic for a given key. ``options`` are the
    solver's hyper-parameters (see :func:`make_solver`)."""
    solver = make_solver(method, max_steps, **options)
    key = jax.random.key(0) if key is None else key
    budget = _check_budget(max_evaluations, solver, problem)
    if METHOD_REGISTRY[method].kind == "least_squares":
        problem = padded(problem)
    if isinstance(solver, BatchedLevenbergMarquardt):
        solver = _traced_settings(solver)
    return _run_one(solver, problem, key, budget)


def _traced_settings(solver: BatchedLevenbergMarquardt) -> BatchedLevenbergMarquardt:
    """The batched LM with its step budget, tolerances and damping as arrays, so that one
    compiled program serves every ``max_steps``, ``ftol``, ``xtol``, ``gtol`` and damping (as
    Python numbers each value compiles its own); the same operations on the same values."""
    tolerances = (solver.ftol, solver.xtol, solver.gtol, solver.initial_damping, solver.min_damping)
    values = (np.asarray(solver.max_steps, np.int32), *(np.asarray(v, np.float64) for v in tolerances))
    return eqx.tree_at(lambda s: (s.max_steps, s.ftol, s.xtol, s.gtol, s.initial_damping, s.min_damping), solver,
                       values)


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
    return _run_batch(solver, problems, keys, _check_budget(max_evaluations, solver, problems))
