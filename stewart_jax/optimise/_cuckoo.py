"""Cuckoo search (CS).

Yang X.-S., Deb S., "Cuckoo search via Lévy flights", Proc. World Congress on Nature &
Biologically Inspired Computing (NaBIC 2009), IEEE, 210–214; steps as in the authors'
reference code (Yang, *Nature-Inspired Metaheuristic Algorithms*, 2nd ed., 2010): per
generation

1. Lévy flights (``get_cuckoos``): ``x' = x + α·sp ⊙ (x − x_best) ⊙ N(0, 1)`` with ``sp``
   Mantegna steps (:mod:`.levy`), clipped to Ω; greedy replacement (``get_best_nest``).
2. Discovery (``empty_nests``): ``x' = x + r·(x_π1 − x_π2) ⊙ K`` with ``r ~ U(0, 1)``, two
   random permutations ``π1, π2`` of the nests and ``K_ij ~ Bernoulli(pa)``, clipped to Ω;
   greedy replacement.

NOTE: the reference code writes ``K = rand > pa`` (each coordinate changes with probability
``1 − pa``); here a coordinate is discovered with probability ``pa``, the probability the
paper states. Both phases evaluate every nest: ``2·population_size`` calls per generation.
"""

from __future__ import annotations

import jax.numpy as jnp

from ._driver import (
    AbstractPopulationSolver,
    PopulationState,
    draw,
    evaluate,
    greedy,
    population_state,
)
from ._levy import BETA, mantegna_from_normals


def check_probability(solver: AbstractPopulationSolver, name: str, p) -> None:
    """A cuckoo method's discovery or abandonment probability (``pa``, ``lu``) lies in [0, 1]
    (elementwise for an array of settings)."""
    solver.check_field(name, (0.0 <= p) & (p <= 1.0), "a probability in [0, 1]")


def check_levy(solver: AbstractPopulationSolver, beta, alpha=None) -> None:
    """The Lévy flight's exponent ``beta`` in (0, 2] (Mantegna's algorithm) and, where the
    method has one, its step scale ``alpha`` > 0."""
    solver.check_field("beta", (0.0 < beta) & (beta <= 2.0), "a Lévy exponent in (0, 2]")
    if alpha is not None:
        solver.check_field("alpha", alpha > 0.0, "> 0")


def check_n_worst(solver: AbstractPopulationSolver, n_worst: int) -> None:
    """The simplex operations of SMCS and VSA-SMCS act on 1 to ``population_size − 1`` worst nests."""
    n = solver.population_size
    solver.check_field("n_worst", (1 <= n_worst) & (n_worst <= n - 1), f"in [1, population_size − 1 = {n - 1}]")


def levy_flight_phase(fn, state: PopulationState, lower, upper, rnd, alpha: float, beta: float
                      ) -> PopulationState:
    """CS step 1: Lévy flights around the current best, clipped to Ω, greedy. ``rnd``:
    standard normals ``zu``, ``zv``, ``z`` of the population's shape."""
    x = state.population
    sp = mantegna_from_normals(rnd["zu"], rnd["zv"], beta)
    x_new = x + alpha * sp * (x - state.best_x) * rnd["z"]
    x_new = jnp.clip(x_new, lower, upper)
    f_new = evaluate(fn, x_new)
    nests, fit = greedy(x, state.fitness, x_new, f_new)
    return population_state(nests, fit, state.n_evals + x.shape[0], state.generation, state)


def discovery_phase(fn, state: PopulationState, lower, upper, rnd, pa: float) -> PopulationState:
    """CS step 2: a fraction ``pa`` of coordinates is discovered and rebuilt by a biased
    random walk between two random nests, clipped to Ω, greedy. ``rnd``: uniforms ``mask``
    (population's shape), ``perm`` (2, n) — permutations by argsort — and ``r`` (1,)."""
    x = state.population
    n = x.shape[0]
    mask = rnd["mask"] < pa
    p1, p2 = jnp.argsort(rnd["perm"], axis=-1)
    x_new = x + rnd["r"][0] * (x[p1] - x[p2]) * mask
    x_new = jnp.clip(x_new, lower, upper)
    f_new = evaluate(fn, x_new)
    nests, fit = greedy(x, state.fitness, x_new, f_new)
    return population_state(nests, fit, state.n_evals + n, state.generation, state)


def cs_randoms(key, n: int, d: int):
    """Every random number of one CS generation, from one generator call."""
    return draw(key, zu=("normal", (n, d)), zv=("normal", (n, d)), z=("normal", (n, d)),
                mask=("uniform", (n, d)), perm=("uniform", (2, n)), r=("uniform", (1,)))


def cs_generation(fn, state: PopulationState, lower, upper, key, alpha: float, beta: float, pa: float
                  ) -> PopulationState:
    """One CS generation: Lévy flights then discovery (``2·population_size`` calls), generation + 1."""
    rnd = cs_randoms(key, *state.population.shape)
    state = levy_flight_phase(fn, state, lower, upper, rnd, alpha, beta)
    state = discovery_phase(fn, state, lower, upper, rnd, pa)
    return state._replace(generation=state.generation + 1)


class CuckooSearch(AbstractPopulationSolver):
    """Cuckoo search (Yang & Deb 2009).

    - ``population_size``: the number of nests; 25, the value of Yang & Deb's paper and code.
    - ``pa``: discovery probability; 0.25 (Yang & Deb).
    - ``alpha``: Lévy step scale; 0.01 (Yang & Deb's code: "0.01 … to avoid the flights
      becoming too aggressive").
    - ``beta``: Lévy exponent; 1.5 (Yang & Deb; Wang et al. 2018, eq. 10).
    - ``target``: stop once the best value is at or below it (any real value); ``None`` by
      default (run the whole budget — a fixed-budget comparison is what the study needs; set it
      to the expected noise floor to stop early).
    - ``stall_generations``, ``stall_rtol``: the convergence test reported in the status
      (:class:`~stewart_jax.optimise.AbstractPopulationSolver`).
    """

    population_size: int = 25
    pa: float = 0.25
    alpha: float = 0.01
    beta: float = BETA
    target: float | None = None
    stall_generations: int = 100
    stall_rtol: float = 1e-6

    def __check_init__(self):
        check_probability(self, "pa", self.pa)
        check_levy(self, self.beta, self.alpha)

    def step(self, fn, state, lower, upper, key):
        return cs_generation(fn, state, lower, upper, key, self.alpha, self.beta, self.pa)

    def step_evaluations(self, n_dim):
        return 2 * self.population_size, 2 * self.population_size
