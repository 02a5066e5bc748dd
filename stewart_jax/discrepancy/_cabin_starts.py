"""The starting values of a cabin record's fits: the record's own modes (the multi-channel
matrix pencil of :mod:`stewart_jax.cable_robot._pencil`, on the record whitened by the tracker's
noise) and, per effect that changes frequencies, the few values at which the model's modes that
move the cabin match them best (see the NOTE on starting points of
:mod:`stewart_jax.discrepancy._cabin_record`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import jax
import jax.numpy as jnp
import numpy as np

from ..cable_robot._cabin_modal import (
    DAMPING_GROUPS,
    CabinModalModel,
    CabinVariation,
    cabin_matrices,
    cabin_modal_modes,
)
from ..cable_robot._pencil import record_modes

if TYPE_CHECKING:
    from ._cabin_record import CabinRecordData

MASS_SHARE_RANGE = (0.0, 1.5)
"""Range of the ``cable_inertia`` starting values (the share of the cables' mass that moves)."""
MAX_STARTS = 4
"""Most starting values per effect (:func:`frequency_starts`), whatever the record's length."""
SECOND_STARTS = {"cable_inertia": (0.0, 1.0)}
"""Starting values of an effect's second parameter, each paired with every start of its first:
the cables' node lag of a release with the cables in equilibrium (0) and at rest (1). The record's
modes set the share μ, not the lag; from a lag of 0 alone, two 20 s records of cables released at
rest fitted another minimum (μ 0.16 and 0.0) and were not named."""
GRID_PARAMS = {"cable_inertia": (0, 2)}
"""The parameters a start of :attr:`CabinRecordModel.grids` sets, by index (default: the first):
``cable_inertia``'s starts are pairs of the mass share μ and the continuum share γ."""
CONTINUUM_RANGE = (-1.0, 1.25)
"""Range of the continuum share γ the ``cable_inertia`` starts are searched in: cables of
``N/√2`` segments (γ = −1) to continuous cables (γ = 1) and a little beyond, where the model at
N stands for its own cables at γ = 0 (:mod:`~stewart_jax.cable_robot._cable_continuum`)."""
CONTINUUM_SCAN_POINTS = 10
"""Values of γ at which the reduced model's frequencies are compared with the record's, at each
of the :data:`INERTIA_SCAN_POINTS` mass shares (steps of 0.25: about 0.5 % at 1 Hz for N = 20)."""
SCAN_POINTS = 301
"""Values of ``cable_stiffness`` and ``cabin_mass`` at which the model's six frequencies are
compared with the record's."""
INERTIA_SCAN_POINTS = 61
"""Values of ``cable_inertia`` at which the full reduced model's frequencies are compared with the
record's (steps of 0.025 in μ: ~1 % in the swing frequency, a fifth of :data:`MATCH_CAP`)."""
PENCIL_ORDER = 24
"""Poles the matrix pencil fits to a record (12 modes: the cabin's six and string modes)."""
MATCH_CAP = 0.05
"""Largest relative frequency mismatch a record's mode adds to the matching cost (a mode the
model has no counterpart for costs no more than this)."""

def _six_frequencies(modal: CabinModalModel, which: str, x: float) -> np.ndarray:
    # The cabin's six modes on quasi-static cables (cable_stiffness, cabin_mass), numpy.
    K, M = np.asarray(modal.stiffness), np.asarray(modal.mass)
    if which == "cable_stiffness":
        lo, hi = modal.ea_range
        K = K + np.polynomial.chebyshev.chebval((2 * x - lo - hi) / (hi - lo), np.asarray(modal.ea_coef))
    else:
        lo, hi = modal.mass_range
        K = K + np.polynomial.chebyshev.chebval((2 * x - lo - hi) / (hi - lo), np.asarray(modal.mass_coef))
        M = M * (1.0 + x)
    lam = np.linalg.eigvals(np.linalg.solve(M, K)).real
    return np.sqrt(np.sort(np.abs(lam))) / (2.0 * np.pi)


_cabin_matrices_jit = jax.jit(cabin_matrices)


def _full_frequencies(modal: CabinModalModel, mass_share: float, continuum: float, cutoff_hz: float) -> np.ndarray:
    # The reduced model with its string modes at (μ, γ): the modes below the cutoff that move the cabin.
    import scipy.linalg

    var = CabinVariation(cable_mass_share=jnp.asarray(float(mass_share)), damping_change=jnp.zeros(len(DAMPING_GROUPS)),
                         continuum=jnp.asarray(float(continuum)))
    K, M = (np.asarray(a) for a in _cabin_matrices_jit(modal, var))
    try:
        lam, phi = scipy.linalg.eigh(K, M)
    except np.linalg.LinAlgError:  # a continuum share γ where the mass matrix is not positive: no model
        return np.zeros(0)
    share = np.einsum("km,kl,lm->m", phi[:6], M[:6, :6], phi[:6])
    f = np.sqrt(np.abs(lam)) / (2.0 * np.pi)
    return f[(share >= 0.01) & (f < cutoff_hz)]


def _mismatch(f_record: np.ndarray, weight: np.ndarray, f_model: np.ndarray) -> float:
    if f_model.size == 0:
        return MATCH_CAP**2
    d = np.min(np.abs(np.log(f_record[:, None]) - np.log(f_model[None, :])), axis=1)
    return float(np.sum(weight * np.minimum(d, MATCH_CAP) ** 2))


def frequency_starts(modal: CabinModalModel, which: str, lo: float, hi: float, f_record: np.ndarray,
                     weight: np.ndarray, cutoff_hz: float) -> tuple:
    """The values of effect ``which`` in ``[lo, hi]`` at which the model's modes best match the
    record's (``f_record``, Hz, with ``weight``s summing to 1): the local minima of the matching
    cost (Σ weight · min(|ln f − ln f_model|, :data:`MATCH_CAP`)², each record mode against the
    nearest model mode that moves the cabin) on a scan of the range, each refined by a bounded
    search between its neighbours; at most :data:`MAX_STARTS`, best first; 0 left out (the
    row of zeros is always a start).

    ``cable_stiffness`` and ``cabin_mass`` are scanned on the cabin's six modes
    (:data:`SCAN_POINTS` values; exact for them: the string modes' share vanishes at μ = 0).
    ``cable_inertia`` is scanned on the full reduced model with its string modes, over the mass
    share μ (:data:`INERTIA_SCAN_POINTS`) and the continuum share γ (:data:`CONTINUUM_RANGE`,
    :data:`CONTINUUM_SCAN_POINTS`), and its starts are ``(μ, γ)`` pairs: the six-mode screen's
    Rayleigh added mass ignores the coupling to the string modes and puts the lumped model's
    swing at μ ≈ 1.3, not 1, and the string modes of cables finer than the model's sit up to a few
    per cent above its own at γ = 0."""
    from scipy.optimize import minimize_scalar

    if which == "cable_inertia":
        return _inertia_starts(modal, lo, hi, f_record, weight, cutoff_hz)

    def cost(x):
        return _mismatch(f_record, weight, _six_frequencies(modal, which, x))
    xs = np.linspace(lo, hi, SCAN_POINTS)
    c = np.array([cost(x) for x in xs])
    interior = np.r_[True, c[1:] <= c[:-1]] & np.r_[c[:-1] <= c[1:], True]
    order = [int(i) for i in np.argsort(c) if interior[i]][:MAX_STARTS]
    starts = []
    for i in order:
        a, b = xs[max(i - 1, 0)], xs[min(i + 1, len(xs) - 1)]
        x = float(minimize_scalar(cost, bounds=(a, b), method="bounded", options={"xatol": 1e-4 * (hi - lo)}).x)
        if abs(x) > 1e-6 and all(abs(x - y) > 1e-3 * (hi - lo) for y in starts):
            starts.append(x)
    return tuple(starts)


def _inertia_starts(modal: CabinModalModel, lo: float, hi: float, f_record: np.ndarray, weight: np.ndarray,
                    cutoff_hz: float) -> tuple[tuple[float, float], ...]:
    # frequency_starts of cable_inertia: local minima of the cost on the (μ, γ) grid (each at most
    # its eight neighbours), refined by Nelder–Mead inside the cell around it.
    from scipy.optimize import minimize

    def cost(x):
        return _mismatch(f_record, weight, _full_frequencies(modal, x[0], x[1], cutoff_hz))
    mus = np.linspace(lo, hi, INERTIA_SCAN_POINTS)
    gammas = np.linspace(*CONTINUUM_RANGE, CONTINUUM_SCAN_POINTS)
    c = np.array([[cost((mu, g)) for g in gammas] for mu in mus])
    padded = np.pad(c, 1, constant_values=np.inf)
    shifted = [padded[1 + i:1 + i + c.shape[0], 1 + j:1 + j + c.shape[1]]
               for i in (-1, 0, 1) for j in (-1, 0, 1) if (i, j) != (0, 0)]
    interior = np.all([c <= x for x in shifted], axis=0)
    starts: list[tuple[float, float]] = []
    dm, dg = mus[1] - mus[0], gammas[1] - gammas[0]
    for flat in np.argsort(c, axis=None):
        if len(starts) == MAX_STARTS:
            break
        i, j = np.unravel_index(flat, c.shape)
        if not interior[i, j] or abs(mus[i]) < 1e-6:
            continue
        box = [(mus[i] - dm, mus[i] + dm), (gammas[j] - dg, gammas[j] + dg)]
        res = minimize(cost, np.array([mus[i], gammas[j]]), method="Nelder-Mead", bounds=box,
                       options={"xatol": 1e-4, "fatol": 1e-12, "initial_simplex": [
                           (mus[i], gammas[j]), (mus[i] + dm / 2, gammas[j]), (mus[i], gammas[j] + dg / 2)]})
        mu, g = float(res.x[0]), float(res.x[1])
        if abs(mu) > 1e-6 and all(abs(mu - a) > 1e-3 * (hi - lo) or abs(g - b) > dg for a, b in starts):
            starts.append((mu, g))
    if starts and abs(starts[0][1]) > 1e-3:
        # NOTE: the cabin's modes, which carry most of a record's weight, move by tens of ppm per
        # step of γ, below what the pencil resolves; the string modes decide γ only where the
        # release rings them. The best share is therefore also started at the model's own
        # discretisation: from γ = −0.12 of the scan, a 200 s record of the model's own cables
        # released from equilibrium fitted another minimum (μ = 1.42) and was not named.
        starts.insert(1, (starts[0][0], 0.0))
    return tuple(starts[:MAX_STARTS])


def record_frequencies(data: CabinRecordData, modal: CabinModalModel, sigma_mm: float,
                       sigma_mrad: float) -> tuple[np.ndarray, np.ndarray, float]:
    """The record's modes (matrix pencil on the pose whitened by the noise σ): frequencies (Hz),
    their weights (squared amplitudes, summing to 1) and the cutoff (1.5 × the quasi-static
    model's highest mode, the most any effect's range raises it)."""
    f_qs = np.asarray(cabin_modal_modes(modal, CabinVariation()).frequencies_hz)[:6]
    cutoff = 1.5 * float(f_qs[-1])
    t = np.asarray(data.time)
    y = np.asarray(data.pose) / np.array([sigma_mm] * 3 + [sigma_mrad] * 3)
    y = y - y.mean(axis=0)
    pm = record_modes(y, float(np.median(np.diff(t))), cutoff, PENCIL_ORDER)
    if pm.frequency_hz.size == 0:
        return np.asarray([float(f_qs[0])]), np.ones(1), cutoff
    w = pm.amplitude**2
    return pm.frequency_hz, w / np.sum(w), cutoff
