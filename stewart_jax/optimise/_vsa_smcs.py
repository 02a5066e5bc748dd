"""VSA-SMCS: simplex cuckoo search with a variable-step adaptive path and bound limiting.

Wang H., Cao X. et al., "Improved cuckoo calibration method of space telescope secondary
mirror adjusting mechanism", Infrared and Laser Engineering 47(5), 2018, §2.2–2.3:

- adaptive step, eq. 11: ``sp_t = sp·a + sp_min``, ``a = exp(−30·(t/T_max)^p)``,
  ``sp_min = sp_1·(1 − t/T_max)``, with ``sp`` a Mantegna Lévy step (eq. 10, :mod:`.levy`);
- nest update, eq. 12: ``u ← u + d·sp_t ⊙ (u − u_best)``;
- bound limiting, eq. 13: every simplex trial point is clipped to Ω (eq. 13 is a clip,
  our reading); the eq. 12 and abandonment trial points are clipped too, as in CS.

One generation is steps (2)–(5) of §2.3: (2) eq. 12 on every nest, greedy replacement;
(3) each nest abandoned with probability ``lu`` for a point uniform in Ω, greedy;
(4) Nelder–Mead on the 12 worst nests, bounded by eq. 13; (5) stop if ``S(u_best) < ε``.
Step (1) is the initial population of 37 nests uniform in Ω.
"""

from __future__ import annotations

import dataclasses

import jax.numpy as jnp

from ._cuckoo import check_levy, check_n_worst, check_probability
from ._driver import AbstractPopulationSolver, draw, evaluate, greedy, holds, population_state
from ._levy import BETA, mantegna_from_normals
from ._simplex import SimplexCoefficients, simplex_on_worst


def adaptive_step(sp, t, t_max, p: float, sp_1: float):
    """Eq. 11: ``sp_t = sp·exp(−30·(t/T_max)^p) + sp_1·(1 − t/T_max)``."""
    frac = jnp.clip(t / t_max, 0.0, 1.0)
    return sp * jnp.exp(-30.0 * frac**p) + sp_1 * (1.0 - frac)


class VSASMCS(AbstractPopulationSolver):
    """VSA-SMCS (Wang et al. 2018, §2.2–2.3).

    Paper values: ``population_size`` = 37, ``n_worst`` = 12, ``beta`` = 1.5; the constant 30 of
    eq. 11. The paper gives no value for the others; choices:

    - ``d`` (path coefficient of eq. 12): 1.0. Eq. 12 has no ``α·N(0, 1)`` factor (CS has
      ``0.01·N(0, 1)``): with ``d = 1`` the random part of a move is a Lévy multiple of the
      nest's distance to the best, so the population's own spread sets the scale. On the
      Table 2 problem (20 000 evaluations, 4 seeds) d ∈ {−1, 0.5, 1, 2} gave the same S
      within the seed-to-seed spread (1–5e-6 mm²): only the order of magnitude matters.
    - ``sp_1`` (minimum-step gradient of eq. 11): 0.1. The deterministic part of the step starts at a
      tenth of the nest-to-best distance and falls linearly to 0; it is what remains once
      ``a`` has died out. 0, 0.1 and 0.5 gave similar S on the Table 2 problem.
    - ``p`` (eq. 11, the paper's range [1, 30]): 10. ``a = exp(−30·(t/T_max)^p)`` keeps the Lévy part above half its
      scale until ``t/T_max ≈ 0.69`` and kills it by 0.85; with ``p = 1`` it is gone after a
      tenth of the run (``a(0.1) = e^−3``), which was up to 10× worse at 20 000 evaluations;
      p ∈ {5, 10, 30} were alike.
    - ``lu`` (abandonment probability): 0.25, Yang & Deb's ``pa``, of which it is the analogue.
    - ``max_generations`` (``T_max``): ``None`` — the generations the evaluation budget
      allows, so that the step schedule of eq. 11 ends when the budget does.
    - ``target`` (the paper's ``ε``; step 5 stops once ``S(u_best) ≤ ε``): ``None`` — run the whole budget
      (a fixed-budget comparison is what the study needs; set it to the expected noise floor,
      e.g. ``6m·σ_q²``, to stop early).
    - ``coefficients``: Nelder–Mead coefficients (standard values).
    - ``stall_generations``, ``stall_rtol``: the convergence test reported in the status.

    Evaluations: ``population_size`` at init; ``2·population_size + 3·n_worst`` per generation (110 with the
    paper's values). Every nest ever held lies in Ω.
    """

    population_size: int = 37
    n_worst: int = 12
    d: float = 1.0
    sp_1: float = 0.1
    p: float = 10.0
    lu: float = 0.25
    beta: float = BETA
    max_generations: int | None = None
    target: float | None = None
    coefficients: SimplexCoefficients = SimplexCoefficients()
    stall_generations: int = 100
    stall_rtol: float = 1e-6

    def __check_init__(self):
        # d, sp_1, p, lu (and the coefficients) may be arrays — one value per setting, vmapped
        # in a sensitivity study — or tracers inside that vmap (not checkable here: ``holds``)
        if not holds((1.0 <= self.p) & (self.p <= 30.0)):
            raise ValueError(f"VSASMCS.p must be in the paper's range [1, 30], got {self.p!r}")
        if not holds(self.sp_1 >= 0.0):
            raise ValueError(f"VSASMCS.sp_1 must be >= 0, got {self.sp_1!r}")
        if self.max_generations is not None and not self.max_generations >= 1:
            raise ValueError(f"VSASMCS.max_generations must be None or >= 1, got {self.max_generations!r}")
        check_probability(self, "lu", self.lu)
        check_levy(self, self.beta)
        check_n_worst(self, self.n_worst)

    def generation_limit(self) -> int | None:
        return self.max_generations

    def with_generation_budget(self, n_generations: int) -> VSASMCS:
        """``T_max`` from the budget where ``max_generations`` is ``None``."""
        if self.max_generations is None:
            return dataclasses.replace(self, max_generations=int(n_generations))
        return self

    def step(self, fn, state, lower, upper, key):
        if self.max_generations is None:
            raise ValueError("VSASMCS.max_generations (T_max) must be set; the driver "
                             "sets it from the evaluation budget")
        n = self.population_size
        x = state.population
        rnd = draw(key, zu=("normal", x.shape), zv=("normal", x.shape), lu=("uniform", (n,)),
                   new=("uniform", x.shape))
        # (2) adaptive Lévy path, eqs. 11-12
        sp = mantegna_from_normals(rnd["zu"], rnd["zv"], self.beta)
        sp_t = adaptive_step(sp, state.generation, self.max_generations, self.p, self.sp_1)
        x_new = jnp.clip(x + self.d * sp_t * (x - state.best_x), lower, upper)
        nests, fit = greedy(x, state.fitness, x_new, evaluate(fn, x_new))
        state = population_state(nests, fit, state.n_evals + n, state.generation, state)
        # (3) abandonment with probability lu, to random points in Ω
        abandon = rnd["lu"] < self.lu
        cand = jnp.where(abandon[:, None], lower + rnd["new"] * (upper - lower), nests)
        nests, fit = greedy(nests, fit, cand, evaluate(fn, cand))
        state = population_state(nests, fit, state.n_evals + n, state.generation, state)
        # (4) simplex on the worst nests, bounded by eq. 13
        nests, fit = simplex_on_worst(fn, nests, fit, self.n_worst, self.coefficients,
                                      lower, upper)
        state = population_state(nests, fit, state.n_evals + 3 * self.n_worst,
                                 state.generation, state)
        return state._replace(generation=state.generation + 1)

    def step_evaluations(self, n_dim):
        n = 2 * self.population_size + 3 * self.n_worst
        return n, n
