"""One driver for every iterative optimiser: ``init``/``step``/``terminate`` in ``lax.scan``.

The design follows optimistix (an immutable solver object holding hyper-parameters only,
a separate state pytree, ``init``/``step``/``terminate → (bool, RESULTS)``) and evosax
(population steps vmapped over the population, a fixed generation budget in ``lax.scan``). The scan
length is fixed by the evaluation budget, so that a batch of trials compiles once; once a trial
has terminated (its solver's ``terminate`` holds: the caller's ``target`` reached, or the
solver's own convergence test) or the next step could overrun the budget, its state is frozen
(``lax.cond``; under ``vmap`` JAX evaluates both branches and selects, so a frozen trial still
costs time but its state, history and evaluation count stay put). A solver with a
``restart_schedule`` (CMA-ES's IPOP and BIPOP) runs instead as a ``lax.while_loop`` over runs,
each a ``lax.while_loop`` over generations, within the one budget (:class:`RestartSchedule`).

Stopping is generic: no objective value ends a run unless the caller asks for it with a
``target`` (any real number, negative included). A run ends on its budget, or on a convergence
test the solver states (CMA-ES's step-size collapse, Nelder–Mead's simplex size), and the
status says which (:class:`~stewart_jax.optimise.RESULTS`).

Evaluation counting: ``n_evals`` counts every objective call that the jitted code of one
trial makes, including calls whose value a branch-free (vmapped) step computes and then
discards. A sequential implementation of the same algorithm could make fewer.

The objective is any ``fn(y, args) -> scalar`` over a box of any pytree structure (raveled to
one vector inside); NaN values are read as +inf before any comparison (:func:`nan_to_inf`), so
that a failed evaluation can never become the best. The contract — bounds finite and ordered,
a scalar objective — is checked before anything is traced.

Writing a new solver: subclass :class:`AbstractPopulationSolver` (or :class:`AbstractSolver`),
give it its hyper-parameters as fields (validated in ``__check_init__`` with
:meth:`AbstractSolver.check_field`), implement ``step`` (one generation, on
:class:`PopulationState`) and ``step_evaluations``, using the helpers :func:`evaluate`,
:func:`greedy`, :func:`uniform_in_box`, :func:`draw` and :func:`population_state`;
:func:`minimise` runs it. What the driver asks of a solver is declared on
:class:`AbstractSolver`, each with a default.
"""

from __future__ import annotations

import abc
import functools
from collections.abc import Callable
from typing import Any, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax import lax
from jax.flatten_util import ravel_pytree
from jaxtyping import Array, Bool, Float, Int, PRNGKeyArray, PyTree

from ._box import all_fixed, check_box, check_scalar_objective, fixed_coordinates, nan_to_inf as nan_to_inf
from ._objective import AbstractOptimiser, Objective
from ._random import draw as draw
from ._result import RESULTS, OptimiseResult


def evaluate(fn, xs: Float[Array, "n d"]) -> Float[Array, " n"]:
    """``fn`` over a population, vmapped; NaN → +inf."""
    return jax.vmap(nan_to_inf(fn))(materialize(xs))


def materialize(x):
    """``x``, computed into memory before any use.

    NOTE: XLA:CPU fuses element-wise producers into their consumers and, for the objective,
    repeats them per pose and per leg: a Lévy candidate ``x + α·sp·(x − x_best)·z`` whose
    Mantegna step (``erfinv``, ``log``, ``pow``) is fused into the inverse kinematics is
    recomputed for every pose and leg, which made CS ten times slower than its objective.
    ``lax.optimization_barrier`` is removed before fusion on CPU; the operand of a while loop
    whose trip count XLA cannot prove is not, so ``x`` goes through a loop that runs zero
    times (its body must not be the identity: XLA removes such loops).
    """
    zero = jnp.minimum(jnp.max(jnp.abs(x)), 0.0) > 0.0  # False, opaque to the compiler
    return lax.while_loop(lambda c: c[1], lambda c: (c[0] + c[0], c[1]), (x, zero))[0]


def uniform_in_box(key: PRNGKeyArray, shape: tuple[int, ...], lower, upper) -> Array:
    """Points uniform in the box ``[lower, upper]`` (broadcast over the leading axes)."""
    u = draw(key, u=("uniform", shape))["u"]
    return lower + u * (upper - lower)


def greedy(x, f, x_new, f_new):
    """Keep the new point where it is not worse (Yang & Deb's ``get_best_nest``)."""
    better = f_new <= f
    return jnp.where(better[..., None], x_new, x), jnp.where(better, f_new, f)


class PopulationState(NamedTuple):
    """State of the population methods (CS, SMCS, VSA-SMCS, DE; PSO and CMA-ES start from one).

    - ``population``: ``Float[Array, "n d"]``, the points (a cuckoo method's nests).
    - ``fitness``: ``Float[Array, "n"]``, the objective at each point (+inf for NaN).
    - ``best_x``, ``best_f``: the best point seen so far and its value.
    - ``n_evals``: objective calls so far.
    - ``generation``: generations done (``t`` of Wang et al. 2018, eq. 11).
    """

    population: Float[Array, "n d"]
    fitness: Float[Array, " n"]
    best_x: Float[Array, " d"]
    best_f: Float[Array, ""]
    n_evals: Int[Array, ""]
    generation: Int[Array, ""]


def population_state(population, fitness, n_evals, generation, prev: PopulationState | None = None
                     ) -> PopulationState:
    """A :class:`PopulationState` whose best-so-far is updated from ``population``."""
    i = jnp.argmin(fitness)
    bx, bf = population[i], fitness[i]
    if prev is not None:
        keep = prev.best_f <= bf
        bx = jnp.where(keep, prev.best_x, bx)
        bf = jnp.where(keep, prev.best_f, bf)
    return PopulationState(population, fitness, bx, bf, jnp.asarray(n_evals, jnp.int32),
                           jnp.asarray(generation, jnp.int32))


class AbstractSolver(AbstractOptimiser):
    """An iterative solver over a box, run by :func:`minimise`: hyper-parameters only. Its state
    is any pytree with ``best_x``, ``best_f`` and ``n_evals`` attributes.

    - ``target``: the run stops once the best value is at or below it (status
      ``target_reached``; :meth:`target_reached` is the test a :meth:`terminate` uses); any real
      number, negative included, checked at construction. ``None``: no value stops the run,
      which spends its budget or ends on the solver's own convergence test.

    The driver asks every solver the same questions, each with a default: :meth:`restart_schedule`
    (one run), :meth:`generation_limit` (none beyond the budget), :meth:`with_generation_budget`
    (the solver unchanged). A subclass checks its hyper-parameters in ``__check_init__`` with
    :meth:`check_field`.
    """

    target: eqx.AbstractVar[float | None]

    def __check_init__(self):
        t = self.target
        if t is None or isinstance(t, jax.core.Tracer):
            return
        if not np.all(~np.isnan(np.asarray(t, dtype=np.float64))):
            raise ValueError(f"{type(self).__name__}.target must be None or a real number, got {t!r}")

    def check_field(self, field: str, ok, requirement: str) -> None:
        """Raise at construction when the hyper-parameter ``field`` is out of range, naming it:
        ``ok`` a bool or an array of bools (every element must hold; a tracer passes, see
        :func:`holds`), ``requirement`` what it must be (``"> 0"``)."""
        if not holds(ok):
            raise ValueError(f"{type(self).__name__}.{field} must be {requirement}, got {vars(self)[field]!r}")

    def target_reached(self, state) -> Bool[Array, ""]:
        """``state.best_f ≤ target`` (never, where ``target`` is ``None``)."""
        if self.target is None:
            return jnp.asarray(False)
        return state.best_f <= self.target

    def restart_schedule(self, n_dim: int, max_evaluations: int) -> RestartSchedule | None:
        """The runs of a restart strategy sharing the budget (:class:`RestartSchedule`: CMA-ES's
        IPOP and BIPOP), or ``None`` for one run (default)."""
        del n_dim, max_evaluations
        return None

    def generation_limit(self) -> int | None:
        """The most generations a run takes, where fewer than the budget allows (default
        ``None``: the budget decides)."""
        return None

    def with_generation_budget(self, n_generations: int) -> AbstractSolver:
        """The solver for a run of ``n_generations`` steps: for a solver whose step depends on
        the planned number of generations (VSA-SMCS's ``T_max``); default: itself."""
        del n_generations
        return self

    def solve(self, objective: Objective, y0, lower, upper, key, args, max_evaluations: int) -> OptimiseResult:
        """:func:`minimise` of ``objective.cost``."""
        return minimise(objective.cost, self, lower, upper, key, max_evaluations=max_evaluations, y0=y0, args=args)

    @abc.abstractmethod
    def init(self, fn, y0, lower, upper, key: PRNGKeyArray) -> Any:
        """Initial state (spends :meth:`init_evaluations` objective calls). ``y0`` is the
        start point, or ``None`` where the caller gave none; population methods ignore it."""

    @abc.abstractmethod
    def step(self, fn, state, lower, upper, key: PRNGKeyArray) -> Any:
        """One generation (between ``min`` and ``max`` of :meth:`step_evaluations` calls)."""

    @abc.abstractmethod
    def terminate(self, state) -> tuple[Bool[Array, ""], RESULTS]:
        """Whether the run is over, and why (a :class:`RESULTS` item: ``target_reached``,
        ``successful`` for the solver's own convergence test, ``stalled``): the driver freezes
        the state from here on."""

    def converged(self, history_cost, history_evaluations) -> Bool[Array, ""]:
        """A no-progress test on the run's history, evaluated once at the end: where it holds and
        :meth:`terminate` does not, the status is ``stalled`` (default: never)."""
        del history_cost, history_evaluations
        return jnp.asarray(False)

    def min_evaluations(self, n_dim: int) -> int:
        """Initialisation and :meth:`postprocess` (a budget that allows no step reports the best
        initial point, status ``max_steps_reached``)."""
        return self.init_evaluations(n_dim) + self.final_evaluations(n_dim)

    def postprocess(self, fn, state, lower, upper) -> Any:
        """Called once after the scan (default: nothing to do). Counts its own calls."""
        del fn, lower, upper
        return state

    def final_evaluations(self, n_dim: int) -> int:
        """Objective calls made by :meth:`postprocess` (reserved from the budget)."""
        return 0

    @abc.abstractmethod
    def init_evaluations(self, n_dim: int) -> int:
        """Objective calls made by :meth:`init`."""

    @abc.abstractmethod
    def step_evaluations(self, n_dim: int) -> tuple[int, int]:
        """The fewest and the most objective calls one :meth:`step` makes."""


def init_population(fn, lower, upper, key, n: int) -> PopulationState:
    """``n`` points uniform in Ω and their fitness (``n`` calls)."""
    x = uniform_in_box(key, (n, lower.shape[-1]), lower, upper)
    return population_state(x, evaluate(fn, x), n, 0)


class AbstractPopulationSolver(AbstractSolver):
    """A population method (CS, SMCS, VSA-SMCS, DE, PSO, CMA-ES).

    - ``population_size``: the points evaluated per generation, sampled uniform in Ω at init
      (a cuckoo method's nests, a swarm's particles; CMA-ES's ``λ``, where ``None`` is its
      default and the method starts from its own sample); at least 2.
    - ``target`` (:class:`AbstractSolver`): ``None`` by default in every population method,
      which then spends its budget (fixed-budget comparisons) or ends on its own convergence
      test. The paper's ``ε`` of Wang et al. (2018) is such a target.
    - ``stall_generations``, ``stall_rtol``: over the last ``stall_generations`` generations
      the best value improved by at most ``stall_rtol·|best|`` — the search has settled (status
      ``stalled``). This is evaluated once, at the end, and never shortens a run. Defaults 100
      and 1e-6.
    """

    population_size: eqx.AbstractVar[int | None]
    stall_generations: eqx.AbstractVar[int]
    stall_rtol: eqx.AbstractVar[float]

    def __check_init__(self):
        if self.population_size is not None:
            self.check_field("population_size", self.population_size >= 2, "at least 2")
        self.check_field("stall_generations", self.stall_generations >= 1, ">= 1")
        self.check_field("stall_rtol", self.stall_rtol >= 0, ">= 0")

    def init(self, fn, y0, lower, upper, key):
        del y0  # the population starts uniform in the box
        return init_population(fn, lower, upper, key, self.population_size)

    def terminate(self, state):
        return self.target_reached(state), RESULTS.target_reached

    def converged(self, history_cost, history_evaluations):
        # The last step that did work is the first index holding the final evaluation count
        # (the count only grows; frozen steps repeat it).
        last = jnp.argmax(history_evaluations)
        ref = history_cost[jnp.maximum(last - self.stall_generations, 0)]
        now = history_cost[last]
        return (last >= self.stall_generations) & jnp.isfinite(now) & (ref - now <= self.stall_rtol * jnp.abs(now))

    def init_evaluations(self, n_dim):
        return self.population_size


def holds(ok) -> bool:
    """Whether a hyper-parameter check passed: ``ok`` a bool or an array of bools (every element
    must hold), or a tracer — a hyper-parameter vmapped over settings, which cannot be checked
    at construction and counts as passing (the caller checks the concrete batch of settings)."""
    if isinstance(ok, jax.core.Tracer):
        return True
    return bool(np.all(np.asarray(ok)))


def n_steps_for_budget(solver: AbstractSolver, n_dim: int, max_evaluations: int) -> int:
    """The scan length that a budget of ``max_evaluations`` calls allows (at least 1):
    exact for the population methods, an upper bound where a step's cost varies."""
    lo, _ = solver.step_evaluations(n_dim)
    spare = int(max_evaluations) - solver.init_evaluations(n_dim) - solver.final_evaluations(n_dim)
    return max(1, spare // lo)


def minimise(
    fn,
    solver: AbstractSolver,
    lower: PyTree[Float[Array, "..."]],
    upper: PyTree[Float[Array, "..."]],
    key: PRNGKeyArray,
    *,
    max_evaluations: int,
    y0: PyTree[Float[Array, "..."]] | None = None,
    args: Any = None,
    return_state: bool = False,
):
    """Minimise ``fn(y, args)`` over the box ``[lower, upper]`` with ``solver`` within
    ``max_evaluations`` objective calls (the optimistix argument order).

    ``lower``, ``upper`` (and ``y0``, the start of solvers that use one) may be any pytree of
    arrays with one structure; ``result.params`` has that structure. Pure and jittable
    (``solver`` and the budget are static); deterministic for a given ``key``; vmap it over
    keys and ``args`` for Monte Carlo.

    Returns an :class:`OptimiseResult` (``history_*`` has one entry per scan step, frozen
    entries repeating the last value), and the final state too if ``return_state``.

    Any real dtype is taken: the bounds, the start and the objective's value are cast to float64
    at this boundary (the solvers work in float64; a float32 objective is computed in float32 and
    its value widened). A coordinate with ``lower == upper`` is fixed (pycma's
    ``fixed_variables``): the solver searches the others, ``result.params`` holds it at its
    value, and with every coordinate fixed the one point is evaluated (status ``successful``).
    Only ``lower > upper`` or a bound that is not finite is refused.
    """
    def flat(tree):
        return ravel_pytree(jax.tree.map(lambda a: jnp.asarray(a, jnp.float64), tree))

    lower_flat, unravel = flat(lower)
    upper_flat, _ = flat(upper)
    if jax.tree.structure(lower) != jax.tree.structure(upper) or lower_flat.shape != upper_flat.shape:
        raise ValueError("lower and upper must have the same pytree structure and shapes")
    check_box(lower_flat, upper_flat)
    y0_flat = None
    if y0 is not None:
        y0_flat, _ = flat(y0)
        if y0_flat.shape != lower_flat.shape:
            raise ValueError(f"y0 has {y0_flat.shape[0]} numbers, the box {lower_flat.shape[0]}")
    if int(max_evaluations) != max_evaluations or max_evaluations < 1:
        raise ValueError(f"max_evaluations must be a positive integer, got {max_evaluations}")

    free = fixed_coordinates(lower_flat, upper_flat)

    def full(x):
        return x if free is None else lower_flat.at[free].set(x)

    def flat_fn(x):
        return jnp.asarray(fn(unravel(full(x)), args), jnp.float64)

    check_scalar_objective(lambda x: fn(unravel(full(x)), args),
                           lower_flat if free is None else lower_flat[free])
    if free is not None and free.size == 0:
        result, state = all_fixed(flat_fn, lower_flat), None
    else:
        lo, hi, start = lower_flat, upper_flat, y0_flat
        if free is not None:
            lo, hi = lower_flat[free], upper_flat[free]
            start = None if y0_flat is None else y0_flat[free]
        result, state = _minimise_flat(flat_fn, solver, lo, hi, start, key, int(max_evaluations))
        result = result._replace(params=full(result.params))
    result = result._replace(params=unravel(result.params))
    return (result, state) if return_state else result


class RestartSchedule(NamedTuple):
    """The runs of a restart strategy (CMA-ES's IPOP and BIPOP), as :func:`minimise` runs them.

    - ``first``: the solver of the first run (the caller's start, ``y0`` or a sample).
    - ``levels``: the solvers of the later runs, ``levels[j]`` with the population ``λ₀·2^j``;
      each run starts from a fresh sample.
    - ``bipop``: ``False``: IPOP, run ``k`` after the first on level ``k`` (Auger & Hansen 2005);
      ``True``: BIPOP, those runs interleaved with small-population runs (Hansen 2009).
    - ``small_step``: ``(solver, factor) -> solver``, a small run's solver: its level's with the
      initial step size scaled by ``factor`` (``0.01^v``; 1 for a large run).
    """

    first: AbstractSolver
    levels: tuple[AbstractSolver, ...]
    bipop: bool
    small_step: Callable[[AbstractSolver, Array], AbstractSolver]


class RestartState(NamedTuple):
    """The final state of a run with restarts (``minimise(..., return_state=True)``).

    - ``levels``: the state of the last run of each population level (zeros for a level on which
      no run started; ``levels[0]`` holds the first run unless a later one used that level).
    - ``n_runs``: runs made; ``n_large``: large-population runs after the first.
    - ``evaluations_small``, ``evaluations_large``: objective calls of BIPOP's two regimes (the
      first run counts as small; with IPOP every run counts as large).
    """

    levels: tuple
    n_runs: Int[Array, ""]
    n_large: Int[Array, ""]
    evaluations_small: Int[Array, ""]
    evaluations_large: Int[Array, ""]


def _minimise_flat(fn, solver, lower, upper, y0, key, max_evaluations):
    """One run, or, for a solver with a ``restart_schedule`` (CMA-ES's IPOP and BIPOP), its
    successive runs sharing the budget (:func:`_restarts`)."""
    n_dim = lower.shape[-1]
    plan = solver.restart_schedule(n_dim, max_evaluations)
    first = solver if plan is None else plan.first
    fixed = first.min_evaluations(n_dim)
    if fixed > max_evaluations:
        raise ValueError(f"max_evaluations={max_evaluations} is below the {fixed} calls that "
                         "initialisation alone needs")
    if plan is None:
        return _run(fn, solver, lower, upper, y0, key, max_evaluations)
    return _restarts(fn, plan, lower, upper, y0, key, max_evaluations)


def _restarts(fn, plan: RestartSchedule, lower, upper, y0, key, max_evaluations: int):
    """The runs of ``plan`` within one budget, until the target or until no further run fits.

    After the first run, each run is either *large* — the next level, ``λ₀·2^k`` for the
    ``k``-th, started while a level is left whose initialisation and one generation fit the
    budget — or, with BIPOP, *small*: started while the small runs (the first included) have
    used fewer calls than the large ones, with at most half the large runs' calls, the
    population ``λ₀·(2^k)^{u²}`` rounded to the nearest level in log scale and the initial step
    size ``σ₀·0.01^v`` (``u, v`` uniform in [0, 1), ``k`` the large runs so far; Hansen 2009, as
    pycma's ``fmin(..., bipop=True)``). A run ends on its solver's ``terminate`` or on its
    share of the budget. The best point of all runs is reported; the evaluations add up; the
    history has one entry per generation of any run (best so far, cumulative calls), the
    entries after the last generation repeating the final values; the status is the target
    wherever it was reached, otherwise the last run's (its budget running out: ``stalled`` or
    ``max_steps_reached`` by the history's stall test).

    NOTE: population sizes are array shapes, so a run is a ``lax.switch`` over the levels
    inside a ``lax.while_loop`` over runs: each level is compiled once, however many runs use
    it, and under ``jit`` a run costs only its own generations (a ``lax.while_loop``). Under
    ``vmap`` the switch evaluates every level for every run of the batch's longest sequence.
    """
    n_dim = lower.shape[-1]
    fn = nan_to_inf(fn)
    levels = plan.levels
    lam0 = plan.first.step_evaluations(n_dim)[1]
    n_hist = max(1, int(max_evaluations) // lam0)  # no generation makes fewer than λ₀ calls
    runs = _Runs(fn, lower, upper, y0, n_hist)
    need = jnp.asarray([s.init_evaluations(n_dim) + s.step_evaluations(n_dim)[1] + s.final_evaluations(n_dim)
                        for s in levels], jnp.int32)
    int0 = jnp.asarray(0, jnp.int32)
    states = tuple(_blank_state(runs, s, key) for s in levels)
    hist = (jnp.full(n_hist, jnp.inf), jnp.zeros(n_hist, jnp.int32), int0, int0, jnp.asarray(jnp.inf))
    states, (best_x, best_f, used, status, hist_f, hist_n, pos) = _one_run(
        runs, plan.first, jax.random.fold_in(key, 0), max_evaluations, states, 0, hist)
    small, large = (used, int0) if plan.bipop else (int0, used)
    c = dict(states=states, best_x=best_x, best_f=best_f, used=used, status=status, hist_f=hist_f,
             hist_n=hist_n, pos=pos, n_runs=jnp.asarray(1, jnp.int32), n_large=int0, small=small, large=large,
             done=status == RESULTS.target_reached, stop=jnp.asarray(False))
    c = lax.while_loop(lambda c: ~c["done"] & ~c["stop"],
                       functools.partial(_next_run, runs, plan, need, key, max_evaluations), c)
    return _restart_result(plan, c, n_hist)


class _Runs(NamedTuple):
    """What the runs of :func:`_restarts` share: the objective (NaN read as +inf), the box
    ``(d,)``, the start ``y0`` (``(d,)`` or ``None``) and the history's length."""

    fn: Callable
    lower: Array
    upper: Array
    y0: Array | None
    n_hist: int


def _blank_state(runs: _Runs, solver: AbstractSolver, key):
    """Zeros of the shape and dtype of ``solver``'s state: a level's state before any run."""
    fn, lower, upper, y0, _ = runs
    shapes = jax.eval_shape(lambda: solver.init(fn, y0, lower, upper, key))
    return jax.tree.map(lambda a: jnp.zeros(a.shape, a.dtype), shapes)


def _one_run(runs: _Runs, solver, key, allowance, states, j, hist):
    """A run of ``solver`` within ``allowance`` calls; its state replaces ``states[j]``.

    ``hist`` is ``(hist_f, hist_n, pos, used, best_before)``: the history (``(n_hist,)``, best
    value and cumulative calls), its next entry, the calls and the best value before this run.
    Returns the states and ``(best_x, best_f, n_evals, status, hist_f, hist_n, pos)``."""
    fn, lower, upper, y0, n_hist = runs
    n_dim = lower.shape[-1]
    hist_f, hist_n, pos, used, best_before = hist
    per_step = solver.step_evaluations(n_dim)[1] + solver.final_evaluations(n_dim)
    k_init, k_steps = jax.random.split(key)
    state = solver.init(fn, y0, lower, upper, k_init)

    def going(c):
        st, _, _, p = c
        return ~solver.terminate(st)[0] & (st.n_evals + per_step <= allowance) & (p < n_hist)

    def generation(c):
        st, hf, hn, p = c
        st = solver.step(fn, st, lower, upper, jax.random.fold_in(k_steps, p))
        hf = hf.at[p].set(jnp.minimum(best_before, st.best_f))
        hn = hn.at[p].set(used + jnp.asarray(st.n_evals, jnp.int32))
        return st, hf, hn, p + 1

    state, hist_f, hist_n, pos = lax.while_loop(going, generation, (state, hist_f, hist_n, pos))
    state = solver.postprocess(fn, state, lower, upper)
    done, why = solver.terminate(state)
    status = RESULTS.where(done, why, RESULTS.max_steps_reached)
    states = states[:j] + (state,) + states[j + 1:]
    return states, (state.best_x, state.best_f, jnp.asarray(state.n_evals, jnp.int32), status,
                    hist_f, hist_n, pos)


def _next_run(runs: _Runs, plan: RestartSchedule, need, key, max_evaluations: int, c: dict) -> dict:
    """The loop state ``c`` of :func:`_restarts` after its next run (small or large, its level
    and its share of the budget chosen), or with ``stop`` set where none fits; ``need``
    (``(levels,)``): the calls of a level's initialisation and one generation."""
    n_levels = len(plan.levels)
    remaining = max_evaluations - c["used"]
    k_run, k_uv = jax.random.split(jax.random.fold_in(key, c["n_runs"]))
    u, v = jax.random.uniform(k_uv, (2,), jnp.float64)
    j_small = jnp.clip(jnp.floor(c["n_large"] * u * u + 0.5).astype(jnp.int32), 0, n_levels - 1)
    allow_small = jnp.minimum(remaining, c["large"] // 2)
    go_small = plan.bipop & (c["small"] < jnp.maximum(1, c["large"])) & (need[j_small] <= allow_small)
    j_large = c["n_large"] + 1
    j_large_c = jnp.minimum(j_large, n_levels - 1)
    go_large = (j_large < n_levels) & (need[j_large_c] <= remaining)
    j = jnp.where(go_small, j_small, j_large_c)
    allowance = jnp.where(go_small, allow_small, remaining)
    factor = jnp.where(go_small, 0.01**v, 1.0)
    run = functools.partial(_run_level, runs, plan, j, k_run, allowance, factor, go_small)
    return lax.cond(go_small | go_large, run, lambda c: dict(c, stop=jnp.asarray(True)), c)


def _run_level(runs: _Runs, plan: RestartSchedule, j, k_run, allowance, factor, go_small, c: dict) -> dict:
    """The loop state ``c`` after a run on level ``j`` (a ``lax.switch`` over the levels) within
    ``allowance`` calls, its initial step size scaled by ``factor``: the best point kept, the
    calls added to the small or the large runs' count."""
    levels = plan.levels

    def branch(i):
        def go(states, hist):
            return _one_run(runs, plan.small_step(levels[i], factor), k_run, allowance, states, i, hist)
        return go

    hist = (c["hist_f"], c["hist_n"], c["pos"], c["used"], c["best_f"])
    states, (bx, bf, n, st, hf, hn, p) = lax.switch(j, [branch(i) for i in range(len(levels))],
                                                   c["states"], hist)
    better = bf < c["best_f"]
    return dict(
        c, states=states, best_x=jnp.where(better, bx, c["best_x"]),
        best_f=jnp.where(better, bf, c["best_f"]), used=c["used"] + n, status=st,
        hist_f=hf, hist_n=hn, pos=p, n_runs=c["n_runs"] + 1,
        n_large=c["n_large"] + jnp.where(go_small, 0, 1).astype(jnp.int32),
        small=c["small"] + jnp.where(go_small, n, 0), large=c["large"] + jnp.where(go_small, 0, n),
        done=st == RESULTS.target_reached)


def _restart_result(plan: RestartSchedule, c: dict, n_hist: int) -> tuple[OptimiseResult, RestartState]:
    """The result of :func:`_restarts` from its final loop state ``c`` (the history's entries
    past ``pos`` set to the final values, the status decided) and its :class:`RestartState`."""
    written = jnp.arange(n_hist) < c["pos"]
    hist_f = jnp.where(written, c["hist_f"], c["best_f"])
    hist_n = jnp.where(written, c["hist_n"], c["used"])
    stalled = plan.first.converged(hist_f, hist_n)
    status = RESULTS.where(c["status"] == RESULTS.max_steps_reached,
                           RESULTS.where(stalled, RESULTS.stalled, RESULTS.max_steps_reached), c["status"])
    status = RESULTS.where(~jnp.isfinite(c["best_f"]), RESULTS.nonfinite, status)
    result = OptimiseResult(c["best_x"], c["best_f"], c["used"], status, hist_f, hist_n)
    return result, RestartState(c["states"], c["n_runs"], c["n_large"], c["small"], c["large"])


def _run(fn, solver, lower, upper, y0, key, max_evaluations):
    """One run of ``solver`` within the budget: a ``lax.scan`` of the steps the budget allows."""
    n_dim = lower.shape[-1]
    n_steps = n_steps_for_budget(solver, n_dim, max_evaluations)
    limit = solver.generation_limit()
    if limit is not None:
        n_steps = min(n_steps, int(limit))
    solver = solver.with_generation_budget(n_steps)
    _, max_per_step = solver.step_evaluations(n_dim)
    max_per_step += solver.final_evaluations(n_dim)
    fn = nan_to_inf(fn)
    k_init, k_steps = jax.random.split(key)
    state = solver.init(fn, y0, lower, upper, k_init)

    def body(state, k):
        frozen = solver.terminate(state)[0] | (state.n_evals + max_per_step > max_evaluations)
        state = lax.cond(frozen, lambda s: s,
                         lambda s: solver.step(fn, s, lower, upper, k), state)
        return state, (state.best_f, state.n_evals)

    state, (hist_f, hist_n) = lax.scan(body, state, jax.random.split(k_steps, n_steps))
    state = solver.postprocess(fn, state, lower, upper)
    hist_n = jnp.asarray(hist_n, jnp.int32)
    done, why = solver.terminate(state)
    stalled = solver.converged(hist_f, hist_n)
    status = RESULTS.where(~jnp.isfinite(state.best_f), RESULTS.nonfinite,
                           RESULTS.where(done, why, RESULTS.where(stalled, RESULTS.stalled,
                                                                 RESULTS.max_steps_reached)))
    result = OptimiseResult(
        params=state.best_x,
        cost=state.best_f,
        n_evaluations=jnp.asarray(state.n_evals, jnp.int32),
        status=status,
        history_cost=hist_f,
        history_evaluations=hist_n,
    )
    return result, state
