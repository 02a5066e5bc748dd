"""Fits of the discrepancy workflow: the base model (Levenberg–Marquardt) and base + any subset
of effects (Gauss–Newton from the base optimum with the Jacobian there; with the Jacobian at
every step where that does not converge), weighted by the model's whitener.

Every fit is the same jitted function of a 0/1 mask over the effects (inactive parameters do
not enter the prediction), so the base model, single candidates and candidate pairs share one
compiled kernel, and many data sets are fitted at once.

References: Levenberg–Marquardt (Moré 1978, "The Levenberg–Marquardt algorithm: implementation
and theory", Lecture Notes in Math. 630), here the project's batched one
(:class:`~stewart_jax.optimise.BatchedLevenbergMarquardt`), all data sets in one solve; Gauss–Newton on the normal
equations with a Levenberg ridge (Nocedal and Wright 2006, "Numerical Optimization", §10.3).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from typing import Any, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ..optimise._batched_lm import BatchedLevenbergMarquardt, least_squares_batch
from ..optimise._result import RESULTS
from ._registry import AbstractDiscrepancyModel, Effect

MAX_STEPS = 100
"""Step budget of the base Levenberg–Marquardt fit."""
GN_STEPS = 4
"""Gauss–Newton steps of every augmented fit."""
GN_TOL = 1e-8
"""Relative χ² change of the last Gauss–Newton step below which a fit counts as converged."""
GN_RIDGE = 1e-12
"""Levenberg damping of the Gauss–Newton normal equations (columns normalised to 1): keeps the
step finite when a candidate pair is collinear given the base parameters."""


def unpack(
    model: AbstractDiscrepancyModel, effects: Sequence[Effect], z: Float[Array, " n"], mask: Float[Array, " K"]
) -> tuple[Float[Array, " p"], list[Float[Array, " _"]]]:
    """Base parameters and per-effect parameters (library units) from the fit's scaled
    unknowns ``z = [(u − u0)/scale_base, θ_1/scale_1, …]``; masked effects get ``θ = 0``."""
    nb = model.base_initial.shape[0]
    base = model.base_initial + model.base_scale * z[:nb]
    thetas, off = [], nb
    for i, e in enumerate(effects):
        thetas.append(z[off : off + e.n_params] * jnp.asarray(e.scale) * mask[i])
        off += e.n_params
    return base, thetas


def effect_slices(model: AbstractDiscrepancyModel, effects: Sequence[Effect]) -> list[np.ndarray]:
    """Indices of each effect's unknowns in ``z``."""
    slices, off = [], model.base_initial.shape[0]
    for e in effects:
        slices.append(np.arange(off, off + e.n_params))
        off += e.n_params
    return slices


def _raw_residual(z, model, effects, mask, data):
    base, thetas = unpack(model, effects, z, mask)
    return model.observed(data) - model.predict(base, effects, thetas, data)


def _white_residual(z, args):
    model, effects, mask, data, w = args
    r = _raw_residual(z, model, effects, mask, data)
    return jnp.einsum("mij,mj->mi", w, r).reshape(-1)


def _keep(model, effects, mask):
    nb = model.base_initial.shape[0]
    return jnp.concatenate([jnp.ones(nb)] + [jnp.full(e.n_params, mask[i]) for i, e in enumerate(effects)])


def _base_residual(model, zb, args):
    """The whitened residual of the base model alone. NOTE: no effect is evaluated (each is the
    identity at θ = 0, so the prediction is the same): the loop of the batched fit then holds the
    base model only, not every candidate's state changes multiplied by zero."""
    data, w0 = args
    r = model.observed(data) - model.predict(model.base_initial + model.base_scale * zb, (), (), data)
    return jnp.einsum("mij,mj->mi", w0, r).reshape(-1)


@eqx.filter_jit
def _base_fits(model, effects, trains):
    """Base fits of every stacked training set from the model's starting parameters: one
    batched Levenberg–Marquardt solve (base parameters only) on the residuals whitened at the
    starting parameters. Returns the scaled unknowns ``(b, n)`` (effects at 0) and whether each
    fit converged."""
    nb = model.base_initial.shape[0]
    n_eff = sum(e.n_params for e in effects)
    w0 = jax.vmap(lambda d: model.whitener(model.base_initial, d))(trains)
    b = w0.shape[0]
    res = least_squares_batch(jax.tree_util.Partial(_base_residual, model),
                              BatchedLevenbergMarquardt(max_steps=MAX_STEPS), jnp.zeros((b, nb)), args=(trains, w0))
    return jnp.concatenate([res.params, jnp.zeros((b, n_eff))], axis=1), res.status == RESULTS.successful


PROFILE_STEPS = 2
"""Gauss–Newton steps on the base parameters alone at each starting point of a model's
:meth:`~stewart_jax.discrepancy.AbstractDiscrepancyModel.effect_grid`."""
LINE_SEARCH = 0.5 ** np.arange(6)
"""Step lengths tried, longest first, by the augmented fits of a model with an effect grid."""
SEARCHED_STEPS_FACTOR = 4
"""The augmented fits of a model with an effect grid take up to this many times its
``fit_steps`` while the last step still changes χ² by more than :data:`GN_TOL`."""


def _grid_profiles(model, effects, train, w_tr):
    """For a model with an effect grid: every row's profile (the base parameters fitted from the
    model's ``base_initial``, not from the base fit, which a far-off model may have sent
    anywhere, with the effects held at the row), its χ², and which effects the row moves.
    ``None`` for a model without a grid."""
    grid = model.effect_grid(effects)
    if grid is None:
        return None
    grid = np.asarray(grid, dtype=np.float64)
    slices = effect_slices(model, effects)
    nb = model.base_initial.shape[0]
    if grid.ndim != 2 or grid.shape[1] != sum(e.n_params for e in effects):
        raise ValueError(f"{type(model).__name__}.effect_grid must return rows of "
                         f"{sum(e.n_params for e in effects)} values, got {grid.shape}")
    moves = np.stack([np.any(grid[:, sl - nb] != 0, axis=1) for sl in slices], axis=1).astype(np.float64)
    args = (model, effects, jnp.ones(len(effects)), train, w_tr)

    # NOTE: the base parameters alone are differentiated here (the effects' parameters are
    # constants of the profile), so a model whose effects change an eigen-decomposition pays
    # for it once per row, not once per unknown; and the rows are profiled once per data set,
    # whatever the masks fitted from them.
    def profile(z_eff):
        def res(zb):
            return _white_residual(jnp.concatenate([zb, z_eff]), args)

        def step(zb, _):
            r = res(zb)
            a = jax.jacfwd(res)(zb)
            d = jnp.linalg.norm(a, axis=0)
            d = jnp.where(d > 0, d, 1.0)
            a = a / d
            normal = a.T @ a + GN_RIDGE * jnp.eye(nb)
            return zb - jax.scipy.linalg.cho_solve(jax.scipy.linalg.cho_factor(normal), a.T @ r) / d, None

        zb, _ = jax.lax.scan(step, jnp.zeros(nb), None, length=PROFILE_STEPS)
        chi2 = jnp.sum(res(zb) ** 2)
        return jnp.concatenate([zb, z_eff]), jnp.where(jnp.isfinite(chi2), chi2, jnp.inf)

    zs, chi2 = jax.lax.map(profile, jnp.asarray(grid))
    return zs, chi2, jnp.asarray(moves)


def _start(model, effects, mask, train, w_tr, z0, profiles):
    """The augmented fit's start: ``z0 * keep`` (the base fit, effects at 0), or, with grid
    ``profiles``, the profiled row of least χ² among those moving only the effects in ``mask``,
    if it beats the base fit's χ²."""
    keep = _keep(model, effects, mask)
    if profiles is None:
        return z0 * keep
    zs, chi2, moves = profiles
    eligible = jnp.all(moves <= mask[None, :], axis=1) & jnp.isfinite(chi2) & jnp.all(jnp.isfinite(zs), axis=1)
    chi2 = jnp.where(eligible, chi2, jnp.inf)  # NOTE: argmin would pick a NaN, and the comparison below drop it
    best = jnp.argmin(chi2)
    chi2_0 = jnp.sum(_white_residual(z0 * keep, (model, effects, mask, train, w_tr)) ** 2)
    return jnp.where(chi2[best] < chi2_0, zs[best] * keep, z0 * keep)


def _fit_gn(model, effects, mask, train, w_tr, test, z0, jac0, profiles=None):
    """Gauss–Newton refinement of base + the effects in ``mask`` from ``z0`` (the base fit), with
    the whitened Jacobian ``jac0`` of every unknown at ``z0``. Returns the scaled unknowns ``z``
    ``(n,)``, the whitened training χ², whether the last step's change of χ² passed the
    convergence test, and the held-out raw residuals ``(m_te, k)`` (library units).

    NOTE: started at the base optimum with the effect parameters at 0, every augmented problem
    is linear to within (effect size / lever arm) ~1e-4, so the Jacobian at the start serves
    every step (the chord method: Kelley C. T., *Iterative Methods for Linear and Nonlinear
    Equations*, SIAM 1995, §5.4): each step costs one evaluation of the residual, not of its
    Jacobian (which dominated the whole workflow's time), and the normal equations are
    factorised once. Its fixed point solves ``J0ᵀ r(z) = 0`` instead of ``J(z)ᵀ r(z) = 0``:
    the χ² there exceeds the minimum by O((ΔJ/J)²·χ²) ~ 1e-8·χ², far below any difference the
    tests resolve, and the convergence rate is that ~1e-4 per step. A fixed number of steps in a
    ``lax.scan`` keeps the kernel cheap to compile and to batch over candidates, pairs and data
    sets (a batched trust-region solver compiles ~10× slower here); the last step's change of
    χ² is returned as the convergence check. Inactive parameters get an identity row and
    active ones a tiny ridge (on unit-normalised columns), so the solve is full-rank even when
    two effects are collinear. The normal equations (Cholesky, ~1 ms) replace QR (~50 ms on
    CPU for these sizes): they square the condition number (~1e5 → 1e10 here), which costs
    accuracy in the step, not in the fixed point — the next step corrects it. Where the chord
    steps do not converge, :func:`_fit_chord` redoes the fit by full Gauss–Newton.

    A model whose effects are far from linear (a frequency change over a long record) names
    starting points (:func:`_start`, ``profiles``) and its own number of steps; its fits
    (:func:`_fit_searched`) take full Gauss–Newton steps from there.
    """
    keep = _keep(model, effects, mask)
    args = (model, effects, mask, train, w_tr)
    ridge = jnp.diag(jnp.where(keep > 0, GN_RIDGE, 1.0))
    a, d = _normalise(jac0, keep)
    factor = jax.scipy.linalg.cho_factor(a.T @ a + ridge)
    if model.effect_grid(effects) is not None:
        z_start = _start(model, effects, mask, train, w_tr, z0, profiles)
        z, chi2, converged = _fit_searched(args, keep, ridge, z_start, model.fit_steps or GN_STEPS)
    else:
        z, chi2, converged = _fit_chord(args, keep, ridge, z0, a, d, factor)
    raw_te = _raw_residual(z, model, effects, mask, test)
    return z, chi2, converged, raw_te


def _normalise(jac, keep):
    """The columns of the whitened Jacobian ``jac`` ``(n_tr, n)`` of the active unknowns
    (``keep``, ``(n,)`` of 0/1) scaled to unit norm, inactive ones zeroed, and the norms ``(n,)``
    (1 for a zero column)."""
    norms = jnp.linalg.norm(jac * keep, axis=0)
    d = jnp.where(norms > 0, norms, 1.0)
    return jac * keep / d, d


def _full_step(z, r, args, keep, ridge):
    """The full Gauss–Newton step ``(n,)`` at ``z`` from the whitened residual ``r`` there, with
    the Jacobian at ``z`` (columns normalised, ``ridge`` added to the normal equations)."""
    an, dn = _normalise(jax.jacfwd(_white_residual)(z, args), keep)
    return -jax.scipy.linalg.cho_solve(jax.scipy.linalg.cho_factor(an.T @ an + ridge), an.T @ r) / dn * keep


def _converged(chi2_prev, chi2):
    """Whether the last step changed χ² by at most :data:`GN_TOL` (relative, χ² below 1 absolute)."""
    return jnp.abs(chi2_prev - chi2) <= GN_TOL * jnp.maximum(chi2, 1.0)


def _chord_step(args, keep, a, d, factor, carry, _):
    """One chord step (the Jacobian ``a`` at the start, its column norms ``d`` and the Cholesky
    ``factor`` of its normal equations): the new ``(z, χ² before the step)``."""
    z, _ = carry
    r = _white_residual(z, args)
    dz = -jax.scipy.linalg.cho_solve(factor, a.T @ r) / d * keep
    return (z + dz, jnp.sum(r**2)), None


def _newton_step(args, keep, ridge, carry, _):
    """One full Gauss–Newton step (the Jacobian at ``z``): the new ``(z, χ² before the step)``."""
    z, _ = carry
    r = _white_residual(z, args)
    dz = _full_step(z, r, args, keep, ridge)
    return (z + dz, jnp.sum(r**2)), None


def _fit_chord(args, keep, ridge, z0, a, d, factor):
    """:data:`GN_STEPS` chord steps from ``z0 * keep`` (see :func:`_fit_gn`), redone by full
    Gauss–Newton where they did not converge: ``(z (n,), χ², converged)``.

    NOTE (when the chord method fails). The contraction ``‖I − (J0ᵀJ0)⁻¹J0ᵀJ(z)‖`` is small only
    when no combination of the unknowns is nearly degenerate: an effect that the base parameters
    almost absorb (a misaligned instrument frame on the 6-PSS, nearly a rigid motion of its base)
    turns the small change of ``J`` into a large one of the step, and the chord iteration stalls
    or diverges (measured on sessions with a hidden 10–20″ misalignment: the candidate left the
    held-out gap at 20× the noise floor and was not named). A fit whose chord steps did not
    converge is therefore redone by full Gauss–Newton from ``z0`` (the Jacobian at every step),
    under ``lax.cond`` inside the ``lax.map`` loops: only such fits pay for the Jacobians.
    """
    def run(step):
        (z, chi2_prev), _ = jax.lax.scan(step, (z0 * keep, jnp.inf), None, length=GN_STEPS)
        chi2 = jnp.sum(_white_residual(z, args) ** 2)
        return z, chi2, _converged(chi2_prev, chi2)

    z, chi2, converged = run(functools.partial(_chord_step, args, keep, a, d, factor))
    return jax.lax.cond(converged, lambda: (z, chi2, converged),
                        lambda: run(functools.partial(_newton_step, args, keep, ridge)))


def _searched_step(args, keep, ridge, z, chi2):
    """One full Gauss–Newton step from ``z`` (whose χ² is ``chi2``) shortened by backtracking:
    the longest of :data:`LINE_SEARCH` that lowers χ², else none. Returns the new ``z`` and its χ²."""
    r = _white_residual(z, args)
    dz = _full_step(z, r, args, keep, ridge)
    trial = jax.vmap(lambda t: jnp.sum(_white_residual(z + t * dz, args) ** 2))(jnp.asarray(LINE_SEARCH))
    ok = jnp.isfinite(trial) & (trial < chi2)
    best = jnp.argmax(ok)
    # NOTE: where no trial lowers χ² the step is not taken at all: ``z + dz·0`` would still carry
    # a non-finite step (a Jacobian through a mode that vanishes) into every later step
    moved = z + dz * jnp.asarray(LINE_SEARCH)[best]
    return jnp.where(jnp.any(ok), moved, z), jnp.where(jnp.any(ok), trial[best], chi2)


def _fit_searched(args, keep, ridge, z_start, n_steps):
    """The fit of a model with an effect grid: backtracking Gauss–Newton steps from ``z_start``
    (:func:`_start`), ``n_steps`` of them and then more, up to :data:`SEARCHED_STEPS_FACTOR` ×
    ``n_steps``, until the last one changes χ² by at most :data:`GN_TOL`: ``(z (n,), χ², converged)``.

    NOTE: measured on a 200 s cabin record (seed 0): six steps left ``cable_inertia`` at
    μ = 1.003 and a node lag of 0.08 (not converged; 91 % of the gap), where the same fit run on
    converges to μ = 0.9999 and closes it. Fits that converge within ``n_steps`` are unchanged."""
    most = SEARCHED_STEPS_FACTOR * n_steps

    def more(carry):
        i, _, prev, now = carry
        return (i < n_steps) | ((i < most) & ~_converged(prev, now))

    def step(carry):
        i, z, _, now = carry
        z, chi2 = _searched_step(args, keep, ridge, z, now)
        return i + 1, z, now, chi2

    chi2_0 = jnp.sum(_white_residual(z_start, args) ** 2)
    _, z, prev, chi2 = jax.lax.while_loop(more, step, (0, z_start, jnp.inf, chi2_0))
    return z, chi2, _converged(prev, chi2)


def _prepare(model, effects, train, test, z_base):
    """Whiteners at the base fit and the whitened Jacobians (all effect columns at 0)."""
    none = jnp.zeros(len(effects))
    base_fit, _ = unpack(model, effects, z_base, none)
    w_tr = model.whitener(base_fit, train)
    w_te = model.whitener(base_fit, test)
    every = jnp.ones(len(effects))
    jac_tr = jax.jacfwd(_white_residual)(z_base, (model, effects, every, train, w_tr))
    jac_te = jax.jacfwd(_white_residual)(z_base, (model, effects, every, test, w_te))
    return w_tr, w_te, jac_tr, jac_te


def _fit_masks(model, effects, masks, train, w_tr, test, z0, jac0, profiles=None):
    return jax.lax.map(lambda m: _fit_gn(model, effects, m, train, w_tr, test, z0, jac0, profiles), masks)


def _map_datasets(fn, in_axes):
    """``fn`` over a leading data-set axis with ``lax.map``.

    NOTE: not ``vmap``: batched QR on CPU is ~100× slower than LAPACK's unbatched one here, and
    every fit is a handful of small QR solves; ``lax.map`` keeps one compiled loop body."""

    def mapped(*args):
        args = args + (None,) * (len(in_axes) - len(args))  # trailing optional arguments left out: None
        fixed = [a if ax is None else None for a, ax in zip(args, in_axes, strict=True)]
        moving = [a if ax is not None else None for a, ax in zip(args, in_axes, strict=True)]

        def body(xs):
            full = [f if ax is None else x for f, x, ax in zip(fixed, xs, in_axes, strict=True)]
            return fn(*full)

        return jax.lax.map(body, moving)

    return mapped


_prepare_many = eqx.filter_jit(eqx.filter_vmap(_prepare, in_axes=(None, None, 0, 0, 0)))
fit_masks_many = eqx.filter_jit(_map_datasets(_fit_masks, (None, None, 0, 0, 0, 0, 0, 0, 0)))
"""``(model, effects, masks[b, q, K], trains, w_tr, tests, z0[b], jac0[b], profiles) -> (z, χ²,
converged, held-out raw residuals)``, each with leading axes ``(b, q)``: base + the effects of
each mask fitted to each of ``b`` data sets (stacked pytrees; ``jac0`` the whitened training
Jacobians at ``z0``; ``profiles`` (``None`` for a model without an effect grid) the starting
points of :func:`_start`, per data set)."""
_profiles_many = eqx.filter_jit(_map_datasets(_grid_profiles, (None, None, 0, 0)))


class BatchFits(NamedTuple):
    """The base fit and the single-candidate fits of ``b`` data sets (NumPy arrays; index
    ``q = 0`` the base model, ``q = i + 1`` base + candidate ``i``; ``n`` unknowns, ``K``
    candidates, ``m_te`` held-out rows of ``k`` observations, ``n_tr``/``n_te`` whitened
    training/held-out residuals).

    - ``z``: ``(b, K+1, n)`` fitted scaled unknowns (see :func:`unpack`).
    - ``chi2``: ``(b, K+1)`` whitened training χ².
    - ``ok``: ``(b, K+1)`` the base LM fit and the Gauss–Newton refinement converged.
    - ``raw_te``: ``(b, K+1, m_te, k)`` held-out residuals, library units.
    - ``w_tr``, ``w_te``: per-row whiteners at the base fit, ``(b, m, k, k)``.
    - ``jac_tr``, ``jac_te``: ``(b, n_tr, n)``, ``(b, n_te, n)`` whitened Jacobians at the base
      fit (all effect columns included).
    - ``base_ok``: ``(b,)`` the base Levenberg–Marquardt fit converged.
    """

    z: np.ndarray
    chi2: np.ndarray
    ok: np.ndarray
    raw_te: np.ndarray
    w_te: np.ndarray
    w_tr: np.ndarray
    jac_tr: np.ndarray
    jac_te: np.ndarray
    base_ok: np.ndarray


def fit_candidates(
    model: AbstractDiscrepancyModel,
    effects: Sequence[Effect],
    trains: Any,
    tests: Any,
) -> BatchFits:
    """Base fits of every training set (``trains``; ``tests`` the held-out sets, both stacked
    along a leading data-set axis), then base + each single effect."""
    k = len(effects)
    z_base, ok = _base_fits(model, effects, trains)
    w_tr, w_te, jac_tr, jac_te = _prepare_many(model, effects, trains, tests, z_base)
    b = z_base.shape[0]
    masks = jnp.broadcast_to(jnp.concatenate([jnp.zeros((1, k)), jnp.eye(k)]), (b, k + 1, k))
    profiles = _profiles_many(model, effects, trains, w_tr) if model.effect_grid(effects) is not None else None
    z, chi2, last, raw_te = fit_masks_many(model, effects, masks, trains, w_tr, tests, z_base, jac_tr, profiles)
    return BatchFits(
        *jax.device_get((z, chi2, ok[:, None] & last, raw_te, w_te, w_tr, jac_tr, jac_te, ok))
    )


def fit_pairs(
    model: AbstractDiscrepancyModel,
    effects: Sequence[Effect],
    masks: Float[np.ndarray, "b q K"],
    trains: Any,
    tests: Any,
    fits: BatchFits,
) -> Float[np.ndarray, "b q"]:
    """Training χ² of base + the effects of each mask, started from the base fits (for a model
    with an effect grid: from the best single-effect fit of an effect in the mask).

    NOTE: ``masks`` padded to the shape of :func:`fit_candidates`' masks (data sets ×
    ``(K + 1)``) reuse its compiled kernel; so do the starts, padded to the grid's rows."""
    grid = model.effect_grid(effects)
    profiles = None
    if grid is not None:
        b, k = fits.chi2.shape[0], len(effects)
        pad = max(grid.shape[0] - k, 0)
        zs = np.concatenate([fits.z[:, 1:], np.zeros((b, pad, fits.z.shape[2]))], axis=1)
        chi2_1 = np.where(np.isfinite(fits.chi2[:, 1:]), fits.chi2[:, 1:], np.inf)
        chi2_1 = np.concatenate([chi2_1, np.full((b, pad), np.inf)], axis=1)
        moves = np.concatenate([np.eye(k), np.ones((pad, k))])[None].repeat(b, axis=0)
        profiles = (jnp.asarray(zs), jnp.asarray(chi2_1), jnp.asarray(moves))
    _, chi2, _, _ = jax.device_get(
        fit_masks_many(model, effects, jnp.asarray(masks), trains, fits.w_tr, tests, fits.z[:, 0], fits.jac_tr,
                       profiles)
    )
    return chi2

