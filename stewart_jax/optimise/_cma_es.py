"""CMA-ES: the covariance matrix adaptation evolution strategy, (μ/μ_W, λ) with rank-one,
rank-μ and active (negative-weight) covariance updates; IPOP and BIPOP restarts as options.

Hansen N., "The CMA Evolution Strategy: A Tutorial", arXiv:1604.00772 (2016; revised 2023), the
algorithm summary of its Appendix A with the default parameters of its Table 1 and, where the
2023 revision changed them, the revision's (the ``1/4`` offset of ``c_μ``), which are also those
of Hansen's reference implementation ``pycma``. Numbered as in that summary:

1. sample ``z_k ~ N(0, I)``, ``y_k = B·D·z_k``, ``x_k = m + σ·y_k``, ``k = 1 … λ``;
2. rank by the objective, ``⟨y⟩_w = Σ_{i≤μ} w_i·y_{i:λ}``; mean ``m ← m + c_m·σ·⟨y⟩_w``;
3. ``p_σ ← (1 − c_σ)·p_σ + √(c_σ(2 − c_σ)μ_eff)·C^{−1/2}⟨y⟩_w``;
4. ``σ ← σ·exp(min(1, (c_σ / d_σ)·(‖p_σ‖ / E‖N(0, I)‖ − 1)))`` (pycma's cap of one e-fold);
5. ``h_σ = [‖p_σ‖ / √(1 − (1 − c_σ)^{2(g+1)}) < (1.4 + 2/(n + 1))·E‖N(0, I)‖]``;
   ``p_c ← (1 − c_c)·p_c + h_σ·√(c_c(2 − c_c)μ_eff)·⟨y⟩_w``;
6. ``C ← (1 + c_1·δ(h_σ) − c_1 − c_μ·Σ_j w_j)·C + c_1·p_c p_cᵀ + c_μ·Σ_{i≤λ} w°_i·y_{i:λ} y_{i:λ}ᵀ``,
   ``δ(h_σ) = (1 − h_σ)·c_c(2 − c_c)``, ``w°_i = w_i`` for ``w_i ≥ 0`` and
   ``w_i·n / ‖C^{−1/2} y_{i:λ}‖²`` otherwise (eq. 46–47);

with Table 1's defaults: ``λ = 4 + ⌊3 ln n⌋``, ``μ = ⌊λ/2⌋``, raw weights
``w'_i = ln((λ + 1)/2) − ln i`` for ``i = 1 … λ`` (positive for ``i ≤ μ``), ``μ_eff`` and ``μ_eff⁻``
of the positive and negative parts, ``c_1 = 2/((n + 1.3)² + μ_eff)``,
``c_μ = min(1 − c_1, 2(1/4 + μ_eff + 1/μ_eff − 2)/((n + 2)² + μ_eff))``, the positive weights summing
to one and the negative ones to ``−min(1 + c_1/c_μ, 1 + 2μ_eff⁻/(μ_eff + 2), (1 − c_1 − c_μ)/(n·c_μ))``
(eq. 53), ``c_σ = (μ_eff + 2)/(n + μ_eff + 5)``, ``d_σ = 1 + 2·max(0, √((μ_eff − 1)/(n + 1)) − 1) + c_σ``,
``c_c = (4 + μ_eff/n)/(n + 4 + 2μ_eff/n)``, ``c_m = 1``, ``E‖N(0, I)‖ ≈ √n·(1 − 1/(4n) + 1/(21n²))``.

The eigendecomposition ``C = B·D²·Bᵀ`` is amortised as the tutorial's §B.2 advises: it is redone
after ``max(1, ⌊1/(10·n·(c_1 + c_μ))⌋`` generations (every generation below ~100 dimensions).

Stopping, as the tutorial's §B.3 and pycma (``tolx``, ``tolfun``, ``tolconditioncov``,
``noeffectcoord``): the step size has collapsed (``σ·max(√diag C, |p_c|) < tolx``, status
``successful``), or the best values of the last ``10 + ⌈30n/λ⌉`` generations and the current
generation's values all lie within ``tolfun`` (``successful``), or ``C`` is too ill-conditioned to
go on (condition number above ``1e14``) or a step of ``0.2σ`` along a coordinate no longer moves
the mean (status ``stalled``). With ``restarts="ipop"`` (Auger A., Hansen N., "A restart CMA
evolution strategy with increasing population size", CEC 2005) the run restarts after any of these
with the population doubled, from a fresh uniform sample, until the budget or the target.
With ``restarts="bipop"`` (Hansen N., "Benchmarking a BI-population CMA-ES on the BBOB-2009
function testbed", GECCO 2009 workshops, as pycma's ``fmin(..., bipop=True)`` implements it) the
large-population runs of IPOP alternate with small-population runs: after the ``k``-th large run
(population ``λ₀·2^k``), runs of population ``λ₀·(2^k)^{u²}`` and initial step size
``σ₀·0.01^v`` (``u, v`` uniform in [0, 1)), each within half the evaluations the large runs have
used, start as long as the small runs' evaluations stay below the large runs'; the first run
counts as small, and ``max_restarts`` counts the large runs only.

NOTE: population sizes are array shapes, fixed when the run is compiled, while BIPOP's choice of
the next run depends on evaluations counted at run time. So the runs are a ``lax.while_loop``
over a ``lax.switch`` between the population levels ``λ₀·2^j`` (each compiled once, however
many runs use it), and a small run's population is rounded to the nearest level in log scale,
``λ₀·2^j`` with ``j = round(k·u²)``, where pycma draws it from the integers in between.

NOTE: the search runs in box-normalised coordinates ``(x − lower)/(upper − lower)`` (so that
``σ`` is a fraction of Ω's width on every axis), and Ω is kept, by default
(``boundary="transform"``), by pycma's ``BoundTransform``: the objective is evaluated at
``T(x)``, a periodic map of the real line onto the box that is the identity on its inner 95 %
(a margin ``a`` of 2.5 % of the width each side, pycma's margin on COCO's box [−5, 5]),
quadratic over ``[−3a, a]`` and ``[1 − a, 1 + 3a]`` and mirrored beyond; the distribution lives on
the unbounded line and is ranked by ``f(T(x))``. Measured: on a rotated ellipsoid in 6-D
(condition 1e6, 64 seeds) the projection-plus-penalty repair of the tutorial's §B.3
(``boundary="penalty"``: ``f(clip x) + λ_p·(1 + |f|)·‖x − clip x‖²``) needed 4 825 evaluations in
median, the transform 2 404, and no boundary within reach 2 656 (pycma: 2 268); on BBOB's f10 and
f11 in 10-D (5 instances × 8 seeds) a margin of 5 % needed 7 677 and 5 577, 2.5 % 5 292 and
4 147 (pycma: 5 915 and 4 230). The best point reported is the mapped one and its value is ``f``
there: every point the method reports lies in Ω.

NOTE: for common random numbers with the other population methods, a run starts like them by
default (``start="sample"``): ``start_samples`` points uniform in Ω; the initial mean is the best of
them and ``σ₀ = sigma0``. ``start="y0"`` starts at :func:`minimise`'s ``y0`` instead.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Literal, NamedTuple

import jax.numpy as jnp
import numpy as np
from jax import lax
from jaxtyping import Array, Float, Int

from ._driver import (
    AbstractPopulationSolver,
    RestartSchedule,
    draw,
    evaluate,
    init_population,
)
from ._result import RESULTS


class CMAESState(NamedTuple):
    """State of :class:`CMAES` (normalised coordinates, ``n`` the dimension, ``L`` the
    ``tolfun`` history length).

    - ``mean``: ``Float[Array, "n"]``; ``sigma``: ``Float[Array, ""]`` (fraction of Ω's width);
      ``cov``: ``Float[Array, "n n"]``; ``p_sigma``, ``p_c``: ``Float[Array, "n"]`` evolution paths.
    - ``basis`` (``B``, ``Float[Array, "n n"]``), ``scale`` (``D``, ``Float[Array, "n"]``): the
      eigendecomposition of ``cov`` last computed, at generation ``eigen_generation``.
    - ``best_x`` (original coordinates, in Ω), ``best_f``: the best point evaluated so far.
    - ``recent_best``: ``Float[Array, "L"]``, the best value of each of the last ``L`` generations
      (a ring); ``generation_range``: the spread of the last generation's values.
    - ``n_evals``: objective calls; ``generation``: generations done (``g``).
    """

    mean: Float[Array, " n"]
    sigma: Float[Array, ""]
    cov: Float[Array, "n n"]
    basis: Float[Array, "n n"]
    scale: Float[Array, " n"]
    eigen_generation: Int[Array, ""]
    p_sigma: Float[Array, " n"]
    p_c: Float[Array, " n"]
    best_x: Float[Array, " n"]
    best_f: Float[Array, ""]
    recent_best: Float[Array, " L"]
    generation_range: Float[Array, ""]
    n_evals: Int[Array, ""]
    generation: Int[Array, ""]


def default_population_size(n_dim: int) -> int:
    """``λ = 4 + ⌊3 ln n⌋`` (Hansen 2016, Table 1): 14 for the 36 parameters of the 6-PSS."""
    return 4 + int(math.floor(3.0 * math.log(n_dim)))


def strategy_parameters(n: int, lam: int) -> dict:
    """The default strategy parameters of Hansen (2016, revised 2023), Table 1, for dimension
    ``n`` and population ``λ``, as Python floats (weights: a NumPy array of length ``λ``)."""
    mu = lam // 2
    raw = np.log((lam + 1) / 2.0) - np.log(np.arange(1, lam + 1))
    pos, neg = raw[:mu], raw[mu:]
    mu_eff = float(pos.sum() ** 2 / np.sum(pos**2))
    c_1 = min(1.0, lam / 6.0) * 2.0 / ((n + 1.3) ** 2 + mu_eff)
    c_mu = min(1.0 - c_1, 2.0 * (0.25 + mu_eff + 1.0 / mu_eff - 2.0) / ((n + 2.0) ** 2 + mu_eff))
    w = np.zeros(lam)
    w[:mu] = pos / pos.sum()
    if np.any(neg < 0) and c_mu > 0:
        mu_eff_neg = float(neg.sum() ** 2 / np.sum(neg**2))
        neg_sum = min(1.0 + c_1 / c_mu, 1.0 + 2.0 * mu_eff_neg / (mu_eff + 2.0), (1.0 - c_1 - c_mu) / (n * c_mu))
        w[mu:] = neg_sum * neg / np.abs(neg).sum()
    c_sigma = (mu_eff + 2.0) / (n + mu_eff + 5.0)
    d_sigma = 1.0 + 2.0 * max(0.0, math.sqrt((mu_eff - 1.0) / (n + 1.0)) - 1.0) + c_sigma
    c_c = (4.0 + mu_eff / n) / (n + 4.0 + 2.0 * mu_eff / n)
    chi_n = math.sqrt(n) * (1.0 - 1.0 / (4.0 * n) + 1.0 / (21.0 * n * n))
    eigen_gap = max(1, int(1.0 / (10.0 * n * (c_1 + c_mu))))
    history = 10 + int(math.ceil(30.0 * n / lam))
    return dict(mu=mu, w=w, mu_eff=mu_eff, c_sigma=c_sigma, d_sigma=d_sigma, c_c=c_c, c_1=c_1, c_mu=c_mu,
                chi_n=chi_n, eigen_gap=eigen_gap, history=history)


MARGIN = 0.025
"""The margin ``a`` of :func:`bound_transform`, a fraction of the box's width."""


def bound_transform(y: Float[Array, "... n"], a: float = MARGIN) -> Float[Array, "... n"]:
    """pycma's ``BoxConstraintsLinQuadTransformation`` on the unit box: the identity on
    ``[a, 1 − a]``, quadratic on ``[−3a, a]`` and ``[1 − a, 1 + 3a]``, mirrored at ``−a`` and
    ``1 + a``, periodic with period ``2(1 + 2a)``; its values lie in ``[0, 1]``."""
    period, start = 2.0 * (1.0 + 2.0 * a), -2.0 * a - 0.5
    far = (y < start) | (y > 1.0 + 2.0 * a + 0.5)
    y = jnp.where(far, y - period * jnp.floor((y - start) / period), y)
    y = jnp.where(y > 1.0 + a, y - 2.0 * (y - 1.0 - a), y)
    y = jnp.where(y < -a, y + 2.0 * (-a - y), y)
    y = jnp.where(y < a, (y + a) ** 2 / (4.0 * a), y)
    y = jnp.where(y > 1.0 - a, 1.0 - (y - 1.0 - a) ** 2 / (4.0 * a), y)
    return jnp.clip(y, 0.0, 1.0)


class CMAES(AbstractPopulationSolver):
    """CMA-ES (Hansen 2016/2023, with active covariance update) over the box Ω.

    - ``population_size`` (λ): ``None`` — Hansen's default ``4 + ⌊3 ln n⌋``.
    - ``sigma0``: initial step size as a fraction of Ω's width; 0.3 (the tutorial's advice for an
      optimum expected anywhere in the box: about a third of the interval).
    - ``start``: ``"sample"`` (default) — the best of ``start_samples`` points uniform in Ω is the
      initial mean; ``"y0"`` — :func:`minimise`'s ``y0`` (one evaluation).
    - ``start_samples``: the size of that initial sample; 37, the population of the cuckoo methods, so
      that every population method starts from the same points for a given key.
    - ``boundary``: ``"transform"`` (default; pycma's ``BoundTransform``, see the module's NOTE) or
      ``"penalty"`` (projection and a penalty of weight ``penalty`` on the distance to Ω).
    - ``tolx``: stop when ``σ·max(√diag C, |p_c|)`` (a fraction of Ω's width) is below it; 1e-12.
    - ``tolfun``: stop when the recent best values and the current generation's values all lie
      within it (absolute, in the objective's unit; pycma's default); 1e-11. ``0`` disables.
    - ``restarts``: ``"none"``, ``"ipop"`` (restart on any stop but the target, the population
      doubled each time, at most ``max_restarts`` times; the budget is shared) or ``"bipop"``
      (IPOP's runs interleaved with small-population runs; see the module's docstring).
    - ``target``, ``stall_generations``, ``stall_rtol``: as for every population method.

    Evaluations: ``start_samples`` (or 1) at init; ``λ`` per generation.
    """

    start_samples: int = 37
    population_size: int | None = None
    sigma0: float = 0.3
    start: Literal["sample", "y0"] = "sample"
    boundary: Literal["transform", "penalty"] = "transform"
    penalty: float = 1.0
    tolx: float = 1e-12
    tolfun: float = 1e-11
    restarts: Literal["none", "ipop", "bipop"] = "none"
    max_restarts: int = 9
    target: float | None = None
    stall_generations: int = 100
    stall_rtol: float = 1e-6

    def __check_init__(self):
        self.check_field("sigma0", self.sigma0 > 0, "> 0")
        self.check_field("penalty", self.penalty >= 0, ">= 0")
        self.check_field("tolx", self.tolx >= 0, ">= 0")
        self.check_field("tolfun", self.tolfun >= 0, ">= 0")
        if self.population_size is not None:
            self.check_field("population_size", self.population_size >= 4, "None or >= 4")
        if self.boundary not in ("transform", "penalty"):
            raise ValueError(f"CMAES.boundary must be 'transform' or 'penalty', got {self.boundary!r}")
        if self.start not in ("sample", "y0"):
            raise ValueError(f"CMAES.start must be 'sample' or 'y0', got {self.start!r}")
        if self.restarts not in ("none", "ipop", "bipop"):
            raise ValueError(f"CMAES.restarts must be 'none', 'ipop' or 'bipop', got {self.restarts!r}")
        self.check_field("max_restarts", self.max_restarts >= 0, ">= 0")

    def _lambda(self, n_dim: int) -> int:
        return default_population_size(n_dim) if self.population_size is None else int(self.population_size)

    def restart_schedule(self, n_dim: int, max_evaluations: int) -> RestartSchedule | None:
        """The runs of IPOP or BIPOP (``None`` without restarts): the first run as configured,
        then population levels ``λ₀·2^j`` for ``j ≤ max_restarts`` as long as a sample and
        one generation of the level fit the budget, each started from a fresh sample."""
        if self.restarts == "none":
            return None
        lam0 = self._lambda(n_dim)
        base = dataclasses.replace(self, restarts="none", population_size=lam0)
        levels = [dataclasses.replace(base, start="sample")]
        for k in range(1, self.max_restarts + 1):
            level = dataclasses.replace(base, population_size=lam0 * 2**k, start="sample")
            if level.init_evaluations(n_dim) + level.step_evaluations(n_dim)[1] > max_evaluations:
                break
            levels.append(level)
        return RestartSchedule(base, tuple(levels), self.restarts == "bipop",
                               lambda s, factor: dataclasses.replace(s, sigma0=s.sigma0 * factor))

    def init(self, fn, y0, lower, upper, key):
        n = lower.shape[-1]
        s = strategy_parameters(n, self._lambda(n))
        if self.start == "y0":
            x0 = 0.5 * (lower + upper) if y0 is None else jnp.clip(jnp.asarray(y0, jnp.float64), lower, upper)
            f0 = evaluate(fn, x0[None])[0]
            best_x, best_f, n_evals = x0, f0, jnp.asarray(1, jnp.int32)
        else:
            pop = init_population(fn, lower, upper, key, self.start_samples)
            best_x, best_f, n_evals = pop.best_x, pop.best_f, pop.n_evals
        mean = (best_x - lower) / (upper - lower)
        zeros = jnp.zeros(n, jnp.float64)
        eye = jnp.eye(n, dtype=jnp.float64)
        return CMAESState(mean, jnp.asarray(self.sigma0, jnp.float64), eye, eye, jnp.ones(n, jnp.float64),
                          jnp.asarray(0, jnp.int32), zeros, zeros, best_x, best_f,
                          jnp.full(s["history"], jnp.inf), jnp.asarray(jnp.inf), n_evals,
                          jnp.asarray(0, jnp.int32))

    def step(self, fn, state, lower, upper, key):
        n = lower.shape[-1]
        lam = self._lambda(n)
        s = strategy_parameters(n, lam)
        mu, w = s["mu"], jnp.asarray(s["w"])
        width = upper - lower

        def decompose(st):
            eigval, basis = jnp.linalg.eigh(0.5 * (st.cov + st.cov.T))
            return basis, jnp.sqrt(jnp.maximum(eigval, 0.0)), st.generation

        basis, scale, eigen_generation = lax.cond(
            state.generation - state.eigen_generation >= s["eigen_gap"], decompose,
            lambda st: (st.basis, st.scale, st.eigen_generation), state)
        safe_scale = jnp.where(scale > 0, scale, 1.0)

        def inv_sqrt_c(v):  # C^{-1/2} v = B D^{-1} Bᵀ v
            return ((v @ basis) / safe_scale) @ basis.T

        # (1) sample
        z = draw(key, z=("normal", (lam, n)))["z"].astype(jnp.float64)
        y = (z * scale) @ basis.T
        x = state.mean + state.sigma * y
        if self.boundary == "transform":
            x_orig = lower + bound_transform(x) * width
            f = evaluate(fn, x_orig)
            g = f
        else:
            xc = jnp.clip(x, 0.0, 1.0)
            x_orig = lower + xc * width
            f = evaluate(fn, x_orig)
            g = f + self.penalty * (1.0 + jnp.abs(f)) * jnp.sum((x - xc) ** 2, axis=-1)
        # (2) recombination
        order = jnp.argsort(g)
        y_sorted = y[order]
        y_w = w[:mu] @ y_sorted[:mu]
        mean = state.mean + state.sigma * y_w
        # (3) step-size path
        c_s, mu_eff = s["c_sigma"], s["mu_eff"]
        p_sigma = (1.0 - c_s) * state.p_sigma + math.sqrt(c_s * (2.0 - c_s) * mu_eff) * inv_sqrt_c(y_w)
        norm_ps = jnp.linalg.norm(p_sigma)
        # (4) step size
        sigma = state.sigma * jnp.exp(jnp.minimum(1.0, (c_s / s["d_sigma"]) * (norm_ps / s["chi_n"] - 1.0)))
        # (5) covariance path with the stall indicator h_σ
        g1 = (state.generation + 1).astype(jnp.float64)
        h_sigma = (norm_ps / jnp.sqrt(1.0 - (1.0 - c_s) ** (2.0 * g1))
                   < (1.4 + 2.0 / (n + 1.0)) * s["chi_n"]).astype(jnp.float64)
        c_c, c_1, c_mu = s["c_c"], s["c_1"], s["c_mu"]
        p_c = (1.0 - c_c) * state.p_c + h_sigma * math.sqrt(c_c * (2.0 - c_c) * mu_eff) * y_w
        # (6) covariance: rank-one, rank-μ and active updates (eq. 46–47)
        mahalanobis2 = jnp.sum(inv_sqrt_c(y_sorted) ** 2, axis=-1)
        w_circ = jnp.where(w >= 0, w, w * n / jnp.maximum(mahalanobis2, 1e-300))
        delta_h = (1.0 - h_sigma) * c_c * (2.0 - c_c)
        rank_mu = jnp.einsum("i,ij,ik->jk", w_circ, y_sorted, y_sorted)
        cov = ((1.0 + c_1 * delta_h - c_1 - c_mu * float(np.sum(s["w"]))) * state.cov
               + c_1 * jnp.outer(p_c, p_c) + c_mu * rank_mu)
        i = jnp.argmin(f)
        better = f[i] < state.best_f
        best_x = jnp.where(better, x_orig[i], state.best_x)
        best_f = jnp.where(better, f[i], state.best_f)
        finite = jnp.isfinite(f)
        f_range = jnp.where(jnp.all(finite), jnp.max(f) - jnp.min(f), jnp.inf)
        recent = state.recent_best.at[state.generation % s["history"]].set(f[i])
        return CMAESState(mean, sigma, cov, basis, scale, eigen_generation, p_sigma, p_c, best_x, best_f,
                          recent, f_range, state.n_evals + lam, state.generation + 1)

    def terminate(self, state):
        n = state.mean.shape[-1]
        lam = self._lambda(n)
        history = strategy_parameters(n, lam)["history"]
        reached = self.target_reached(state)
        diag = jnp.sqrt(jnp.diagonal(state.cov))
        tolx = state.sigma * jnp.maximum(jnp.max(diag), jnp.max(jnp.abs(state.p_c))) < self.tolx
        spread = jnp.max(state.recent_best) - jnp.min(state.recent_best)
        tolfun = ((state.generation >= history) & (spread < self.tolfun)
                  & (state.generation_range < self.tolfun))
        condition = jnp.max(state.scale) ** 2 > 1e14 * jnp.min(state.scale) ** 2
        no_effect = jnp.any(state.mean == state.mean + 0.2 * state.sigma * diag) & (state.generation > 0)
        converged = tolx | tolfun
        stalled = condition | no_effect
        why = RESULTS.where(reached, RESULTS.target_reached,
                            RESULTS.where(converged, RESULTS.successful, RESULTS.stalled))
        return reached | converged | stalled, why

    def init_evaluations(self, n_dim):
        return 1 if self.start == "y0" else self.start_samples

    def step_evaluations(self, n_dim):
        lam = self._lambda(n_dim)
        return lam, lam
