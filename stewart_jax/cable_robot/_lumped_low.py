"""The low modes of the lumped-mass cables (:mod:`._lumped`) without the dense eigenproblem:
shift-invert inverse iteration on the banded stiffness and a Rayleigh–Ritz step, checked and,
where a check fails, replaced by the dense route; and the modal summary of either kind of modes.
The model, its statics and its modal bookkeeping are those of :mod:`._lumped`."""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import scipy.linalg
import scipy.sparse
import scipy.sparse.csgraph
from jaxtyping import Array, ArrayLike, Bool, Float

from . import _lumped_blocks as _blocks
from ._lumped import (
    CABIN_COORDINATES,
    LumpedModes,
    LumpedStatics,
    _blocks_at,
    _continuous_statics,
    _mass_matrix,
    _raise_if_failed,
    _statics,
    check_segments,
    lumped_modes,
)
from ._statics import StaticSolution
from ._system import FastParams


class LumpedLowModes(NamedTuple):
    """The vibration modes of the cabin and its lumped-mass cables below a cut-off
    (:func:`lumped_low_modes`), ``k`` of them, ascending; the same quantities as
    :class:`LumpedModes` for those modes.

    - ``frequencies_hz``: ``Float[Array, "k"]`` (negative for an unstable direction).
    - ``shapes``: ``Float[Array, "n k"]``, M-orthonormal columns, rows as :class:`LumpedModes`.
    - ``cabin_energy_share``: ``Float[Array, "k"]``; ``compliance_share``: ``Float[Array, "k 6"]``.
    - ``compliance``: ``Float[Array, "6"]``, ``(K⁻¹)_kk`` by a direct solve (m/N, rad/(N·m)).
    - ``compliance_resolved``: ``Float[Array, "6"]``, the share of each coordinate's static
      compliance in the modes below the cut-off (the rest lies above it).
    - ``cutoff_hz``: the cut-off; ``statics``: :class:`LumpedStatics`.
    - ``residual``: ``Float[Array, ""]``, the largest ``‖K φ − ω² M φ‖_{M⁻¹} / ω²`` (the relative
      error bound of the eigenvalues); ``stable``, ``ok``: ``Bool[Array, ""]``.
    - ``method``: ``"banded"`` (the sparse route) or ``"dense"`` (its fallback).
    """

    frequencies_hz: Float[Array, " k"]
    shapes: Float[Array, "n k"]
    cabin_energy_share: Float[Array, " k"]
    compliance_share: Float[Array, "k 6"]
    compliance: Float[Array, "6"]
    compliance_resolved: Float[Array, "6"]
    cutoff_hz: float
    statics: LumpedStatics
    residual: Float[Array, ""]
    stable: Bool[Array, ""]
    ok: Bool[Array, ""]
    method: str


class _LowPrep(NamedTuple):
    statics: LumpedStatics
    blocks: _blocks.ArrowBlocks
    mass_cc: Float[Array, "6 6"]
    node_mass: Float[Array, "6"]
    band: Float[Array, "24 n"]
    compliance: Float[Array, "6"]


def _low_prepare(params, position, R, static, n_segments):
    st, y = _statics(params, position, R, static, n_segments, 100, 1e-10)
    K = _blocks_at(params, position, R, st.s0, y, n_segments)
    M = _mass_matrix(params, st, n_segments)
    mass_cc, node_mass = M[:6, :6], params.cable.rho * st.s0 / n_segments
    band, _ = _blocks.band_standard_form(K, mass_cc, node_mass)
    compliance = jnp.diag(jnp.linalg.inv(_blocks.factor(K).schur))
    return _LowPrep(st, K, mass_cc, node_mass, band, compliance)


_low_prepare_jit = jax.jit(_low_prepare, static_argnames=("n_segments",))


_CHUNK = 32
"""Shifts per call of the jitted inverse iteration (one compilation per ``N``)."""


def _inverse_iteration(prep: _LowPrep, lam, tau, chunk, label):
    # NOTE: inverse iteration, two steps from random starts, a chunk of eigenvalues at once
    # (vmap over the shifts), each with the chain-by-chain solve of K − σM (one step of
    # iterative refinement on the last, the chain elimination being unpivoted). σ = λ − tau
    # with tau = 1e-12 ‖A‖ (λ is known to ε‖A‖ ≈ 2e-16 ‖A‖): no pivot is exactly singular, and
    # a mode a gap g away is damped by tau/g per step. The vectors of a cluster of close or
    # repeated eigenvalues (`label`; e.g. the string modes of equal cables at the centre) would
    # all turn towards the same eigenvector: after each step they are M-orthonormalised
    # against each other (Gram–Schmidt, as LAPACK's dstein does), so that together
    # they span the cluster; the Rayleigh–Ritz step (:func:`_rayleigh_ritz`) separates them.
    # Returns V, M V and K V (n × chunk).
    K, Mcc, mn = prep.blocks, prep.mass_cc, prep.node_mass
    nn = K.diag.shape[1]
    n = 6 + 18 * nn
    width = lam.shape[0]

    def mass(v):
        return jnp.concatenate([Mcc @ v[:6], (mn[:, None, None] * v[6:].reshape(6, nn, 3)).reshape(-1)])

    def kmul(M, v):
        c, x = _blocks.matvec(M, v[:6], v[6:].reshape(6, nn, 3))
        return jnp.concatenate([c, x.reshape(-1)])

    shifted = jax.vmap(lambda sg: _blocks.shifted(K, sg, Mcc, mn))(lam - tau)
    factors = jax.vmap(_blocks.factor)(shifted)

    def solve(f, r):
        c, x = _blocks.solve(f, r[:6], r[6:].reshape(6, nn, 3))
        return jnp.concatenate([c, x.reshape(-1)])

    same = label[:, None] == label[None, :]
    # rank of each vector inside its cluster (clusters are runs of equal labels)
    rank = jnp.sum(same & (jnp.arange(width)[None, :] < jnp.arange(width)[:, None]), axis=1)

    def orthonormalise(X):
        # Gram–Schmidt in the M inner product inside each cluster, all clusters at once: the
        # vectors of rank r are orthogonalised (twice, for rounding) against the lower ranks
        # of their cluster, then normalised. No LAPACK call: a small dense factorisation
        # through a multithreaded BLAS costs 5× more than all this on a loaded machine.
        def step(r, X):
            row = rank == r
            lower = same & (rank[None, :] < r) & row[:, None]
            for _ in range(2):
                coef = (X @ jax.vmap(mass)(X).T) * lower
                X = X - coef @ X
            norm = jnp.sqrt(jnp.einsum("ij,ij->i", X, jax.vmap(mass)(X)))
            return jnp.where(row[:, None], X / norm[:, None], X)
        return jax.lax.fori_loop(0, jnp.max(rank) + 1, step, X)

    X = jax.random.normal(jax.random.fold_in(jax.random.PRNGKey(0), chunk), (width, n))
    R = jax.vmap(mass)(X)
    X = orthonormalise(jax.vmap(solve)(factors, R))
    R = jax.vmap(mass)(X)
    X = jax.vmap(solve)(factors, R)
    for _ in range(2):   # iterative refinement
        X = X + jax.vmap(solve)(factors, R - jax.vmap(kmul)(shifted, X))
    X = orthonormalise(X)
    return X.T, jax.vmap(mass)(X).T, jax.vmap(lambda v: kmul(K, v))(X).T


_inverse_iteration_jit = jax.jit(_inverse_iteration)


def _rayleigh_ritz(V, MV, KV, mass_cc, node_mass, tau, coupling=1e-10, window=16):
    # K and M projected on span(V) (numpy, any number of vectors: no compilation per size);
    # returns the Ritz values, M-orthonormal Ritz vectors (largest component positive) and
    # their residuals ‖K φ − θ M φ‖_{M⁻¹} / |θ|, a bound on each eigenvalue's relative error.
    # NOTE: converged inverse-iteration vectors of distinct eigenvalues are M-orthogonal to
    # rounding, so the projected pencil is diagonal but for groups of close modes (coupling
    # above `coupling` in the normalised K or M between modes at most `window` apart in the
    # ascending order: the repeated string modes of equal cables, or modes 1e-5 apart; 2–12
    # of them): each group is solved on its own, the rest are Rayleigh quotients. Only
    # elementwise products and few×few solves: no k×k LAPACK call (with a multithreaded BLAS
    # on a loaded machine one costs 100× its single-thread time). The residuals are the check.
    d = np.sqrt(np.einsum("ij,ij->j", V, MV))
    V, MV, KV = V / d, MV / d, KV / d
    m = V.shape[1]
    g_diag = np.ones(m)
    k_diag = np.einsum("ij,ij->j", V, KV)
    kd = np.sqrt(np.abs(k_diag))
    rows, cols = [], []
    for o in range(1, min(window, m - 1) + 1):
        g = np.einsum("ij,ij->j", V[:, :-o], MV[:, o:])
        kk = np.einsum("ij,ij->j", V[:, :-o], KV[:, o:])
        hit = np.flatnonzero((np.abs(g) > coupling) | (np.abs(kk) > coupling * kd[:-o] * kd[o:]))
        rows.append(hit)
        cols.append(hit + o)
    rows, cols = np.concatenate(rows), np.concatenate(cols)
    graph = scipy.sparse.coo_matrix((np.ones(rows.size), (rows, cols)), shape=(m, m))
    _, label = scipy.sparse.csgraph.connected_components(graph, directed=False)
    theta = k_diag / g_diag
    shapes, kphi, mphi = V.copy(), KV.copy(), MV.copy()
    for c in np.flatnonzero(np.bincount(label) > 1):
        idx = np.flatnonzero(label == c)
        Vc, Mc, Kc = V[:, idx], MV[:, idx], KV[:, idx]
        Gc, Krc = Vc.T @ Mc, Vc.T @ Kc
        w, Y = scipy.linalg.eigh(0.5 * (Krc + Krc.T), 0.5 * (Gc + Gc.T))
        theta[idx], shapes[:, idx], kphi[:, idx], mphi[:, idx] = w, Vc @ Y, Kc @ Y, Mc @ Y
    order = np.argsort(theta, kind="stable")
    theta, shapes, kphi, mphi = theta[order], shapes[:, order], kphi[:, order], mphi[:, order]
    r = kphi - theta * mphi
    nn = (V.shape[0] - 6) // 18
    minv_r = np.concatenate([np.linalg.solve(mass_cc, r[:6]), r[6:] / np.repeat(node_mass, 3 * nn)[:, None]])
    res = np.sqrt(np.abs(np.sum(r * minv_r, axis=0))) / np.maximum(np.abs(theta), tau)
    sign = np.sign(shapes[np.argmax(np.abs(shapes), axis=0), np.arange(m)])
    return theta, shapes * np.where(sign == 0, 1.0, sign), res


def _undetermined(share, resolved):
    # a coordinate whose best share below the cut-off does not exceed what lies above it
    return np.max(share, axis=0) <= 1.0 - resolved


def lumped_low_modes(
    params: FastParams,
    position: Float[ArrayLike, "3"],
    n_segments: int,
    cutoff_hz: float = 1.5,
    R: Float[ArrayLike, "3 3"] | None = None,
    static: StaticSolution | None = None,
    *,
    resolve_dominant: bool = True,
) -> LumpedLowModes:
    """The vibration modes below ``cutoff_hz`` of the cabin on ``N = n_segments`` lumped-mass
    segments per cable, about the lumped statics at ``position`` (m), with the shares of
    :func:`lumped_modes` — the same numbers to rounding, for the modes below the cut-off, in
    ``O(N)`` memory and far less time.

    How (see :mod:`._lumped_blocks`): the statics' Newton steps and the Hessian use its
    block structure (a star of six block-tridiagonal chains); the eigenvalues come from the
    banded symmetric eigen-solver (LAPACK through :func:`scipy.linalg.eigvals_banded`, on the
    host: not traceable) on ``L⁻¹ K L⁻ᵀ`` ordered by level (half-bandwidth 14); the shapes of
    the modes below the cut-off (and a few above, as a guard) from inverse iteration with the
    chain solve (jitted, 32 shifts per call) and a Rayleigh–Ritz step. Every mode's residual
    is checked: a vector above 1e-9 is recomputed with its shift moved by 1e-6 λ; where one is
    still not at rounding level (``residual > 1e-6``) the dense route (:func:`lumped_modes`) is
    used instead and ``method`` says so. The compliances are a
    direct solve, so ``compliance_resolved`` tells how much of each lies below the cut-off.

    With ``resolve_dominant`` (the default), where a cabin coordinate's dominant mode could lie
    above ``cutoff_hz`` (its largest share below does not exceed the share above, e.g. a yaw
    mode just above 1.5 Hz), the cut-off is raised by steps of 25 % until none can, so that
    :func:`modal_summary` names every coordinate's dominant mode as from all modes; the
    returned ``cutoff_hz`` is the one reached.

    Raises what :func:`lumped_statics` raises, and ``ValueError`` for a cut-off that is not a
    positive frequency or below the lowest mode.
    """
    n = check_segments(n_segments)
    if not (isinstance(cutoff_hz, int | float | np.floating) and np.isfinite(cutoff_hz) and cutoff_hz > 0):
        raise ValueError(f"cutoff_hz must be a positive frequency in Hz, got {cutoff_hz!r}")
    pos, R, st = _continuous_statics(params, position, R, static)
    prep = _low_prepare_jit(params, pos, R, st, n)
    _raise_if_failed(prep.statics, position, st)
    spec = _banded_spectrum(prep)
    lam_all, tau = spec.lam, spec.tau
    n_dof = lam_all.shape[0]
    compliance = np.asarray(prep.compliance)
    cut = float(cutoff_hz)
    chunks, done = [], 0
    while True:
        k = int(np.searchsorted(lam_all, (2.0 * np.pi * cut) ** 2, side="right"))
        if k == 0:
            raise ValueError(f"no mode below cutoff_hz = {cutoff_hz} Hz (the lowest is at "
                             f"{np.sign(lam_all[0]) * np.sqrt(abs(lam_all[0])) / (2 * np.pi):.4g} Hz)")
        # NOTE: the shapes of at least 4 modes above the cut-off are computed too (the guard: a
        # mode just above, which inverse iteration cannot damp from its neighbour below, is
        # then inside the Rayleigh–Ritz space instead of polluting it)
        done = _more_vectors(prep, spec, chunks, done, min(n_dof, k + 4))
        ritz = None if done is None else _checked_ritz(prep, spec, chunks, k)
        if ritz is None:
            return _low_from_dense(lumped_modes(params, pos, n, R, st), cut)
        theta, shapes, res = ritz
        theta, shapes, res = theta[:k], shapes[:, :k], res[:k]
        share = (shapes[:6] ** 2 / theta[None, :]).T / compliance
        resolved = np.sum(share, axis=0)
        if not (resolve_dominant and np.any(_undetermined(share, resolved)) and k < n_dof):
            break
        cut *= 1.25
    residual = float(np.max(res))
    lam_ok = np.max(np.abs(theta - lam_all[:k]) / np.maximum(np.abs(lam_all[:k]), tau)) < 1e-6
    if not (np.isfinite(residual) and residual <= 1e-6 and lam_ok):
        return _low_from_dense(lumped_modes(params, pos, n, R, st), cut)
    return _banded_modes(prep, spec, theta, shapes, share, resolved, cut, residual)


class _Spectrum(NamedTuple):
    """The eigenvalues of the banded standard form (:func:`_banded_spectrum`).

    - ``lam``: ``(n_dof,)``, ascending (rad²/s²); ``tau``: the shifts' offset, 1e-12 ``‖A‖``.
    - ``cluster``: ``(n_dof,)``, each eigenvalue's cluster, numbered in order; ``sizes``: the
      eigenvalues of each cluster.
    """

    lam: np.ndarray
    tau: float
    cluster: np.ndarray
    sizes: np.ndarray


def _banded_spectrum(prep: _LowPrep) -> _Spectrum:
    """Every eigenvalue of the banded standard form (band reduction and QR: faster than
    bisection for the ~100 wanted), grouped into clusters of consecutive eigenvalues closer
    than 1e-6 relative or 1e3 ``tau``."""
    lam_all = scipy.linalg.eigvals_banded(np.asarray(prep.band), lower=False)
    tau = 1e-12 * float(np.max(np.abs(lam_all)))
    close = np.diff(lam_all) < 1e-6 * np.abs(lam_all[1:]) + 1e3 * tau
    cluster = np.concatenate([[0], np.cumsum(~close)])
    return _Spectrum(lam_all, tau, cluster, np.bincount(cluster))


def _more_vectors(prep: _LowPrep, spec: _Spectrum, chunks: list, done: int, need: int) -> int | None:
    """Inverse-iteration vectors of eigenvalues ``done … need − 1`` and on to the end of the last
    one's cluster, appended to ``chunks`` (per call of the jitted iteration ``[V, M V, K V]``,
    each ``(n, width)``), a chunk of whole clusters at a time (padded with repeats of its last
    shift, dropped after). Returns the eigenvalues now covered, or ``None`` for a cluster wider
    than a chunk (the dense route)."""
    lam_all, cluster, sizes = spec.lam, spec.cluster, spec.sizes
    n_dof = lam_all.shape[0]
    while done < need:
        end = done
        while end < n_dof and end - done + sizes[cluster[end]] <= _CHUNK:
            end += sizes[cluster[end]]
        if end == done:
            return None
        lam = np.concatenate([lam_all[done:end], np.full(_CHUNK - (end - done), lam_all[end - 1])])
        label = np.concatenate([cluster[done:end], -1 - np.arange(_CHUNK - (end - done))])
        out = _inverse_iteration_jit(prep, jnp.asarray(lam), jnp.asarray(spec.tau), len(chunks), jnp.asarray(label))
        chunks.append([np.asarray(a)[:, :end - done] for a in out])
        done = end
    return done


def _checked_ritz(prep: _LowPrep, spec: _Spectrum, chunks: list, k: int):
    """The Rayleigh–Ritz values, vectors and residuals (:func:`_rayleigh_ritz`) of the vectors
    of ``chunks``, a vector of the lowest ``k`` whose residual exceeds 1e-9 recomputed with its
    shift moved; ``None`` where the vectors do not span the modes (the dense route).

    NOTE: the chains are eliminated without pivoting across blocks; where σ happens to lie
    within ~ε‖A‖ of an eigenvalue of a chain's tail (one of ~N² per cable) a pivot is near
    singular and that one vector is poor (residual 1e-7–1e-3 where the rest are at 1e-12). Such
    vectors are recomputed with the shift moved by 1e-6 λ, above and then below (a different
    tail pivot; the neighbours it lets in are inside the Ritz space).
    """
    lam_all, tau = spec.lam, spec.tau
    mass_cc, node_mass = np.asarray(prep.mass_cc), np.asarray(prep.node_mass)
    V, MV, KV = (np.concatenate([c[i] for c in chunks], axis=1) for i in range(3))
    for attempt, move in enumerate((1.0 + 1e-6, 1.0 - 1e-6, None)):
        try:
            theta, shapes, res = _rayleigh_ritz(V, MV, KV, mass_cc, node_mass, tau)
        except np.linalg.LinAlgError:
            return None
        bad = np.flatnonzero(~(res[:k] <= 1e-9))
        if move is None or bad.size == 0 or bad.size > _CHUNK:
            break
        lam = np.concatenate([lam_all[bad] * move, np.full(_CHUNK - bad.size, lam_all[bad[-1]] * move)])
        out = _inverse_iteration_jit(prep, jnp.asarray(lam), jnp.asarray(tau), 1000 + attempt,
                                     jnp.asarray(-1 - np.arange(_CHUNK)))
        for a, b in zip((V, MV, KV), out, strict=True):
            a[:, bad] = np.asarray(b)[:, :bad.size]
    return theta, shapes, res


def _banded_modes(prep: _LowPrep, spec: _Spectrum, theta, shapes, share, resolved, cut: float,
                  residual: float) -> LumpedLowModes:
    """The :class:`LumpedLowModes` of the banded route from the checked Ritz values ``theta``
    ``(k,)`` (rad²/s²), shapes ``(n, k)`` and compliance shares ``(k, 6)``, ``resolved`` ``(6,)``."""
    freq = np.sign(theta) * np.sqrt(np.abs(theta)) / (2.0 * np.pi)
    cab = shapes[:6]
    energy_share = np.einsum("km,kl,lm->m", cab, np.asarray(prep.mass_cc), cab)
    ok = bool(prep.statics.converged) and bool(np.all(np.isfinite(freq)))
    return LumpedLowModes(jnp.asarray(freq), jnp.asarray(shapes), jnp.asarray(energy_share), jnp.asarray(share),
                          prep.compliance, jnp.asarray(resolved), cut, prep.statics, jnp.asarray(residual),
                          jnp.asarray(bool(spec.lam[0] > 0)), jnp.asarray(ok), "banded")


def _low_from_dense(full: LumpedModes, cutoff_hz: float) -> LumpedLowModes:
    keep = np.asarray(full.frequencies_hz) < cutoff_hz
    share = full.compliance_share[keep]
    phi = full.shapes[:, keep]
    w2 = jnp.sign(full.frequencies_hz[keep]) * (2.0 * jnp.pi * full.frequencies_hz[keep]) ** 2
    r = full.stiffness @ phi - w2 * (full.mass @ phi)
    res = jnp.sqrt(jnp.abs(jnp.sum(r * jnp.linalg.solve(full.mass, r), axis=0))) / jnp.abs(w2)
    return LumpedLowModes(full.frequencies_hz[keep], phi, full.cabin_energy_share[keep], share, full.compliance,
                          jnp.sum(share, axis=0), float(cutoff_hz), full.statics, jnp.max(res), full.stable,
                          full.ok, "dense")


class ModalSummary(NamedTuple):
    """The modes below a cut-off and the cabin-dominant mode of each coordinate (numpy).

    - ``frequencies_hz``: ``(k,)``, every mode below the cut-off, ascending.
    - ``cabin_energy_share``: ``(k,)``; ``compliance_share``: ``(k, 6)``.
    - ``kind``: ``k`` strings, ``"cabin"`` or ``"string"`` (cabin energy share < ``string_share``).
    - ``dominant``: dict coordinate name → ``(index among all modes, frequency_hz, share)``, or
      ``None`` where the modes given cannot tell (see :func:`modal_summary`).
    """

    frequencies_hz: np.ndarray
    cabin_energy_share: np.ndarray
    compliance_share: np.ndarray
    kind: list
    dominant: dict


def modal_summary(modes: LumpedModes | LumpedLowModes, cutoff_hz: float = 1.5,
                  string_share: float = 0.01) -> ModalSummary:
    """The modes of ``modes`` below ``cutoff_hz`` with their shares, each marked ``"string"``
    when the cabin holds less than ``string_share`` of its kinetic energy, and, per cabin
    coordinate, the mode with the largest share of its static compliance (searched over all
    modes, so it is named even above the cut-off).

    With :class:`LumpedLowModes` (only the modes below its own cut-off are known) the
    dominant mode of a coordinate is named only where it is certain: its share exceeds the
    share of the compliance above the cut-off (``1 − compliance_resolved``), which no mode
    above could beat otherwise; else ``None``. ``cutoff_hz`` may not exceed that of ``modes``.
    """
    f = np.asarray(modes.frequencies_hz)
    e = np.asarray(modes.cabin_energy_share)
    c = np.asarray(modes.compliance_share)
    low = isinstance(modes, LumpedLowModes)
    if low and cutoff_hz > modes.cutoff_hz:
        raise ValueError(f"cutoff_hz = {cutoff_hz} Hz is above the {modes.cutoff_hz} Hz up to which these modes "
                         "were computed")
    keep = f < cutoff_hz
    rest = 1.0 - np.asarray(modes.compliance_resolved) if low else np.zeros(6)
    dominant = {}
    for k, name in enumerate(CABIN_COORDINATES):
        m = int(np.argmax(c[:, k]))
        dominant[name] = (m, float(f[m]), float(c[m, k])) if c[m, k] > rest[k] else None
    kind = ["string" if s < string_share else "cabin" for s in e[keep]]
    return ModalSummary(f[keep], e[keep], c[keep], kind, dominant)
