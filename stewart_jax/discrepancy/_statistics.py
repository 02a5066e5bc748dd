"""Statistics of the discrepancy workflow: χ² and F tail probabilities, nested-model tests,
the held-out (predictive) χ², the Bayesian information criterion, the noise-scale estimate,
and the "where" analysis of residuals against factors.

References: likelihood-ratio / extra-sum-of-squares F tests of nested linear(ised) models and
the predictive χ² (Seber and Lee 2003, "Linear Regression Analysis", §4.3, §5.1); BIC (Schwarz
1978, "Estimating the dimension of a model", Ann. Statist. 6); Bonferroni correction of
multiple tests; Pearson correlation t test with ``m − 2`` degrees of freedom.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
from jax.scipy.special import betainc, gammaincc
from jaxtyping import Float

from ._subspace import prediction_factor


def chi2_sf(x: float, dof: float) -> float:
    """``P(χ²_dof > x)``."""
    if dof <= 0:
        return 1.0
    return float(gammaincc(dof / 2.0, max(float(x), 0.0) / 2.0))


def f_sf(x: float, d1: float, d2: float) -> float:
    """``P(F(d1, d2) > x)``."""
    if d1 <= 0 or d2 <= 0:
        return 1.0
    x = max(float(x), 0.0)
    return float(betainc(d2 / 2.0, d1 / 2.0, d2 / (d2 + d1 * x)))


def nested_p(chi2_small: float, chi2_big: float, df: int, dof_big: int, known: bool) -> float:
    """p-value of "the bigger model explains nothing more": χ² test of the drop with ``df``
    degrees of freedom when σ is known, F test (σ² estimated from the bigger model) otherwise."""
    if df <= 0:
        return 1.0
    drop = max(chi2_small - chi2_big, 0.0)
    if known:
        return chi2_sf(drop, df)
    return f_sf((drop / df) / (chi2_big / dof_big), df, dof_big)


def heldout_p(t: float, n_te: int, dof0: int, scale2: float, known: bool) -> float:
    """p-value of a held-out χ² ``t`` of ``n_te`` residuals: χ²(n_te) when σ is known, else
    ``F(n_te, dof0)`` of ``(t / n_te) / scale2`` (``scale2`` estimated with ``dof0`` dof)."""
    return chi2_sf(t, n_te) if known else f_sf((t / n_te) / scale2, n_te, dof0)


def noise_scale2(chi2_base: float, dof0: int, known: bool) -> float:
    """Noise variance relative to the model's σ²: 1 when σ is trusted, else the base fit's
    training ``χ² / dof``."""
    return chi2_base / dof0 if not known else 1.0


def bic(chi2: float, n_params: int, n_obs: int, known: bool) -> float:
    """BIC of a least-squares fit with whitened ``chi2``: ``χ² + p ln n`` when σ is known,
    ``n ln(χ²/n) + p ln n`` (σ profiled out) otherwise."""
    if known:
        return chi2 + n_params * math.log(n_obs)
    return n_obs * math.log(max(chi2, 1e-300) / n_obs) + n_params * math.log(n_obs)


def heldout_chi2(r: Float[np.ndarray, " t"], a_tr: Float[np.ndarray, "n p"], a_te: Float[np.ndarray, "t p"]) -> float:
    """``rᵀ (I + U Uᵀ)⁻¹ r`` with ``U Uᵀ = A_te (A_trᵀ A_tr)⁺ A_teᵀ`` (see
    :func:`~stewart_jax.discrepancy._subspace.prediction_factor`), by Woodbury:
    ``rᵀr − (Uᵀr)ᵀ (I + UᵀU)⁻¹ (Uᵀr)``. All in whitened units.

    NOTE: the held-out residual of a fit is the held-out noise minus the prediction error of
    the fitted parameters, ``r = ε_te − A_te (û − u)``, with ``Cov(û) = (A_trᵀ A_tr)⁻¹`` in
    whitened units and independent of ``ε_te``. Its covariance is therefore
    ``I + A_te C A_teᵀ``, and the statistic is exactly χ²(n_te) for a correct linear(ised) model.
    Ignoring the second term would raise the false-alarm rate: with 36 parameters fitted to a
    few hundred residuals it inflates the held-out χ² by several percent.
    """
    u = prediction_factor(a_tr, a_te)
    ur = u.T @ r
    return float(r @ r - ur @ np.linalg.solve(np.eye(u.shape[1]) + u.T @ u, ur))


# ---------------------------------------------------------------------------- where


class Bin(NamedTuple):
    """Mean residual (report units) of the rows whose factor falls in one bin (mean factor
    ``x``, in the factor's unit; ``n`` rows)."""

    x: float
    mean: float
    n: int

    def to_dict(self) -> dict[str, Any]:
        return {"x": self.x, "mean": self.mean, "n": self.n}


class FactorDependence(NamedTuple):
    """How the residuals of each output depend on one factor (one entry per output):
    Pearson ``correlation``, its two-sided ``p_value``, the least-squares ``slope`` (report
    units per factor unit; NaN where undefined) and the binned means ``bins``."""

    correlation: list[float]
    p_value: list[float]
    slope: list[float]
    bins: list[list[Bin]]

    def to_dict(self) -> dict[str, Any]:
        return {
            "correlation": list(self.correlation),
            "p_value": list(self.p_value),
            "slope": list(self.slope),
            "bins": [[b.to_dict() for b in bs] for bs in self.bins],
        }


class WhereFlag(NamedTuple):
    """A (factor, output) pair whose correlation is significant after Bonferroni."""

    factor: str
    output: str
    correlation: float
    p_value: float

    def to_dict(self) -> dict[str, Any]:
        return {"factor": self.factor, "output": self.output, "correlation": self.correlation, "p_value": self.p_value}


class WhereAnalysis(NamedTuple):
    """Result of :func:`where_analysis`: the ``outputs`` names, per factor name its
    :class:`FactorDependence`, and the ``flags`` sorted by p-value."""

    outputs: list[str]
    factors: dict[str, FactorDependence]
    flags: list[WhereFlag]

    def to_dict(self) -> dict[str, Any]:
        return {
            "outputs": list(self.outputs),
            "factors": {k: v.to_dict() for k, v in self.factors.items()},
            "flags": [f.to_dict() for f in self.flags],
        }


def where_analysis(
    residuals: Float[np.ndarray, "m k"],
    factors: dict[str, Float[np.ndarray, "m k"]],
    output_names: Sequence[str],
    alpha: float,
    n_bins: int = 4,
) -> WhereAnalysis:
    """How the residuals (report units) depend on each factor: per output, Pearson
    correlation, its two-sided p-value (t test, ``m − 2`` dof), the slope, and mean residuals in
    quantile bins (or per value for a two-valued factor). ``flags`` lists the (factor, output)
    pairs significant at ``alpha`` after Bonferroni over all pairs."""
    m, k = residuals.shape
    n_tests = max(len(factors) * k, 1)
    flags, out = [], {}
    for name, x in factors.items():
        corr, pval, slopes, all_bins = [], [], [], []
        for j in range(k):
            xj, rj = np.asarray(x[:, j], dtype=float), residuals[:, j]
            sx, sr = np.std(xj), np.std(rj)
            if m < 3 or sx == 0 or sr == 0:
                r = p = slope = float("nan")
            else:
                r = float(np.corrcoef(xj, rj)[0, 1])
                r = float(np.clip(r, -1 + 1e-15, 1 - 1e-15))
                t2 = r * r * (m - 2) / (1 - r * r)
                p = f_sf(t2, 1, m - 2)
                slope = float(np.polyfit(xj, rj, 1)[0])
            values = np.unique(xj)
            if values.size <= 2:
                bins = [Bin(float(v), float(np.mean(rj[xj == v])), int(np.sum(xj == v))) for v in values]
            else:
                edges = np.quantile(xj, np.linspace(0, 1, n_bins + 1))
                idx = np.clip(np.searchsorted(edges, xj, side="right") - 1, 0, n_bins - 1)
                bins = [
                    Bin(float(np.mean(xj[sel])), float(np.mean(rj[sel])), int(np.sum(sel)))
                    for sel in (idx == b for b in range(n_bins))
                    if np.any(sel)
                ]
            corr.append(r)
            pval.append(p)
            slopes.append(slope)
            all_bins.append(bins)
            if math.isfinite(p) and p < alpha / n_tests:
                flags.append(WhereFlag(name, output_names[j], r, p))
        out[name] = FactorDependence(corr, pval, slopes, all_bins)
    return WhereAnalysis(list(output_names), out, sorted(flags, key=lambda f: f.p_value))
