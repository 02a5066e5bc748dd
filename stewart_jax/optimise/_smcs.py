"""SMCS: cuckoo search improved by simplex operations on the worst nests.

Wang et al. 2018, §2.1 (Wang H., Cao X. et al., Infrared and Laser Engineering 47(5), 2018, after its
refs. [12–13]): before each CS generation (Yang & Deb 2009, :mod:`.cuckoo`) the population is
read as a Nelder–Mead simplex and its worst nests are replaced by reflection, expansion,
contraction or shrink (:func:`.simplex.simplex_on_worst`); the CS generation then starts from
the result. As the paper describes it — and as the defect VSA-SMCS fixes — the simplex steps
are **not** bounded: nests (and the reported best point) can leave Ω. The CS phases still
clip their own trial points to Ω.
"""

from __future__ import annotations

from ._cuckoo import check_levy, check_n_worst, check_probability, cs_generation
from ._driver import AbstractPopulationSolver, population_state
from ._levy import BETA
from ._simplex import SimplexCoefficients, simplex_on_worst


class SMCS(AbstractPopulationSolver):
    """Simplex-modified cuckoo search (Wang et al. 2018, §2.1).

    - ``population_size``: 37, the population of Wang et al. (2018) §2.3 (a simplex in 36 dimensions), so that
      SMCS and VSA-SMCS compare at equal settings.
    - ``n_worst``: simplex operations per generation, one per worst nest; the paper does not
      say for SMCS: 12, the value it gives for VSA-SMCS, so that the comparison isolates the
      adaptive step and the bound limiting.
    - ``pa`` 0.25, ``alpha`` 0.01, ``beta`` 1.5: Yang & Deb's CS (see :class:`.CuckooSearch`).
    - ``coefficients``: Nelder–Mead coefficients (standard values).
    - ``target``: stop once the best value is at or below it; ``None`` (run the whole budget).
    - ``stall_generations``, ``stall_rtol``: the convergence test reported in the status.

    Evaluations: ``population_size`` at init; ``3·n_worst + 2·population_size`` per generation.
    """

    population_size: int = 37
    n_worst: int = 12
    pa: float = 0.25
    alpha: float = 0.01
    beta: float = BETA
    coefficients: SimplexCoefficients = SimplexCoefficients()
    target: float | None = None
    stall_generations: int = 100
    stall_rtol: float = 1e-6

    def __check_init__(self):
        check_probability(self, "pa", self.pa)
        check_levy(self, self.beta, self.alpha)
        check_n_worst(self, self.n_worst)

    def step(self, fn, state, lower, upper, key):
        nests, fit = simplex_on_worst(fn, state.population, state.fitness, self.n_worst,
                                      self.coefficients)
        state = population_state(nests, fit, state.n_evals + 3 * self.n_worst,
                                 state.generation, state)
        return cs_generation(fn, state, lower, upper, key, self.alpha, self.beta, self.pa)

    def step_evaluations(self, n_dim):
        n = 3 * self.n_worst + 2 * self.population_size
        return n, n
