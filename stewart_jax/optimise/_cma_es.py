"""CMA-ES: the covariance matrix adaptation evolution strategy, (μ/μ_W, λ) with rank-one and
rank-μ updates.

Hansen N., "The CMA Evolution Strategy: A Tutorial", arXiv:1604.00772 (2016), the algorithm
summary of its Appendix A and the default parameters of its Table 1. Numbered here as in that
summary (our numbering, in the order the summary gives them):

1. sample ``z_k ~ N(0, I)``, ``y_k = B·D·z_k``, ``x_k = m + σ·y_k``, ``k = 1 … λ``;
2. rank by the objective, ``⟨y⟩_w = Σ_{i≤μ} w_i·y_{i:λ}``; mean ``m ← m + c_m·σ·⟨y⟩_w``;
3. ``p_σ ← (1 − c_σ)·p_σ + √(c_σ(2 − c_σ)μ_eff)·C^{−1/2}⟨y⟩_w``;
4. ``σ ← σ·exp((c_σ / d_σ)·(‖p_σ‖ / E‖N(0, I)‖ − 1))``;
5. ``h_σ = [‖p_σ‖ / √(1 − (1 − c_σ)^{2(g+1)}) < (1.4 + 2/(n + 1))·E‖N(0, I)‖]``;
   ``p_c ← (1 − c_c)·p_c + h_σ·√(c_c(2 − c_c)μ_eff)·⟨y⟩_w``;
6. ``C ← (1 + c_1·δ(h_σ) − c_1 − c_μ·Σw)·C + c_1·p_c p_cᵀ + c_μ·Σ_{i≤μ} w_i·y_{i:λ} y_{i:λ}ᵀ``,
   ``δ(h_σ) = (1 − h_σ)·c_c(2 − c_c)``;

with Table 1's defaults: ``λ = 4 + ⌊3 ln n⌋``, ``μ = ⌊λ/2⌋``, ``w_i ∝ ln((λ + 1)/2) − ln i``
(positive weights only: the non-active CMA-ES), ``c_σ = (μ_eff + 2)/(n + μ_eff + 5)``,
``d_σ = 1 + 2·max(0, √((μ_eff − 1)/(n + 1)) − 1) + c_σ``, ``c_c = (4 + μ_eff/n)/(n + 4 + 2μ_eff/n)``,
``c_1 = 2/((n + 1.3)² + μ_eff)``, ``c_μ = min(1 − c_1, 2(μ_eff − 2 + 1/μ_eff)/((n + 2)² + μ_eff))``,
``c_m = 1``, ``E‖N(0, I)‖ ≈ √n·(1 − 1/(4n) + 1/(21n²))``.

NOTE: the search runs in box-normalised coordinates ``(x − lower)/(upper − lower)`` (so that
``σ`` is a fraction of Ω's width on every axis), and Ω is kept by evaluating the objective at the
projection ``clip(x)`` and ranking by ``f(clip x) + λ_p·(1 + |f|)·‖x − clip x‖²`` (the
projection-plus-penalty repair of the tutorial's §B.3 on boundaries; the same projected
objective as our bounded Nelder–Mead). The best point reported is the projected one and its value
is ``f`` there: every point the method reports lies in Ω.

NOTE: for common random numbers with the other population methods, the run starts like them:
``n_nests`` points uniform in Ω; the initial mean is the best of them and ``σ₀ = sigma0``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from ._driver import AbstractPopulationSolver, _check, draw, evaluate, init_population


class CMAESState(NamedTuple):
    """State of :class:`CMAES` (normalised coordinates, ``n`` the dimension).

    - ``mean``: ``Float[Array, "n"]``; ``sigma``: ``Float[Array, ""]`` (fraction of Ω's width);
      ``cov``: ``Float[Array, "n n"]``; ``p_sigma``, ``p_c``: ``Float[Array, "n"]`` evolution paths.
    - ``best_x`` (original coordinates, in Ω), ``best_f``: the best point evaluated so far.
    - ``n_evals``: objective calls; ``generation``: generations done (``g``).
    """

    mean: Float[Array, " n"]
    sigma: Float[Array, ""]
    cov: Float[Array, "n n"]
    p_sigma: Float[Array, " n"]
    p_c: Float[Array, " n"]
    best_x: Float[Array, " n"]
    best_f: Float[Array, ""]
    n_evals: Int[Array, ""]
    generation: Int[Array, ""]


def default_population_size(n_dim: int) -> int:
    """``λ = 4 + ⌊3 ln n⌋`` (Hansen 2016, Table 1): 14 for the 36 parameters of the 6-PSS."""
    return 4 + int(math.floor(3.0 * math.log(n_dim)))


def _strategy(n: int, lam: int) -> dict:
    """The default strategy parameters of Hansen (2016), Table 1 (Python floats)."""
    mu = lam // 2
    w = np.log((lam + 1) / 2.0) - np.log(np.arange(1, mu + 1))
    w = w / w.sum()
    mu_eff = 1.0 / float(np.sum(w**2))
    c_sigma = (mu_eff + 2.0) / (n + mu_eff + 5.0)
    d_sigma = 1.0 + 2.0 * max(0.0, math.sqrt((mu_eff - 1.0) / (n + 1.0)) - 1.0) + c_sigma
    c_c = (4.0 + mu_eff / n) / (n + 4.0 + 2.0 * mu_eff / n)
    c_1 = 2.0 / ((n + 1.3) ** 2 + mu_eff)
    c_mu = min(1.0 - c_1, 2.0 * (mu_eff - 2.0 + 1.0 / mu_eff) / ((n + 2.0) ** 2 + mu_eff))
    chi_n = math.sqrt(n) * (1.0 - 1.0 / (4.0 * n) + 1.0 / (21.0 * n * n))
    return dict(mu=mu, w=w, mu_eff=mu_eff, c_sigma=c_sigma, d_sigma=d_sigma, c_c=c_c, c_1=c_1,
                c_mu=c_mu, chi_n=chi_n)


class CMAES(AbstractPopulationSolver):
    """CMA-ES (Hansen 2016) over the box Ω.

    - ``population_size`` (λ): ``None`` — Hansen's default ``4 + ⌊3 ln n⌋``.
    - ``sigma0``: initial step size as a fraction of Ω's width; 0.3 (the tutorial's advice for an
      optimum expected anywhere in the box: about a third of the interval).
    - ``n_nests``: the initial uniform sample whose best point is the initial mean; 37, the
      population of the cuckoo methods, so that every population method starts from the same
      points for a given key (common random numbers).
    - ``penalty`` (λ_p): weight of the distance to Ω in the ranking; 1.0.
    - ``epsilon``, ``stall_generations``, ``stall_rtol``: as for every population method.

    Evaluations: ``n_nests`` at init; ``λ`` per generation.
    """

    n_nests: int = 37
    population_size: int | None = None
    sigma0: float = 0.3
    penalty: float = 1.0
    epsilon: float = 0.0
    stall_generations: int = 100
    stall_rtol: float = 1e-6

    def __check_init__(self):
        _check(self, "sigma0", self.sigma0 > 0, "> 0")
        _check(self, "penalty", self.penalty >= 0, ">= 0")
        if self.population_size is not None:
            _check(self, "population_size", self.population_size >= 4, "None or >= 4")

    def _lambda(self, n_dim: int) -> int:
        return default_population_size(n_dim) if self.population_size is None else int(self.population_size)

    def init(self, fn, y0, lower, upper, key):
        del y0
        pop = init_population(fn, lower, upper, key, self.n_nests)
        n = lower.shape[-1]
        mean = (pop.best_x - lower) / (upper - lower)
        zeros = jnp.zeros(n, jnp.float64)
        return CMAESState(mean, jnp.asarray(self.sigma0, jnp.float64), jnp.eye(n, dtype=jnp.float64), zeros,
                          zeros, pop.best_x, pop.best_f, pop.n_evals, pop.generation)

    def step(self, fn, state, lower, upper, key):
        n = lower.shape[-1]
        lam = self._lambda(n)
        s = _strategy(n, lam)
        w = jnp.asarray(s["w"])
        width = upper - lower
        # (1) sample
        eigval, basis = jnp.linalg.eigh(0.5 * (state.cov + state.cov.T))
        scale = jnp.sqrt(jnp.maximum(eigval, 0.0))
        z = draw(key, z=("normal", (lam, n)))["z"].astype(jnp.float64)
        y = (z * scale) @ basis.T
        x = state.mean + state.sigma * y
        xc = jnp.clip(x, 0.0, 1.0)
        x_orig = lower + xc * width
        f = evaluate(fn, x_orig)
        g = f + self.penalty * (1.0 + jnp.abs(f)) * jnp.sum((x - xc) ** 2, axis=-1)
        # (2) recombination
        order = jnp.argsort(g)
        y_sel = y[order[: s["mu"]]]
        y_w = w @ y_sel
        mean = state.mean + state.sigma * y_w
        # (3) step-size path, with C^{-1/2} = B D^{-1} Bᵀ
        inv_sqrt_y = basis @ ((basis.T @ y_w) / jnp.where(scale > 0, scale, 1.0))
        c_s, mu_eff = s["c_sigma"], s["mu_eff"]
        p_sigma = (1.0 - c_s) * state.p_sigma + math.sqrt(c_s * (2.0 - c_s) * mu_eff) * inv_sqrt_y
        norm_ps = jnp.linalg.norm(p_sigma)
        # (4) step size
        sigma = state.sigma * jnp.exp((c_s / s["d_sigma"]) * (norm_ps / s["chi_n"] - 1.0))
        # (5) covariance path with the stall indicator h_σ
        g1 = (state.generation + 1).astype(jnp.float64)
        h_sigma = (norm_ps / jnp.sqrt(1.0 - (1.0 - c_s) ** (2.0 * g1))
                   < (1.4 + 2.0 / (n + 1.0)) * s["chi_n"]).astype(jnp.float64)
        c_c, c_1, c_mu = s["c_c"], s["c_1"], s["c_mu"]
        p_c = (1.0 - c_c) * state.p_c + h_sigma * math.sqrt(c_c * (2.0 - c_c) * mu_eff) * y_w
        # (6) covariance: rank-one and rank-μ updates
        delta_h = (1.0 - h_sigma) * c_c * (2.0 - c_c)
        rank_mu = jnp.einsum("i,ij,ik->jk", w, y_sel, y_sel)
        cov = ((1.0 + c_1 * delta_h - c_1 - c_mu * float(np.sum(s["w"]))) * state.cov
               + c_1 * jnp.outer(p_c, p_c) + c_mu * rank_mu)
        i = jnp.argmin(f)
        better = f[i] < state.best_f
        best_x = jnp.where(better, x_orig[i], state.best_x)
        best_f = jnp.where(better, f[i], state.best_f)
        return CMAESState(mean, sigma, cov, p_sigma, p_c, best_x, best_f, state.n_evals + lam,
                          state.generation + 1)

    def step_evaluations(self, n_dim):
        lam = self._lambda(n_dim)
        return lam, lam
