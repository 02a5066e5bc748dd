"""Discovered terms earn their place: a term of the open search is kept only when it shrinks the
held-out gap and is chosen again on most re-splits of the training rows, in the manner of the
ensembles of PySINDy (Fasel, Kutz, Brunton, Brunton 2022, "Ensemble-SINDy: Robust sparse model
discovery in the low-data, high-noise limit, with active learning and control", Proc. R. Soc. A
478; de Silva et al. 2020, "PySINDy: a Python package for the sparse identification of
nonlinear dynamical systems from data", JOSS 5(49)).

1. The forward selection of ``_discovery.py`` runs on the training rows and gives groups in the
   order chosen.
2. It runs again on :data:`N_SPLITS` seeded re-splits of the training rows (a share
   :data:`SUB_FRACTION` for the selection, the rest for its held-out stop); a group's *inclusion
   frequency* is the share of re-splits that choose it again (the same factor, form, degree,
   product and actuator; a period within :data:`PERIOD_MATCH`).
3. In the order chosen, a group is kept when its inclusion frequency is at least
   :data:`MIN_INCLUSION` and adding it to the groups kept so far lowers the held-out residual RMS
   (the gap); a group that fails is dropped from the fit, the report and the summary.
4. The kept groups are fitted together (the base Jacobian in the regression); the augmented
   model passes when the held-out test that detected the discrepancy passes at the same level.
5. The kept groups are not a discovery when a registered candidate reproduces their fitted
   signature (the encompassing test of ``_equivalence.py``: the part of the signature outside base
   + the candidate is within the noise): they are that candidate again, whose own held-out test and
   comparison with the others already decided it (e.g. one coefficient per strut on the reading,
   which is ``strut_scale``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from ._discovery import (
    DiscoveredTerms,
    TermSpec,
    _columns,
    _legs,
    _n_coef,
    _unit,
    describe,
    discover,
    period_unit,
    reading_factor,
    term_units,
)
from ._equivalence import encompassed
from ._statistics import bic, heldout_chi2, heldout_p, nested_p
from ._subspace import basis

N_SPLITS = 5
"""Re-splits of the training rows on which the selection is repeated."""
SUB_FRACTION = 0.7
"""Share of the training rows the selection uses on a re-split (the rest is its held-out stop)."""
MIN_INCLUSION = 0.6
"""Least inclusion frequency of a kept group (3 of 5 re-splits)."""
PERIOD_MATCH = 0.02
"""Relative difference of periods within which a re-split's periodic group is the same group."""


class TermInputs(NamedTuple):
    """What the open search works on (see :func:`~stewart_jax.discrepancy._discovery.discover`):
    the base fit's whitened residuals and Jacobians on the training and held-out rows, the
    readings (library unit), the whiteners, the raw held-out residuals (library units)."""

    model: Any
    train: Any
    test: Any
    reading_tr: np.ndarray
    reading_te: np.ndarray
    white_tr: np.ndarray
    white_te: np.ndarray
    raw_te: np.ndarray
    w_tr: np.ndarray
    w_te: np.ndarray
    jac_tr: np.ndarray
    jac_te: np.ndarray
    dof0: int
    scale2: float
    known: bool
    alpha: float


class TermFit(NamedTuple):
    """A fit of base + groups: ``delta`` (scaled base unknowns), ``coef`` and ``std`` (library
    units), training ``chi2`` and column ``rank``, held-out ``heldout_p`` and ``gap_after``
    (report unit)."""

    delta: np.ndarray
    coef: np.ndarray
    std: np.ndarray
    chi2: float
    rank: int
    heldout_p: float
    gap_after: float


def fit_terms(specs: Sequence[TermSpec], inp: TermInputs) -> TermFit:
    """Base + ``specs`` fitted on the training rows (linearised at the base fit) and tested on
    the held-out rows."""
    scale = reading_factor(inp.model)[0]
    blocks_tr = [inp.jac_tr] + [_columns(s, inp.reading_tr * scale, inp.train, inp.w_tr) for s in specs]
    blocks_te = [inp.jac_te] + [_columns(s, inp.reading_te * scale, inp.test, inp.w_te) for s in specs]
    a_tr, a_te = np.concatenate(blocks_tr, axis=1), np.concatenate(blocks_te, axis=1)
    sol = np.linalg.lstsq(a_tr, -inp.white_tr, rcond=None)[0]
    res = inp.white_tr + a_tr @ sol
    # r(z + δ) ≈ r + J δ; the terms enter as + C c with c = −(coefficient): see _columns.
    r_te = inp.white_te + a_te @ sol
    p_te = heldout_p(heldout_chi2(r_te, a_tr, a_te), inp.white_te.size, inp.dof0, inp.scale2, inp.known)
    raw_after = inp.raw_te + np.einsum("mij,mj->mi", np.linalg.inv(inp.w_te), (a_te @ sol).reshape(inp.raw_te.shape))
    nb = inp.jac_tr.shape[1]
    cov = np.linalg.pinv(a_tr.T @ a_tr) * inp.scale2
    return TermFit(
        delta=sol[:nb], coef=-sol[nb:], std=np.sqrt(np.clip(np.diag(cov)[nb:], 0, None)), chi2=float(res @ res),
        rank=basis(a_tr).shape[1], heldout_p=float(p_te),
        gap_after=float(np.sqrt(np.mean(raw_after**2)) * inp.model.report_factor),
    )


def _same(a: TermSpec, b: TermSpec) -> bool:
    if a._replace(period=None) != b._replace(period=None):
        return False
    return a.period is None or abs(b.period / a.period - 1.0) <= PERIOD_MATCH


def _split_inputs(inp: TermInputs, sub: np.ndarray, held: np.ndarray) -> TermInputs:
    """The training rows ``sub`` as a training part and ``held`` as a held-out part."""
    m, k = inp.reading_tr.shape
    white = inp.white_tr.reshape(m, k)
    jac = inp.jac_tr.reshape(m, k, -1)
    raw_held = np.einsum("mij,mj->mi", np.linalg.inv(inp.w_tr[held]), white[held])
    take = inp.model.take
    n_sub = sub.size * k
    return inp._replace(
        train=take(inp.train, sub), test=take(inp.train, held), reading_tr=inp.reading_tr[sub],
        reading_te=inp.reading_tr[held], white_tr=white[sub].reshape(-1), white_te=white[held].reshape(-1),
        raw_te=raw_held, w_tr=inp.w_tr[sub], w_te=inp.w_tr[held], jac_tr=jac[sub].reshape(n_sub, -1),
        jac_te=jac[held].reshape(held.size * k, -1), dof0=n_sub - basis(jac[sub].reshape(n_sub, -1)).shape[1],
    )


def inclusion_frequency(specs: Sequence[TermSpec], inp: TermInputs, seed: int = 0) -> list[float]:
    """Per group of ``specs``, the share of :data:`N_SPLITS` re-splits of the training rows whose
    own selection chooses it again."""
    m = inp.reading_tr.shape[0]
    n_sub = int(round(SUB_FRACTION * m))
    rng = np.random.default_rng(seed)
    hits = np.zeros(len(specs))
    for _ in range(N_SPLITS):
        perm = rng.permutation(m)
        sub_inp = _split_inputs(inp, np.sort(perm[:n_sub]), np.sort(perm[n_sub:]))
        found = discover(**sub_inp._asdict())
        hits += [any(_same(s, f) for f in found) for s in specs]
    return (hits / N_SPLITS).tolist()


def earn_place(inp: TermInputs, gap_before: float) -> tuple[DiscoveredTerms, list[dict[str, Any]], TermFit, bool]:
    """The open search with every group earning its place (module docstring): the kept terms,
    one report dict per kept group (JSON form), the fit of base + kept groups, and whether it
    passes the held-out test. ``gap_before``: the base model's held-out RMS (report unit)."""
    chosen = discover(**inp._asdict())
    k = inp.reading_tr.shape[1]
    freq = inclusion_frequency(chosen, inp) if chosen else []
    kept: list[TermSpec] = []
    steps: list[dict[str, Any]] = []
    now = fit_terms([], inp)
    gap_now = gap_before
    for spec, f in zip(chosen, freq, strict=True):
        if f < MIN_INCLUSION:
            continue
        trial = fit_terms([*kept, spec], inp)
        if not trial.gap_after < gap_now:
            continue
        df = trial.rank - now.rank
        n_tr = inp.white_tr.size
        steps.append({
            "gap_before": gap_now, "gap_after": trial.gap_after, "heldout_p": trial.heldout_p,
            "p_value": float(nested_p(now.chi2, trial.chi2, df, n_tr - trial.rank, inp.known)),
            "bic_gain": float(bic(now.chi2, now.rank, n_tr, inp.known) - bic(trial.chi2, trial.rank, n_tr, inp.known)),
            "inclusion_frequency": f,
        })
        kept.append(spec)
        now, gap_now = trial, trial.gap_after
    terms = DiscoveredTerms(tuple(kept), k)
    passed = bool(kept) and now.heldout_p >= inp.alpha
    return terms, _term_reports(terms, steps, now.coef, now.std, inp.model), now, passed


def _term_reports(terms: DiscoveredTerms, steps: Sequence[dict], coef, std, model) -> list[dict[str, Any]]:
    out, off = [], 0
    rf = model.report_factor
    units = term_units(model)
    for s, step in zip(terms.specs, steps, strict=True):
        c = _n_coef(s)
        names = ("sin", "cos") if s.form == "periodic" else ("coefficient",)
        coefs = []
        for j in _legs(s, terms.k):
            for i, nm in enumerate(names):
                coefs.append({"leg": j + 1, "basis": nm, "value": float(coef[off + i] * rf),
                              "std": float(std[off + i] * rf), "unit": _unit(s, units, j)})
            off += c
        d = {
            "leg": None if s.leg is None else s.leg + 1,
            "output": None if s.leg is None or units.names is None else units.names[s.leg],
            "factor": s.factor,
            "form": s.form,
            "period": s.period,
            "period_unit": period_unit(s, units),
            "degree": s.degree,
            "times": s.times or None,
            "coefficients": coefs,
            "gap_before": step["gap_before"],
            "gap_after": step["gap_after"],
            "heldout_p": step["heldout_p"],
            "p_value": step["p_value"],
            "inclusion_frequency": step["inclusion_frequency"],
            "description": describe(s, units),
        }
        if s.form == "periodic":
            amp = [math.hypot(coefs[2 * i]["value"], coefs[2 * i + 1]["value"]) for i in range(len(coefs) // 2)]
            d["amplitude"] = amp
            d["amplitude_unit"] = ", ".join(dict.fromkeys(units.report[j] for j in _legs(s, terms.k)))
        out.append(d)
    return out


def reproduced_by(terms: DiscoveredTerms, fit: TermFit, inp: TermInputs,
                  candidates: Sequence[tuple[str, np.ndarray]]) -> str | None:
    """The first registered candidate that reproduces the kept terms' fitted signature (step 5 of
    the module docstring), or ``None``. ``candidates``: per registered candidate its name and its
    whitened training columns ``(rows, c)``, in the row order of ``inp.jac_tr``."""
    if not terms.specs:
        return None
    scale = reading_factor(inp.model)[0]
    cols = np.concatenate([_columns(s, inp.reading_tr * scale, inp.train, inp.w_tr) for s in terms.specs], axis=1)
    q_g = basis(inp.jac_tr)
    own = cols - q_g @ (q_g.T @ cols)
    sig = own @ fit.coef
    return next((name for name, cand in candidates
                 if encompassed(inp.jac_tr, cand, sig, own, inp.alpha, inp.scale2)[1]), None)
