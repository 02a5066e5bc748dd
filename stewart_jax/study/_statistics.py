"""Paired statistics and benchmarking profiles for comparing calibration methods over seeds.

- Wilcoxon signed-rank test: Wilcoxon F., "Individual comparisons by ranking methods",
  Biometrics Bulletin 1(6) (1945) 80–83. Zero differences are dropped (Wilcoxon's rule), ties
  get average ranks. Exact null distribution (all ``2ⁿ`` sign patterns, counted by dynamic
  programming) when there are at most 50 non-zero differences and no ties; otherwise the normal
  approximation with the tie correction of the variance, ``n(n+1)(2n+1)/24 − Σ(t³ − t)/48``
  (no continuity correction) — the choices of ``scipy.stats.wilcoxon``'s defaults.
- Bootstrap confidence interval of the median of the paired ratios ``a_i / b_i``: Efron B.,
  Tibshirani R., *An Introduction to the Bootstrap* (1993), ch. 13 (percentile interval),
  resampling whole seeds so that the pairing (common random numbers) is kept.
- Data profiles: Moré J. J., Wild S. M., "Benchmarking derivative-free optimization
  algorithms", SIAM J. Optim. 20(1) (2009) 172–191: the convergence test of their eq. (2.2),
  ``f(x) ≤ f_L + τ·(f(x₀) − f_L)`` with ``f_L`` the best value any solver reached on the problem,
  and the data profile of eq. (2.7), ``d_s(α) = |{p : t_{p,s} / (n_p + 1) ≤ α}| / |P|`` (``α`` in
  "simplex gradients", ``n_p + 1`` evaluations each).
- Budget curves: the best value found within each budget of a grid (the anytime curve read off
  an optimiser's history).

NumPy only (no SciPy at import time); ``stewart_jax.study`` re-exports every public name.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

_EXACT_MAX_N = 50


class WilcoxonResult(NamedTuple):
    """``statistic``: ``min(W⁺, W⁻)`` (the two-sided statistic); ``w_plus``: the sum of the ranks of
    the positive differences ``x − y``; ``p_value`` (two-sided); ``n``: non-zero differences;
    ``method``: ``"exact"`` or ``"normal"``."""

    statistic: float
    w_plus: float
    p_value: float
    n: int
    method: str


def _ranks(a: np.ndarray) -> np.ndarray:
    """Ranks 1 … n of ``a`` with ties given their average rank."""
    order = np.argsort(a, kind="mergesort")
    ranks = np.empty(len(a), dtype=np.float64)
    sorted_a = a[order]
    i = 0
    while i < len(a):
        j = i
        while j + 1 < len(a) and sorted_a[j + 1] == sorted_a[i]:
            j += 1
        ranks[order[i:j + 1]] = 0.5 * (i + j) + 1.0
        i = j + 1
    return ranks


def _signed_rank_counts(n: int) -> np.ndarray:
    """Number of sign patterns of ranks ``1 … n`` whose positive ranks sum to ``s``, ``s = 0 … n(n+1)/2``."""
    top = n * (n + 1) // 2
    counts = np.zeros(top + 1, dtype=np.float64)
    counts[0] = 1.0
    for k in range(1, n + 1):
        counts[k:] = counts[k:] + counts[:-k].copy()
    return counts


def wilcoxon_signed_rank(x, y=None) -> WilcoxonResult:
    """Two-sided Wilcoxon signed-rank test of ``x − y`` (paired samples; ``y`` omitted: of ``x``)
    against a distribution symmetric about 0. Non-finite pairs raise; all-zero differences give
    ``p = 1``."""
    x = np.asarray(x, dtype=np.float64).ravel()
    if y is not None and np.size(y) != x.size:
        raise ValueError(f"x and y must have the same length, got {x.size} and {np.size(y)}")
    d = x if y is None else x - np.asarray(y, dtype=np.float64).ravel()
    if not np.all(np.isfinite(d)):
        raise ValueError("the paired differences must be finite (drop or repair failed runs first)")
    d = d[d != 0.0]
    n = d.size
    if n == 0:
        return WilcoxonResult(0.0, 0.0, 1.0, 0, "exact")
    r = _ranks(np.abs(d))
    w_plus = float(np.sum(r[d > 0]))
    w_minus = float(np.sum(r[d < 0]))
    stat = min(w_plus, w_minus)
    ties = len(np.unique(np.abs(d))) < n
    if n <= _EXACT_MAX_N and not ties:
        counts = _signed_rank_counts(n)
        cdf = float(np.sum(counts[: int(stat) + 1])) / 2.0**n
        return WilcoxonResult(stat, w_plus, min(1.0, 2.0 * cdf), n, "exact")
    _, t = np.unique(np.abs(d), return_counts=True)
    mean = n * (n + 1) / 4.0
    var = n * (n + 1) * (2 * n + 1) / 24.0 - float(np.sum(t**3 - t)) / 48.0
    z = (w_plus - mean) / math.sqrt(var) if var > 0 else 0.0
    return WilcoxonResult(stat, w_plus, math.erfc(abs(z) / math.sqrt(2.0)), n, "normal")


class RatioInterval(NamedTuple):
    """``estimate``: the median of the paired ratios; ``low``, ``high``: the percentile bootstrap
    interval at ``confidence``."""

    estimate: float
    low: float
    high: float
    confidence: float


def bootstrap_median_ratio(a, b, *, n_resamples: int = 10_000, confidence: float = 0.95,
                           seed: int = 0) -> RatioInterval:
    """Median of ``a_i / b_i`` over paired seeds and its percentile bootstrap interval (seeds
    resampled with replacement, pairs kept together). A ratio below 1 means ``a`` is smaller
    (better, for a cost or an error)."""
    a = np.asarray(a, dtype=np.float64).ravel()
    b = np.asarray(b, dtype=np.float64).ravel()
    if a.shape != b.shape or a.size == 0:
        raise ValueError(f"a and b must be non-empty and of one length, got {a.size} and {b.size}")
    if not (0.0 < confidence < 1.0):
        raise ValueError(f"confidence must lie in (0, 1), got {confidence}")
    if int(n_resamples) < 1:
        raise ValueError(f"n_resamples must be >= 1, got {n_resamples}")
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b)) and np.all(b > 0) and np.all(a >= 0)):
        raise ValueError("the paired values must be finite, a >= 0 and b > 0 (costs or errors)")
    ratio = a / b
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, ratio.size, size=(int(n_resamples), ratio.size))
    boot = np.median(ratio[idx], axis=1)
    tail = 50.0 * (1.0 - confidence)
    low, high = np.percentile(boot, [tail, 100.0 - tail])
    return RatioInterval(float(np.median(ratio)), float(low), float(high), confidence)


def paired_comparison(a, b, **bootstrap_options) -> dict:
    """Both statistics for paired per-seed values of two methods (lower is better): the Wilcoxon
    p-value of ``a − b``, the median ratio ``a/b`` with its bootstrap interval, and the fraction
    of seeds on which ``a`` is strictly better. JSON-ready."""
    w = wilcoxon_signed_rank(a, b)
    r = bootstrap_median_ratio(a, b, **bootstrap_options)
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return {"n": int(a.size), "wilcoxon_p": w.p_value, "wilcoxon_method": w.method, "w_plus": w.w_plus,
            "median_ratio": r.estimate, "ratio_ci_low": r.low, "ratio_ci_high": r.high,
            "confidence": r.confidence, "a_better_fraction": float(np.mean(a < b))}


def best_within_budgets(history_cost, history_evaluations, budgets) -> np.ndarray:
    """The best value found within each budget: for trial ``t`` and budget ``g``, the last
    ``history_cost[t, k]`` whose ``history_evaluations[t, k] ≤ g`` (histories hold the best so far,
    so this is the best within ``g`` calls); +inf where no entry fits. Shapes ``(T, K)``,
    ``(T, K)``, ``(G,)`` → ``(T, G)``."""
    cost = np.atleast_2d(np.asarray(history_cost, dtype=np.float64))
    evals = np.atleast_2d(np.asarray(history_evaluations, dtype=np.float64))
    budgets = np.asarray(budgets, dtype=np.float64).ravel()
    if cost.shape != evals.shape:
        raise ValueError(f"history_cost {cost.shape} and history_evaluations {evals.shape} differ in shape")
    best = np.minimum.accumulate(np.where(np.isnan(cost), np.inf, cost), axis=1)
    out = np.full((cost.shape[0], budgets.size), np.inf)
    for t in range(cost.shape[0]):
        k = np.searchsorted(evals[t], budgets, side="right") - 1  # evaluation counts never decrease
        out[t] = np.where(k >= 0, best[t, np.maximum(k, 0)], np.inf)
    return out


def evaluations_to_solve(history_cost, history_evaluations, threshold) -> np.ndarray:
    """Moré & Wild's ``t_{p,s}``: the evaluations after which the best value first satisfies
    ``cost ≤ threshold`` (one threshold per problem); +inf where it never does. Shapes
    ``(P, K)``, ``(P, K)``, ``(P,)`` → ``(P,)``."""
    cost = np.atleast_2d(np.asarray(history_cost, dtype=np.float64))
    evals = np.atleast_2d(np.asarray(history_evaluations, dtype=np.float64))
    thr = np.asarray(threshold, dtype=np.float64).reshape(-1, 1)
    hit = cost <= thr
    first = np.argmax(hit, axis=1)
    return np.where(hit.any(axis=1), evals[np.arange(cost.shape[0]), first], np.inf)


def data_profiles(histories: Sequence[tuple], f0, n_dim, alphas, tau: float = 1e-3):
    """Moré–Wild data profiles of several solvers on one problem set.

    ``histories``: per solver, ``(history_cost, history_evaluations)`` of shapes ``(P, K_s)``
    (any history length per solver; the same ``P`` problems in the same order); ``f0``: ``(P,)``,
    the value at the common starting point of each problem; ``n_dim``: the number of parameters
    (an int, or ``(P,)``); ``alphas``: budgets in simplex gradients; ``tau``: the tolerance of
    eq. (2.2). Returns ``(profiles, f_best)``: ``profiles[s, a]`` is the fraction of problems
    solver ``s`` solves within ``alphas[a]·(n_p + 1)`` evaluations, ``f_best`` the ``f_L`` per problem.
    """
    if not 0.0 < tau < 1.0:
        raise ValueError(f"tau must lie in (0, 1), got {tau}")
    f0 = np.asarray(f0, dtype=np.float64).ravel()
    n_p = np.broadcast_to(np.asarray(n_dim, dtype=np.float64), f0.shape)
    costs = [np.atleast_2d(np.asarray(c, dtype=np.float64)) for c, _ in histories]
    if any(c.shape[0] != f0.size for c in costs):
        raise ValueError(f"every solver's history must have {f0.size} problems (rows), got "
                         f"{[c.shape[0] for c in costs]}")
    f_best = np.min(np.stack([np.nanmin(np.where(np.isnan(c), np.inf, c), axis=1) for c in costs]), axis=0)
    threshold = f_best + tau * (f0 - f_best)
    alphas = np.asarray(alphas, dtype=np.float64).ravel()
    out = np.zeros((len(histories), alphas.size))
    for s, (c, e) in enumerate(histories):
        t = evaluations_to_solve(c, e, threshold) / (n_p + 1.0)
        out[s] = np.mean(t[:, None] <= alphas[None, :], axis=0)
    return out, f_best
