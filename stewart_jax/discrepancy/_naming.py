"""Detect and name: the tests on one data set once its fits are done (the driver,
``_driver.py``, batches the fits and assembles the report).

Detection is the base model's held-out χ² test; naming is each candidate's likelihood-ratio test
against the base with its identifiable degrees of freedom, its BIC score and its held-out test,
at the Bonferroni level over the testable candidates, and the encompassing tests of the named
candidate against each other significant one fitted together with it (Mizon and Richard 1986,
"The encompassing principle and its application to testing non-nested hypotheses",
Econometrica 54). The statistics are in ``_statistics.py``, the subspace algebra in
``_subspace.py``.
"""

from __future__ import annotations

import dataclasses
from typing import Any, NamedTuple

import numpy as np

from ._errors_in_variables import heldout_corrections
from ._fits import BatchFits
from ._registry import AbstractDiscrepancyModel, Effect
from ._report import Candidate
from ._statistics import bic, heldout_chi2, heldout_p, nested_p, noise_scale2
from ._subspace import absorption, basis, n_identifiable, rank


@dataclasses.dataclass(frozen=True)
class Decision:
    """Detection and naming on one data set, before the report is assembled.

    - ``cands``: per candidate (the order of ``effects``) its :class:`Candidate`.
    - ``significant``: indices of the significant candidates.
    - ``named_index``: index of the named candidate (``None``: none).
    - ``detected``, ``p_detect``, ``t0``: the held-out test of the base model (χ² ``t0``).
    - ``dof0``: residual dof of the base fit; ``rank_g``: rank of its whitened Jacobian.
    - ``scale2``: noise variance relative to the model's σ² (1 when σ is trusted).
    - ``level``: Bonferroni level of the candidates' tests.
    - ``chi2``: ``(K+1,)`` training χ² of the base fit and the single-candidate fits.
    - ``n_tr``, ``n_te``: whitened training / held-out residuals.
    - ``pairs``: index ``c`` → training χ² of named + ``c`` fitted together.
    - ``outcome``: index ``c`` → (p of "c explains named ∪ c", p of "named explains named ∪ c").
    """

    cands: tuple[Candidate, ...]
    significant: tuple[int, ...]
    named_index: int | None
    detected: bool
    p_detect: float
    t0: float
    dof0: int
    rank_g: int
    scale2: float
    level: float
    chi2: np.ndarray
    n_tr: int
    n_te: int
    pairs: dict[int, float] = dataclasses.field(default_factory=dict)
    outcome: dict[int, tuple[float, float]] = dataclasses.field(default_factory=dict)


@dataclasses.dataclass(frozen=True, eq=False)
class DataSet:
    """One data set of a batch as the steps after the fits read it: its index ``b`` in ``fits``,
    the model, the candidates ``effects`` with their columns ``slices`` among the augmented
    unknowns (``nb`` base unknowns first), the level ``alpha``, whether the noise is ``known``,
    its training and held-out rows, and the stated σ of a recorded temperature (K)."""

    b: int
    fits: BatchFits
    model: AbstractDiscrepancyModel
    effects: tuple[Effect, ...]
    slices: list[np.ndarray]
    nb: int
    alpha: float
    known: bool
    train: Any = None
    test: Any = None
    temperature_std_k: float = 0.0


class _BaseTest(NamedTuple):
    """The base fit of one data set and its held-out test: the training χ² of the base and of
    each single-candidate fit (``chi2``, ``(K+1,)``), the Jacobians, the whitened and raw held-out
    residuals of every fit, the rank, basis and residual dof of the base columns, the noise
    variance ratio ``scale2``, the held-out statistic ``t0`` and its p-value."""

    chi2: np.ndarray
    jac_tr: np.ndarray
    jac_te: np.ndarray
    white_te: np.ndarray
    raw_te: np.ndarray
    rank_g: int
    q_g: np.ndarray
    dof0: int
    scale2: float
    t0: float
    p_detect: float


def _base_test(ds: DataSet) -> _BaseTest:
    """Detect: the base model's held-out χ² test on data set ``ds``."""
    b, fits, g_cols = ds.b, ds.fits, np.arange(ds.nb)
    chi2 = np.asarray(fits.chi2[b], dtype=float)
    jac_tr = np.asarray(fits.jac_tr[b])
    jac_te = np.asarray(fits.jac_te[b])
    rank_g = rank(jac_tr[:, g_cols])
    dof0 = jac_tr.shape[0] - rank_g
    raw_te = np.asarray(fits.raw_te[b])
    white_te = np.einsum("mij,qmj->qmi", np.asarray(fits.w_te[b]), raw_te).reshape(len(ds.effects) + 1, -1)
    scale2 = noise_scale2(chi2[0], dof0, ds.known)
    t0 = heldout_chi2(white_te[0], jac_tr[:, g_cols], jac_te[:, g_cols])
    p_detect = heldout_p(t0, jac_te.shape[0], dof0, scale2, ds.known)
    return _BaseTest(chi2, jac_tr, jac_te, white_te, raw_te, rank_g, basis(jac_tr[:, g_cols]), dof0, scale2,
                     t0, p_detect)


def _candidate_tests(ds: DataSet, base: _BaseTest, i: int, eiv: float = 0.0) -> dict[str, Any]:
    """Name: candidate ``i``'s nested test against the base, its BIC score, its held-out test and
    how much of its signature the base absorbs (the fields of :class:`Candidate` but the verdicts).
    ``eiv``: the held-out χ² the recorded temperature's noise accounts for (``_errors_in_variables.py``)."""
    e, known, g_cols = ds.effects[i], ds.known, np.arange(ds.nb)
    jac_tr, jac_te, chi2 = base.jac_tr, base.jac_te, base.chi2
    n_tr, n_te = jac_tr.shape[0], jac_te.shape[0]
    cols = np.concatenate([g_cols, ds.slices[i]])
    ab = absorption(jac_tr[:, g_cols], jac_tr[:, ds.slices[i]], base.q_g)
    df = ab.identifiable_rank
    dof_c = n_tr - base.rank_g - df
    p = nested_p(chi2[0], chi2[i + 1], df, dof_c, known)
    bic_c = bic(chi2[i + 1], base.rank_g + df, n_tr, known)
    t = heldout_chi2(base.white_te[i + 1], jac_tr[:, cols], jac_te[:, cols]) - eiv
    theta = np.asarray(ds.fits.z[ds.b, i + 1])[ds.slices[i]] * np.asarray(e.scale) * np.asarray(e.report_factor)
    return dict(
        effect=e.name,
        score=float(bic(chi2[0], base.rank_g, n_tr, known) - bic_c),
        bic=float(bic_c),
        delta_chi2=float(chi2[0] - chi2[i + 1]),
        dof=int(df),
        p_value=float(p),
        heldout_chi2=float(t),
        heldout_p=float(heldout_p(t, n_te, base.dof0, base.scale2, known)),
        heldout_rms=float(np.sqrt(np.mean(base.raw_te[i + 1] ** 2)) * ds.model.report_factor),
        absorbed_fraction=ab.absorbed_fraction,
        identifiable_rank=df,
        sines=ab.sines,
        converged=bool(ds.fits.ok[ds.b, i + 1]),
        params=theta.tolist(),
        unit=e.unit,
    )


def decide(ds: DataSet) -> Decision:
    """Detection and naming on one data set: the candidates significant at the Bonferroni level
    over the testable ones, those of them that pass the held-out test explain, and the best
    explaining one by BIC is named when a discrepancy is detected."""
    base = _base_test(ds)
    eiv = heldout_corrections(ds.model, ds.effects, np.asarray(ds.fits.z[ds.b]), np.asarray(ds.fits.w_te[ds.b]),
                              base.white_te, ds.test, ds.temperature_std_k, base.scale2)
    stats = [_candidate_tests(ds, base, i, eiv[i]) for i in range(len(ds.effects))]
    testable = [i for i, c in enumerate(stats) if c["identifiable_rank"] > 0]
    level = ds.alpha / max(len(testable), 1)
    significant = tuple(i for i in testable if stats[i]["p_value"] < level)
    cands = tuple(
        Candidate(significant=i in significant, explains=i in significant and c["heldout_p"] >= ds.alpha, **c)
        for i, c in enumerate(stats)
    )
    detected = bool(base.p_detect < ds.alpha)
    explaining = [i for i in significant if cands[i].explains]
    named = max(explaining, key=lambda i: cands[i].score) if (detected and explaining) else None
    return Decision(
        cands=cands,
        significant=significant,
        named_index=named,
        detected=detected,
        p_detect=base.p_detect,
        t0=base.t0,
        dof0=base.dof0,
        rank_g=base.rank_g,
        scale2=base.scale2,
        level=level,
        chi2=base.chi2,
        n_tr=base.jac_tr.shape[0],
        n_te=base.jac_te.shape[0],
    )


def pair_tests(
    dec: Decision, jac_tr: np.ndarray, slices: list[np.ndarray], nb: int, known: bool
) -> dict[int, tuple[float, float]]:
    """For the named candidate ``a`` and each other ``c`` fitted together with it: p-values of
    "c explains all that a ∪ c does" and "a explains all that a ∪ c does" (the degrees of
    freedom are the directions of the one not spanned by the base and the other)."""
    a, chi2, n_tr = dec.named_index, dec.chi2, dec.n_tr
    g = jac_tr[:, :nb]
    q_ga = basis(np.concatenate([g, jac_tr[:, slices[a]]], axis=1))
    out = {}
    for c, chi2_ac in dec.pairs.items():
        q_gc = basis(np.concatenate([g, jac_tr[:, slices[c]]], axis=1))
        df_c = n_identifiable(q_gc, jac_tr[:, slices[a]])
        df_a = n_identifiable(q_ga, jac_tr[:, slices[c]])
        dof_ac = n_tr - q_ga.shape[1] - df_a
        out[c] = (
            nested_p(chi2[c + 1], chi2_ac, df_c, dof_ac, known),
            nested_p(chi2[a + 1], chi2_ac, df_a, dof_ac, known),
        )
    return out
