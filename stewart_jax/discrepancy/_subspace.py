"""Subspace algebra of the discrepancy workflow: numerical rank, orthonormal bases, principal
angles between an effect's and the base parameters' Jacobian columns (how much of an effect
the base parameters absorb), and the held-out prediction factor of a linearised fit.

References: principal angles by the SVD of ``Q_Eᵀ(I − P_G)`` (Björck and Golub 1973,
"Numerical methods for computing angles between linear subspaces", Math. Comp. 27); the
prediction covariance ``A_te (A_trᵀ A_tr)⁺ A_teᵀ`` of linear least squares (e.g. Seber and Lee
2003, "Linear Regression Analysis", §5.1).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from jaxtyping import Float

RANK_RTOL = 1e-9
"""Relative singular-value threshold for the numerical rank of whitened, column-normalised
Jacobians (float64 rounding of these is ~1e-13)."""
SINE_TOL = 1e-7
"""An effect direction whose principal-angle sine to the base span is below this counts as
absorbed (not identifiable): the rounding of the projection is ~cond(G)·1e-16 ≲ 1e-9 here."""


def normalised(a: Float[np.ndarray, "n p"]) -> Float[np.ndarray, "n p"]:
    """Columns scaled to unit norm (zero columns left as they are)."""
    n = np.linalg.norm(a, axis=0)
    return a / np.where(n > 0, n, 1.0)


def rank(a: Float[np.ndarray, "n p"]) -> int:
    """Numerical rank of the column-normalised ``a`` at :data:`RANK_RTOL`."""
    if a.shape[1] == 0:
        return 0
    s = np.linalg.svd(normalised(a), compute_uv=False)
    return int(np.sum(s > RANK_RTOL * s[0])) if s[0] > 0 else 0


def basis(a: Float[np.ndarray, "n p"]) -> Float[np.ndarray, "n r"]:
    """Orthonormal basis of the span of ``a``'s columns (rank cut at :data:`RANK_RTOL`)."""
    u, s, _ = np.linalg.svd(normalised(a), full_matrices=False)
    return u[:, s > RANK_RTOL * s[0]] if s.size and s[0] > 0 else u[:, :0]


def sines(q: Float[np.ndarray, "n r"], columns: Float[np.ndarray, "n k"]) -> Float[np.ndarray, " s"]:
    """Sines of the principal angles between span(columns) and span(q) (q orthonormal),
    largest first."""
    ue = basis(columns)
    if not ue.shape[1]:
        return np.zeros(0)
    return np.clip(np.linalg.svd(ue - q @ (q.T @ ue), compute_uv=False), 0.0, 1.0)


def n_identifiable(q: Float[np.ndarray, "n r"], columns: Float[np.ndarray, "n k"]) -> int:
    """Directions of ``columns`` outside span(q): principal-angle sines above :data:`SINE_TOL`."""
    return int(np.sum(sines(q, columns) > SINE_TOL))


@dataclasses.dataclass(frozen=True)
class Absorption:
    """How much of an effect's signature the base parameters can absorb (whitened training
    Jacobian at the base fit).

    - ``absorbed_fraction``: ``1 − ‖(I − P_G) J_e‖²_F / ‖J_e‖²_F`` with ``J_e`` in the fit's
      scaled units (dimensionless, in [0, 1]): the expected share of the signature of an effect
      with random (isotropic) parameters that a refit of the base parameters removes.
    - ``sines``: sines of the principal angles between the effect's and the base columns'
      spans, largest first (1: orthogonal, 0: inside the base span).
    - ``identifiable_rank``: ``rank([G, E]) − rank(G)``, the effect directions the data can see.
    """

    absorbed_fraction: float
    sines: tuple[float, ...]
    identifiable_rank: int

    @property
    def completely_absorbed(self) -> bool:
        return self.identifiable_rank == 0


def absorption(
    base_columns: Float[np.ndarray, "n p"],
    effect_columns: Float[np.ndarray, "n k"],
    base_basis: Float[np.ndarray, "n r"] | None = None,
) -> Absorption:
    """:class:`Absorption` of ``effect_columns`` by ``base_columns``; ``base_basis``, an
    orthonormal basis of the base columns' span, may be passed to save work."""
    q = basis(base_columns) if base_basis is None else base_basis
    perp = effect_columns - q @ (q.T @ effect_columns)
    total = float(np.sum(effect_columns**2))
    frac = 1.0 - float(np.sum(perp**2)) / total if total > 0 else 1.0
    s = sines(q, effect_columns)
    r = int(np.sum(s > SINE_TOL))
    return Absorption(float(np.clip(frac, 0.0, 1.0)), tuple(float(x) for x in s), r)


def prediction_factor(a_tr: Float[np.ndarray, "n p"], a_te: Float[np.ndarray, "t p"]) -> Float[np.ndarray, "t r"]:
    """``U = A_te V S⁻¹`` from the SVD ``A_tr = W S Vᵀ`` (columns normalised first so that the
    rank cut is scale-free): ``U Uᵀ = A_te (A_trᵀ A_tr)⁺ A_teᵀ``, the covariance of the held-out
    prediction error of a linear(ised) least-squares fit, in whitened units."""
    n = np.linalg.norm(a_tr, axis=0)
    keep = n > 0
    _, sv, vt = np.linalg.svd(a_tr[:, keep] / n[keep], full_matrices=False)
    ok = sv > RANK_RTOL * sv[0]
    return (a_te[:, keep] / n[keep]) @ (vt[ok].T / sv[ok])


ABSORB_SHARE = 0.1
"""A base parameter is listed as absorbing an effect when its part of the least-squares
reproduction of the effect's columns is at least this share of the largest part."""


def base_param_names(model) -> tuple[str, ...]:
    """Labels of a discrepancy model's base parameters: its mechanism's ``param_names`` when
    they match, ``A1x … B6z`` for the 36 joint centres of the 6-PSS, ``u1 …`` otherwise."""
    nb = int(model.base_initial.shape[0])
    names = tuple(model.base_names)
    if len(names) == nb:
        return names
    if nb == 36:
        return tuple(f"{s}{i}{a}" for s in "AB" for i in range(1, 7) for a in "xyz")
    return tuple(f"u{i}" for i in range(1, nb + 1))


def absorbing_params(
    base_columns: Float[np.ndarray, "n p"], effect_columns: Float[np.ndarray, "n k"], names: tuple[str, ...]
) -> list[str]:
    """The base parameters whose change reproduces an (absorbed) effect's columns: the
    minimum-norm least-squares ``G β = E``; parameter ``j`` counts by ``‖G_j‖·‖β_j‖`` (its
    share of the reproduction, scale-free), listed largest first down to :data:`ABSORB_SHARE`
    of the largest."""
    n = np.linalg.norm(base_columns, axis=0)
    beta = np.linalg.lstsq(normalised(base_columns), effect_columns, rcond=RANK_RTOL)[0]
    part = np.linalg.norm(beta, axis=1) * (n > 0)
    if not np.any(part > 0):
        return []
    order = np.argsort(-part)
    return [names[j] for j in order if part[j] >= ABSORB_SHARE * part[order[0]]]
