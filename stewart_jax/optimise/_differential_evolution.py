"""Differential evolution, DE/rand/1/bin.

Storn R., Price K., "Differential Evolution – A Simple and Efficient Heuristic for Global
Optimization over Continuous Spaces", Journal of Global Optimization 11 (1997) 341–359, §2
(scheme DE1): for each target vector ``x_i`` of the population,

1. mutation, eq. (1): ``v_i = x_r1 + F·(x_r2 − x_r3)`` with ``r1, r2, r3`` distinct random indices,
   all different from ``i``;
2. binomial crossover, eq. (2): ``u_ij = v_ij`` if ``rand_j ≤ CR`` or ``j = rnbr(i)`` (one
   coordinate always taken from ``v_i``), else ``x_ij``;
3. selection: ``u_i`` replaces ``x_i`` if it is not worse (greedy).

NOTE: Ω is kept by clipping the trial vector ``u_i`` to the box (the paper is unbounded). The
three donors are drawn as three distinct offsets ``1 … n−1`` from ``i`` (modulo ``n``), which
makes them distinct from each other and from ``i`` with one sort per nest.
"""

from __future__ import annotations

import jax.numpy as jnp

from ._driver import AbstractPopulationSolver, draw, evaluate, greedy, population_state


class DifferentialEvolution(AbstractPopulationSolver):
    """DE/rand/1/bin (Storn & Price 1997) over the box Ω.

    - ``population_size`` (NP): population size; 37, the cuckoo methods' population, so that every
      population method starts from the same points for a given key (common random numbers).
      Storn & Price suggest 5–10 × the dimension; at the budgets of Wang et al. (2018)'s study
      (10⁴–10⁵ evaluations in 36 dimensions) that would leave only tens of generations.
    - ``mutation`` (F): 0.5; ``crossover`` (CR): 0.9 — Storn & Price's recommended start
      ("F = 0.5 … CR = 0.1, or 0.9 … for a quick convergence").
    - ``target``, ``stall_generations``, ``stall_rtol``: as for every population method.

    Evaluations: ``population_size`` at init and per generation.
    """

    population_size: int = 37
    mutation: float = 0.5
    crossover: float = 0.9
    target: float | None = None
    stall_generations: int = 100
    stall_rtol: float = 1e-6

    def __check_init__(self):
        self.check_field("population_size", self.population_size >= 4, ">= 4 (a target and three distinct donors)")
        self.check_field("mutation", (self.mutation > 0) & (self.mutation <= 2), "in (0, 2]")
        self.check_field("crossover", (self.crossover >= 0) & (self.crossover <= 1), "a probability in [0, 1]")

    def step(self, fn, state, lower, upper, key):
        x = state.population
        n, d = x.shape
        rnd = draw(key, pick=("uniform", (n, n - 1)), cross=("uniform", (n, d)), jrand=("uniform", (n,)))
        offsets = jnp.argsort(rnd["pick"], axis=-1)[:, :3] + 1
        r = (jnp.arange(n)[:, None] + offsets) % n
        v = x[r[:, 0]] + self.mutation * (x[r[:, 1]] - x[r[:, 2]])
        forced = jnp.floor(rnd["jrand"] * d).astype(jnp.int32)
        take = (rnd["cross"] <= self.crossover) | (jnp.arange(d)[None, :] == forced[:, None])
        u = jnp.clip(jnp.where(take, v, x), lower, upper)
        nests, fit = greedy(x, state.fitness, u, evaluate(fn, u))
        return population_state(nests, fit, state.n_evals + n, state.generation + 1, state)

    def step_evaluations(self, n_dim):
        return self.population_size, self.population_size
