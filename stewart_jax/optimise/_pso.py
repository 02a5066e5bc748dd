"""Particle swarm optimisation with an inertia weight.

Kennedy J., Eberhart R., "Particle swarm optimization", Proc. IEEE International Conference on
Neural Networks (1995) 1942–1948 (velocity and position update, the personal and the global
best); the inertia weight ``w`` of Shi Y., Eberhart R., "A modified particle swarm optimizer",
IEEE World Congress on Computational Intelligence (1998) 69–73, eq. (2a):

    v ← w·v + c₁·r₁ ⊙ (p_i − x) + c₂·r₂ ⊙ (p_g − x),    x ← x + v,

``r₁, r₂ ~ U(0, 1)`` per coordinate, ``|v|`` limited to ``V_max``. Default coefficients
``w = 0.7298``, ``c₁ = c₂ = 1.49618``: the constriction setting of Clerc M., Kennedy J., "The
particle swarm — explosion, stability, and convergence in a multidimensional complex space",
IEEE Trans. Evol. Comput. 6 (2002) 58–73, written in the inertia form (Eberhart R., Shi Y.,
"Comparing inertia weights and constriction factors in particle swarm optimization", CEC 2000,
who also advise ``V_max`` = the box width with these values).

NOTE: Ω is kept by clipping the new position to the box and zeroing the velocity components
that hit a bound ("absorbing walls"). Velocities start at zero, so the first move is the pull
towards the best initial particle.
"""

from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp
from jaxtyping import Array, Float, Int

from ._driver import AbstractPopulationSolver, draw, evaluate, init_population


class PSOState(NamedTuple):
    """State of :class:`ParticleSwarm`: positions ``population`` and ``velocities``
    (``Float[Array, "n d"]``), each particle's best ``personal_x``/``personal_f``, the swarm's
    best ``best_x``/``best_f``, ``n_evals`` and ``generation``."""

    population: Float[Array, "n d"]
    velocities: Float[Array, "n d"]
    personal_x: Float[Array, "n d"]
    personal_f: Float[Array, " n"]
    best_x: Float[Array, " d"]
    best_f: Float[Array, ""]
    n_evals: Int[Array, ""]
    generation: Int[Array, ""]


class ParticleSwarm(AbstractPopulationSolver):
    """PSO with inertia (Kennedy & Eberhart 1995; Shi & Eberhart 1998) over the box Ω.

    - ``population_size``: swarm size; 37, the cuckoo methods' population, so that every population
      method starts from the same points for a given key (common random numbers).
    - ``inertia`` (w) 0.7298, ``cognitive`` (c₁) and ``social`` (c₂) 1.49618: Clerc & Kennedy's
      constriction setting.
    - ``v_max``: velocity limit as a fraction of Ω's width per axis; 1.0 (Eberhart & Shi 2000).
    - ``target``, ``stall_generations``, ``stall_rtol``: as for every population method.

    Evaluations: ``population_size`` at init and per generation.
    """

    population_size: int = 37
    inertia: float = 0.7298
    cognitive: float = 1.49618
    social: float = 1.49618
    v_max: float = 1.0
    target: float | None = None
    stall_generations: int = 100
    stall_rtol: float = 1e-6

    def __check_init__(self):
        self.check_field("inertia", (self.inertia >= 0) & (self.inertia < 1), "in [0, 1)")
        self.check_field("cognitive", self.cognitive >= 0, ">= 0")
        self.check_field("social", self.social >= 0, ">= 0")
        self.check_field("v_max", self.v_max > 0, "> 0")

    def init(self, fn, y0, lower, upper, key):
        del y0
        pop = init_population(fn, lower, upper, key, self.population_size)
        x = pop.population
        return PSOState(x, jnp.zeros_like(x), x, pop.fitness, pop.best_x, pop.best_f, pop.n_evals, pop.generation)

    def step(self, fn, state, lower, upper, key):
        x = state.population
        n = x.shape[0]
        rnd = draw(key, r1=("uniform", x.shape), r2=("uniform", x.shape))
        limit = self.v_max * (upper - lower)
        v = (self.inertia * state.velocities + self.cognitive * rnd["r1"] * (state.personal_x - x)
             + self.social * rnd["r2"] * (state.best_x - x))
        v = jnp.clip(v, -limit, limit)
        moved = x + v
        x_new = jnp.clip(moved, lower, upper)
        v = jnp.where(x_new == moved, v, 0.0)
        f = evaluate(fn, x_new)
        better = f <= state.personal_f
        personal_x = jnp.where(better[:, None], x_new, state.personal_x)
        personal_f = jnp.where(better, f, state.personal_f)
        i = jnp.argmin(personal_f)
        keep = state.best_f <= personal_f[i]
        best_x = jnp.where(keep, state.best_x, personal_x[i])
        best_f = jnp.where(keep, state.best_f, personal_f[i])
        return PSOState(x_new, v, personal_x, personal_f, best_x, best_f, state.n_evals + n, state.generation + 1)

    def step_evaluations(self, n_dim):
        return self.population_size, self.population_size
