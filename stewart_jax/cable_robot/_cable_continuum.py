"""The Craig–Bampton blocks of the lumped-mass cables and their extrapolation to continuous
cables (Richardson L. F., *The deferred approach to the limit*, Phil. Trans. R. Soc. A 226,
1927, 299–361).

A lumped-mass chain of N segments errs by ``O(1/N²)`` in every quantity the cabin's motion
sees: the fixed-interface frequencies ``Ω_k`` (a taut string's k-th by the factor
``sin(kπ/2N)/(kπ/2N)``), their coupling to the cabin ``b_k = Gᵀ M_n ψ_k``, the added mass
``M_a + Gᵀ M_n G`` and the static stiffness ``K_s``. With the same blocks at 2N and 4N,
Richardson's two steps remove the ``1/N²`` and ``1/N⁴`` terms (:data:`RICHARDSON`):
``ΔX = (64 X_4N − 20 X_2N − 44 X_N)/45`` carries the model at N to continuous cables, and
``X_N + γ ΔX`` is, to leading order, the model of cables with ``N' = N / √(1 − γ)`` segments
(γ = 0: N; γ = 3/4: 2N; γ = 1: continuous). With 4N beyond the segments' cap one step is taken
(``ΔX = 4/3 (X_2N − X_N)``).

NOTE (matching modes): ``Ω_k`` and ``b_k`` are extrapolated mode by mode, so the fixed-interface
modes are taken cable by cable (the cables are independent with the cabin held; six cables of a
symmetric pose have equal spectra, and a joint eigenbasis would mix them arbitrarily). Within a
cable, each mode at N is paired with the mode at 2N whose shape, sampled at the N chain's nodes
(the 2N chain's even nodes), is most nearly parallel, and that one likewise with a mode at 4N
(an assignment, not the sorted order: two families of string modes shift by different amounts
and may cross). A mode is extrapolated only where each pair is unambiguous (``|cos| ≥``
:data:`MATCH_COS`) and resolved (its ``Ω²`` moves by less than :data:`RESOLVED_CHANGE` between
N and 2N); the others, far above the cabin's modes, keep the N chain's values.
"""

from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp
import numpy as np
import scipy.optimize
from jaxtyping import Array, Float

from ._lumped import lumped_modes
from ._modes import cabin_mass_matrix

MATCH_COS = 0.9
"""Least |cosine| between a mode's shape at N and its partner's at 2N for the pair to be
extrapolated."""
RESOLVED_CHANGE = 0.1
"""Largest relative change of a mode's ``Ω²`` between N and 2N segments for it to be
extrapolated (beyond it the ``O(1/N²)`` term does not dominate the error)."""


class CraigBampton(NamedTuple):
    """The cables' blocks of the reduced model at one static pose, ``N − 1`` nodes per cable.

    - ``added_mass``: ``Float[Array, "6 6"]``, ``M_a + Gᵀ M_n G``, ``M_a`` the cables' end
      nodes riding on the cabin (kg, kg·m, kg·m²).
    - ``coupling``: ``Float[Array, "6 n"]``, ``Gᵀ M_n Ψ``; ``omega2``: ``Float[Array, "n"]``,
      ``Ω²`` (rad²/s²); ``n = 18 (N − 1)``, cable by cable, ascending within a cable.
    - ``stiffness``: ``Float[Array, "6 6"]``, ``K_s`` (N/m, N, N·m/rad).
    - ``shapes``: ``Float[Array, "6 3(N-1) 3(N-1)"]``, each cable's ``Ψ`` (m per unit p).
    """

    added_mass: Float[Array, "6 6"]
    coupling: Float[Array, "6 n"]
    omega2: Float[Array, " n"]
    stiffness: Float[Array, "6 6"]
    shapes: Float[Array, "6 k k"]


class ContinuumChange(NamedTuple):
    """The changes ``ΔX`` that carry the blocks at N to continuous cables
    (:func:`continuum_change`): ``added_mass`` (6 × 6), ``coupling`` (6 × n), ``omega2`` (n),
    ``stiffness`` (6 × 6, of ``K_s``), in the units of :class:`CraigBampton`.

    NOTE (the added mass): ``M_a + Gᵀ M_n G`` is extrapolated on its own, not as
    ``M_a + Σ_k b_k b_kᵀ`` from the extrapolated couplings: those carry the modes left at the
    N chain's values (above :data:`RESOLVED_CHANGE`) and a ``γ² Δb Δbᵀ`` of Richardson's order
    with a large constant (the first in-plane mode's coupling moves 2.7 % from N = 20 to 40). At
    N = 20 that put the swing modes 420–460 ppm above or below the continuous cables', where the
    added mass on its own puts them 22 ppm below. The price: the reduced mass matrix's Schur
    complement ``M + μ (A(γ) − c(γ) c(γ)ᵀ)`` is concave in γ and can lose positivity far from
    γ = 0 where N is small (N = 8: at γ = −1; N = 20: not in −1…1.25); such a γ is no model
    (:func:`~stewart_jax.discrepancy._cabin_starts.frequency_starts` skips it, a fit's step there
    is refused as non-finite)."""

    added_mass: Float[Array, "6 6"]
    coupling: Float[Array, "6 n"]
    omega2: Float[Array, " n"]
    stiffness: Float[Array, "6 6"]


def craig_bampton(params, position, R, static, n_segments: int) -> CraigBampton:
    """The :class:`CraigBampton` blocks of the lumped cables with ``n_segments`` segments about
    the lumped statics near ``static`` (numpy; the modes by :func:`~._lumped.lumped_modes`, whose
    errors it raises)."""
    lm = lumped_modes(params, position, n_segments, R, static)
    Kf, Mf = np.asarray(lm.stiffness), np.asarray(lm.mass)
    Kcn, Knn = Kf[:6, 6:], Kf[6:, 6:]
    G = -np.linalg.solve(Knn, Kcn.T)
    Ks = Kf[:6, :6] + Kcn @ G
    mn = np.diag(Mf)[6:]
    Ma = Mf[:6, :6] - np.asarray(cabin_mass_matrix(params, lm.statics.R))
    k = 3 * (n_segments - 1)
    omega2, shapes, coupling = [], [], []
    for i in range(6):
        sl = slice(i * k, (i + 1) * k)
        d = 1.0 / np.sqrt(mn[sl])
        w2, V = np.linalg.eigh(d[:, None] * Knn[sl, sl] * d[None, :])
        psi = d[:, None] * V
        omega2.append(w2)
        shapes.append(psi)
        coupling.append(G[sl].T @ (mn[sl, None] * psi))
    return CraigBampton(Ma + G.T @ (mn[:, None] * G), np.concatenate(coupling, axis=1),
                        np.concatenate(omega2), 0.5 * (Ks + Ks.T), np.stack(shapes))


def _pairs(coarse: np.ndarray, fine: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    # Partner at 2N of each mode at N (one cable) and the cosine of the pair's shapes, the fine
    # shapes sampled at the coarse chain's nodes (the fine chain's nodes 2, 4, …).
    nodes = coarse.shape[0] // 3
    sampled = fine.reshape(2 * nodes + 1, 3, -1)[1::2].reshape(3 * nodes, -1)
    a = coarse / np.linalg.norm(coarse, axis=0)
    b = sampled / np.maximum(np.linalg.norm(sampled, axis=0), 1e-300)
    cos = a.T @ b
    rows, cols = scipy.optimize.linear_sum_assignment(-np.abs(cos))
    partner = np.empty(coarse.shape[1], dtype=int)
    partner[rows] = cols
    return partner, cos[np.arange(coarse.shape[1]), partner]


RICHARDSON = {1: (0.0,), 2: (-4.0 / 3.0, 4.0 / 3.0), 3: (-44.0 / 45.0, -20.0 / 45.0, 64.0 / 45.0)}
"""Weights of the blocks at N, 2N (, 4N) in ``ΔX = X_∞ − X_N``: one step removes the ``1/N²``
term, two steps the ``1/N⁴`` term too (``X_∞ = (64 X_4N − 20 X_2N + X_N) / 45``); with the blocks
at N alone (2N beyond :data:`~._lumped.MAX_SEGMENTS`) there is no step and ``ΔX = 0``."""


def continuum_change(levels: tuple[CraigBampton, ...]) -> ContinuumChange:
    """``ΔX = X_∞ − X_N`` by Richardson's extrapolation (:data:`RICHARDSON`) from the blocks at
    N, 2N and optionally 4N segments (``levels``, coarsest first): the
    :class:`ContinuumChange` that carries the blocks at N to continuous cables (see the module's
    docstring)."""
    weights = RICHARDSON[len(levels)]
    coarse = levels[0]
    k = coarse.shapes.shape[1]
    d_omega2 = np.zeros_like(coarse.omega2)
    d_coupling = np.zeros_like(coarse.coupling)
    for i in range(6):
        index, sign, use = np.arange(k), np.ones(k), np.ones(k, dtype=bool)
        w = [coarse.omega2[i * k:(i + 1) * k]]
        b = [coarse.coupling[:, i * k:(i + 1) * k]]
        for prev, level in zip(levels[:-1], levels[1:], strict=True):
            kl = level.shapes.shape[1]
            partner, cos = _pairs(prev.shapes[i], level.shapes[i])
            use &= np.abs(cos[index]) >= MATCH_COS
            index, sign = partner[index], sign * np.sign(cos[index])
            w.append(level.omega2[i * kl:(i + 1) * kl][index])
            b.append(level.coupling[:, i * kl:(i + 1) * kl][:, index] * sign)
        use &= np.abs(w[1] / w[0] - 1.0) <= RESOLVED_CHANGE
        d_omega2[i * k:(i + 1) * k] = np.where(use, _combine(weights, w), 0.0)
        d_coupling[:, i * k:(i + 1) * k] = np.where(use[None, :], _combine(weights, b), 0.0)
    return ContinuumChange(_combine(weights, [x.added_mass for x in levels]), d_coupling, d_omega2,
                           _combine(weights, [x.stiffness for x in levels]))


def _combine(weights, xs):
    return sum(c * x for c, x in zip(weights, xs, strict=True))


def segments_of(continuum: Float[Array, ""], n_segments: int) -> float:
    """The segments per cable ``N / √(1 − γ)`` whose lumped cables the model at ``n_segments``
    with the continuum share γ stands for (``inf`` for γ ≥ 1: continuous cables)."""
    g = float(continuum)
    return float("inf") if g >= 1.0 else n_segments / float(np.sqrt(1.0 - g))


def as_arrays(change: ContinuumChange) -> ContinuumChange:
    """``change`` as jax arrays."""
    return ContinuumChange(*(jnp.asarray(x) for x in change))
