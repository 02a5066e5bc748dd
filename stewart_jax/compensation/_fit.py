"""Fitting a compensation table to a campaign: per-axis polynomial degrees chosen by held-out
error, coefficient and prediction uncertainties, and only the coefficients the data support.

Stone M., 1974, "Cross-validatory choice and assessment of statistical predictions" (J. R. Stat.
Soc. B 36): the degrees in elevation, rotator angle and temperature are chosen by K-fold
held-out error, with the one-standard-error rule of Breiman L., Friedman J., Olshen R., Stone C.,
1984, "Classification and Regression Trees": the smallest model whose held-out mean squared
error is within one standard error of the lowest. The coefficients are ordinary least squares
with covariance ``s²·(AᵀA)⁻¹``, ``s²`` the residual variance. Coefficients are labelled by
``t = |c|/σ_c`` as the calibration reports of Nguyen T. D. et al., 2023, "FIGAROH: a Python
toolbox for dynamic identification and geometric calibration of robots and humanoids"
(IEEE-RAS Humanoids) label identified parameters: ``solid`` (t ≥ 5), ``marginal`` (2 ≤ t < 5),
``noise`` (t < 2). Backward elimination drops the ``noise`` coefficient of smallest t while the
held-out RMS does not grow by more than 0.2 %: only what the data support is deployed.

NOTE: the basis is the monomials of the controller's rule in scaled variables (elevation/90,
rotation/the campaign's largest |rotation|, temperature/its largest |value|), so that the normal
equations stay well conditioned; t-ratios do not depend on that scaling, and the coefficients
and their σ are divided by the scale powers on the way to the table.
"""

from __future__ import annotations

import itertools
from typing import NamedTuple

import jax.numpy as jnp
import numpy as np

from ._campaign import Campaign, check_campaign
from ._table import AXES, AXIS_UNITS, CompensationTable

SOLID_T = 5.0
MARGINAL_T = 2.0
DROP_TOLERANCE = 0.002  # relative growth of the held-out RMS allowed when a noise coefficient is dropped


class Term(NamedTuple):
    """One coefficient of an axis: ``elevation_power``, ``rotation_power`` (an ``E^j·R^k`` term)
    or ``temperature_power`` ≥ 1 (a ``T^j`` term, the others 0), its value and σ in the
    table's units, ``t = |value|/σ``, its label and whether it is deployed."""

    elevation_power: int
    rotation_power: int
    temperature_power: int
    value: float
    std: float
    t: float
    label: str
    kept: bool


class AxisFit(NamedTuple):
    """The fit of one axis (``unit``: ``"um"`` or ``"deg"``): the degrees chosen, the held-out
    RMS of each candidate tried (``cv_rms``: ``{(de, dr, dt): rms}``), the residual RMS, and the
    predictions' σ over the domain (largest and RMS, with the attitude of the largest)."""

    axis: str
    unit: str
    degrees: tuple[int, int, int]
    terms: tuple[Term, ...]
    cv_rms: float
    residual_rms: float
    prediction_std_max: float
    prediction_std_rms: float
    prediction_std_max_at: tuple[float, float, float]
    candidates: dict


class TableFit(NamedTuple):
    """:func:`fit_table`'s result: the ``table`` to deploy and, per axis, an ``AxisFit`` (its
    degrees, held-out and residual RMS, the predictions' σ over the domain, and each coefficient
    as a ``Term``: powers, value, σ, t, label, kept); :meth:`report` gives it as JSON data."""

    table: CompensationTable
    axes: tuple[AxisFit, ...]
    n_attitudes: int
    folds: int
    temperature_range_degC: tuple[float, float] | None

    def report(self) -> dict:
        """The fit as JSON-ready data: per axis the degrees, held-out and residual RMS,
        prediction σ and every coefficient with its σ, t and label (units in the keys)."""
        return _report(self)


def _design(e, r, t, scales, terms) -> np.ndarray:
    se, sr, st = scales
    cols = [(e / se) ** j * (r / sr) ** k * (t / st) ** m for j, k, m in terms]
    return np.stack(cols, axis=1) if cols else np.zeros((len(e), 0))


def _candidate_terms(de: int, dr: int, dt: int) -> list[tuple[int, int, int]]:
    return [(j, k, 0) for j in range(de + 1) for k in range(dr + 1)] + [(0, 0, m) for m in range(1, dt + 1)]


def _folds(n: int, folds: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).permutation(n) % folds


class _CrossValidation:
    """K-fold held-out RMS of least-squares fits on column subsets of one design matrix.

    NOTE: each fold's Gram matrix ``AᵀA`` of the full design is formed once; a candidate's fit
    is then a small solve on its rows and columns. In the scaled basis (variables in [−1, 1])
    the Gram matrices of the degrees tried stay below ~1e9 in condition number, far from
    float64's limit for a score; the deployed fit itself is solved by SVD (:func:`_ols`)."""

    def __init__(self, a: np.ndarray, fold: np.ndarray, folds: int):
        self.a = a
        self.test = [fold == f for f in range(folds)]
        self.gram = [a[~m].T @ a[~m] for m in self.test]
        self.rhs: list[np.ndarray] = []
        self.y = np.zeros(len(a))

    def target(self, y: np.ndarray) -> None:
        self.y = y
        self.rhs = [self.a[~m].T @ y[~m] for m in self.test]

    def squared_errors(self, cols: list[int]) -> np.ndarray:
        """Each attitude's squared held-out error."""
        y = self.y
        if not cols:
            return y**2
        sq = np.empty(len(y))
        for m, g, b in zip(self.test, self.gram, self.rhs, strict=True):
            try:
                coef = np.linalg.solve(g[np.ix_(cols, cols)], b[cols])
            except np.linalg.LinAlgError:
                coef = np.linalg.lstsq(self.a[~m][:, cols], y[~m], rcond=None)[0]
            sq[m] = (self.a[m][:, cols] @ coef - y[m]) ** 2
        return sq

    def rms(self, cols: list[int]) -> float:
        return float(np.sqrt(np.mean(self.squared_errors(cols))))


def _ols(a: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Coefficients, their covariance ``s²(AᵀA)⁻¹`` and the residual RMS."""
    if a.shape[1] == 0:
        return np.zeros(0), np.zeros((0, 0)), float(np.sqrt(np.mean(y**2)))
    u, s, vt = np.linalg.svd(a, full_matrices=False)
    inv = np.where(s > s[0] * 1e-12, 1.0 / np.where(s > 0, s, 1.0), 0.0)  # the pseudo-inverse's
    coef = vt.T @ ((u.T @ y) * inv)
    res = y - a @ coef
    dof = max(len(y) - int(np.count_nonzero(inv)), 1)
    s2 = float(res @ res) / dof
    cov = (vt.T * inv**2) @ vt * s2
    return coef, cov, float(np.sqrt(np.mean(res**2)))


def _label(t: float) -> str:
    return "solid" if t >= SOLID_T else ("marginal" if t >= MARGINAL_T else "noise")


def fit_table(
    campaign: Campaign,
    hexapod: str = "camera",
    *,
    max_degrees: tuple[int, int, int] = (5, 6, 2),
    folds: int = 5,
    seed: int = 0,
    drop: bool = True,
    rotation_range_deg: tuple[float, float] | None = None,
    one_se: bool = True,
) -> TableFit:
    """Fit a schema-v7 table to ``campaign`` (offsets in the correction sign).

    Per axis, every ``(de, dr, dt) ≤ max_degrees`` (elevation, rotator angle, temperature; the
    temperature degree is 0 unless the campaign's temperature varies) is scored by the
    ``folds``-fold held-out RMS; the smallest within one standard error of the best (``one_se``;
    else the best) is fitted on all attitudes; ``noise`` coefficients are
    then dropped while the held-out RMS allows (``drop``). The predictions' σ is evaluated over
    elevation [0, 90] × ``rotation_range_deg`` (default: the campaign's) × the campaign's
    temperatures. The temperature polynomial's range is the campaign's: outside it the
    controller extends it linearly."""
    check_campaign(campaign)
    if folds < 2:
        raise ValueError(f"folds must be >= 2, got {folds}")
    if any(d < 0 for d in max_degrees) or len(max_degrees) != 3:
        raise ValueError(f"max_degrees are three degrees >= 0 (elevation, rotation, temperature), got {max_degrees}")
    e, r, t = campaign.elevation_deg, campaign.rotation_deg, campaign.temperature_degC
    n = len(e)
    varies_t = campaign.has_temperature and np.ptp(t) > 0
    if n < 2 * folds:
        raise ValueError(f"a campaign of {n} attitudes is too small for {folds}-fold cross-validation")
    scales = (90.0, max(float(np.max(np.abs(r))), 1.0), max(float(np.max(np.abs(t))), 1.0))
    rot_range = rotation_range_deg or (float(np.min(r)), float(np.max(r)))
    grid = np.meshgrid(np.linspace(0, 90, 19), np.linspace(*rot_range, 19),
                       np.unique(np.linspace(np.min(t), np.max(t), 3)) if varies_t else np.zeros(1), indexing="ij")
    grid = [g.ravel() for g in grid]
    fold = _folds(n, folds, seed)
    # a degree needs more distinct values than itself: a campaign at one rotator angle fits none in R
    max_de, max_dr, max_dt = (min(d, len(np.unique(x)) - 1)
                              for d, x in zip(max_degrees, (e, r, t if varies_t else t[:1]), strict=True))
    ranked = list(itertools.product(range(max_de + 1), range(max_dr + 1), range(max_dt + 1)))
    all_terms = _candidate_terms(max_de, max_dr, max_dt)
    full = _design(e, r, t, scales, all_terms)
    cv = _CrossValidation(full, fold, folds)
    col = {term: i for i, term in enumerate(all_terms)}
    n_train = n - int(np.ceil(n / folds))
    axes = []
    for i, axis in enumerate(AXES):
        y = campaign.offsets[:, i]
        cv.target(y)
        scores, sq = {}, {}
        for deg in ranked:
            terms = _candidate_terms(*deg)
            if len(terms) >= 0.8 * n_train:
                continue
            sq[deg] = cv.squared_errors([col[x] for x in terms])
            scores[deg] = float(np.sqrt(np.mean(sq[deg])))
        best = min(scores, key=lambda d: (scores[d], len(_candidate_terms(*d))))
        if one_se:
            bound = np.mean(sq[best]) + np.std(sq[best]) / np.sqrt(n)
            best = min((d for d in scores if np.mean(sq[d]) <= bound),
                       key=lambda d: (len(_candidate_terms(*d)), scores[d]))
        axes.append(_fit_axis(axis, AXIS_UNITS[i], best, scores, cv, col, scales, grid, drop))
    table = _to_table(axes, hexapod, (float(np.min(t)), float(np.max(t))) if varies_t else None)
    return TableFit(table, tuple(axes), n, folds, (float(np.min(t)), float(np.max(t))) if varies_t else None)


def _fit_axis(axis, unit, degrees, scores, cv, col, scales, grid, drop) -> AxisFit:
    full, y = cv.a, cv.y
    terms = _candidate_terms(*degrees)
    keep = list(terms)
    dropped: dict[tuple[int, int, int], float] = {}
    best = scores[degrees]
    while drop and keep:
        a = full[:, [col[x] for x in keep]]
        coef, cov, _ = _ols(a, y)
        tr = np.abs(coef) / np.sqrt(np.maximum(np.diag(cov), 1e-300))
        order = [j for j in np.argsort(tr) if tr[j] < MARGINAL_T]
        if not order:
            break
        j = order[0]
        trial = keep[:j] + keep[j + 1:]
        cv_trial = cv.rms([col[x] for x in trial])
        if cv_trial > best * (1.0 + DROP_TOLERANCE):
            break
        dropped[keep[j]] = float(tr[j])
        keep, best = trial, cv_trial
    a = full[:, [col[x] for x in keep]]
    coef, cov, rms = _ols(a, y)
    se, sr, st = scales
    factor = np.array([1.0 / (se**j * sr**k * st**m) for j, k, m in keep])
    std = np.sqrt(np.diag(cov))
    out = [Term(j, k, m, float(c * f), float(s * f), float(abs(c) / s) if s > 0 else np.inf,
                _label(abs(c) / s if s > 0 else np.inf), True)
           for (j, k, m), c, s, f in zip(keep, coef, std, factor, strict=True)]
    out += [Term(j, k, m, 0.0, float("nan"), tval, "noise", False) for (j, k, m), tval in dropped.items()]
    phi = _design(*grid, scales, keep)
    pstd = np.sqrt(np.einsum("ij,jk,ik->i", phi, cov, phi))
    worst = int(np.argmax(pstd))
    return AxisFit(axis, unit, degrees, tuple(out), best, rms, float(pstd[worst]), float(np.sqrt(np.mean(pstd**2))),
                   (float(grid[0][worst]), float(grid[1][worst]), float(grid[2][worst])),
                   {f"{d[0]},{d[1]},{d[2]}": s for d, s in scores.items()})


def _to_table(axes: list[AxisFit], hexapod: str, t_range: tuple[float, float] | None) -> CompensationTable:
    de = max([x.elevation_power for a in axes for x in a.terms] + [0])
    dr = max([x.rotation_power for a in axes for x in a.terms] + [0])
    dt = max([x.temperature_power for a in axes for x in a.terms] + [0])
    er = np.zeros((6, de + 1, dr + 1))
    tc = np.zeros((6, dt + 1))
    for i, a in enumerate(axes):
        for x in a.terms:
            if not x.kept:
                continue
            if x.temperature_power:
                tc[i, x.temperature_power] = x.value
            else:
                er[i, x.elevation_power, x.rotation_power] = x.value
    lo, hi = t_range if t_range is not None else (-20.0, 20.0)
    return CompensationTable(jnp.asarray(er), jnp.zeros((6, 1)), jnp.asarray(tc), jnp.asarray(lo), jnp.asarray(hi),
                             jnp.zeros(0), (), bool(dt > 0), hexapod)


def _coefficient_unit(unit: str, term: Term) -> str:
    """``um/deg^3``, ``deg/degC``, ``um``: the unit of a coefficient of the rule."""
    out = unit
    for name, n in (("deg", term.elevation_power + term.rotation_power), ("degC", term.temperature_power)):
        if n:
            out += f"/{name}" + (f"^{n}" if n > 1 else "")
    return out


def _report(fit: TableFit) -> dict:
    out = {"n_attitudes": fit.n_attitudes, "folds": fit.folds,
           "temperature_range_degC": fit.temperature_range_degC, "labels": {
               "solid": f"t >= {SOLID_T:g}", "marginal": f"{MARGINAL_T:g} <= t < {SOLID_T:g}",
               "noise": f"t < {MARGINAL_T:g}"}, "axes": {}}
    for a in fit.axes:
        u = a.unit
        out["axes"][a.axis] = {
            "unit": u, "degrees": {"elevation": a.degrees[0], "rotation": a.degrees[1], "temperature": a.degrees[2]},
            f"cv_rms_{u}": a.cv_rms, f"residual_rms_{u}": a.residual_rms,
            f"prediction_std_max_{u}": a.prediction_std_max, f"prediction_std_rms_{u}": a.prediction_std_rms,
            "prediction_std_max_at": dict(zip(("elevation_deg", "rotation_deg", "temperature_degC"),
                                              a.prediction_std_max_at, strict=True)),
            f"cv_rms_by_degrees_{u}": a.candidates,
            "coefficients": [{"elevation_power": x.elevation_power, "rotation_power": x.rotation_power,
                              "temperature_power": x.temperature_power, "unit": _coefficient_unit(u, x),
                              "value": x.value, "std": x.std, "t": x.t, "label": x.label, "kept": x.kept}
                             for x in a.terms],
        }
    return out
