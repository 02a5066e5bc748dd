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


def _fit_gn(model, effects, mask, train, w_tr, test, z0, jac0):
    """Gauss–Newton refinement of base + the effects in ``mask`` from ``z0`` (the base fit), with
    the whitened Jacobian ``jac0`` of every unknown at ``z0``.

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
    accuracy in the step, not in the fixed point — the next step corrects it.

    NOTE (when the chord method fails). The contraction ``‖I − (J0ᵀJ0)⁻¹J0ᵀJ(z)‖`` is small only
    when no combination of the unknowns is nearly degenerate: an effect that the base parameters
    almost absorb (a misaligned instrument frame on the 6-PSS, nearly a rigid motion of its base)
    turns the small change of ``J`` into a large one of the step, and the chord iteration stalls
    or diverges (measured on sessions with a hidden 10–20″ misalignment: the candidate left the
    held-out gap at 20× the noise floor and was not named). A fit whose chord steps did not
    converge is therefore redone by full Gauss–Newton from ``z0`` (the Jacobian at every step),
    under ``lax.cond`` inside the ``lax.map`` loops: only such fits pay for the Jacobians.
    """
    keep = _keep(model, effects, mask)
    args = (model, effects, mask, train, w_tr)
    ridge = jnp.diag(jnp.where(keep > 0, GN_RIDGE, 1.0))

    def normalise(jac):
        norms = jnp.linalg.norm(jac * keep, axis=0)
        d = jnp.where(norms > 0, norms, 1.0)
        return jac * keep / d, d

    a, d = normalise(jac0)
    factor = jax.scipy.linalg.cho_factor(a.T @ a + ridge)

    def chord(carry, _):
        z, _ = carry
        r = _white_residual(z, args)
        dz = -jax.scipy.linalg.cho_solve(factor, a.T @ r) / d * keep
        return (z + dz, jnp.sum(r**2)), None

    def newton(carry, _):
        z, _ = carry
        r = _white_residual(z, args)
        an, dn = normalise(jax.jacfwd(_white_residual)(z, args))
        dz = -jax.scipy.linalg.cho_solve(jax.scipy.linalg.cho_factor(an.T @ an + ridge), an.T @ r) / dn * keep
        return (z + dz, jnp.sum(r**2)), None

    def run(step):
        (z, chi2_prev), _ = jax.lax.scan(step, (z0 * keep, jnp.inf), None, length=GN_STEPS)
        chi2 = jnp.sum(_white_residual(z, args) ** 2)
        return z, chi2, jnp.abs(chi2_prev - chi2) <= GN_TOL * jnp.maximum(chi2, 1.0)

    z, chi2, converged = run(chord)
    z, chi2, converged = jax.lax.cond(converged, lambda: (z, chi2, converged), lambda: run(newton))
    raw_te = _raw_residual(z, model, effects, mask, test)
    return z, chi2, converged, raw_te


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


def _fit_masks(model, effects, masks, train, w_tr, test, z0, jac0):
    return jax.lax.map(lambda m: _fit_gn(model, effects, m, train, w_tr, test, z0, jac0), masks)


def _map_datasets(fn, in_axes):
    """``fn`` over a leading data-set axis with ``lax.map``.

    NOTE: not ``vmap``: batched QR on CPU is ~100× slower than LAPACK's unbatched one here, and
    every fit is a handful of small QR solves; ``lax.map`` keeps one compiled loop body."""

    def mapped(*args):
        fixed = [a if ax is None else None for a, ax in zip(args, in_axes, strict=True)]
        moving = [a if ax is not None else None for a, ax in zip(args, in_axes, strict=True)]

        def body(xs):
            full = [f if ax is None else x for f, x, ax in zip(fixed, xs, in_axes, strict=True)]
            return fn(*full)

        return jax.lax.map(body, moving)

    return mapped


_prepare_many = eqx.filter_jit(eqx.filter_vmap(_prepare, in_axes=(None, None, 0, 0, 0)))
fit_masks_many = eqx.filter_jit(_map_datasets(_fit_masks, (None, None, 0, 0, 0, 0, 0, 0)))
"""``(model, effects, masks[b, q, K], trains, w_tr, tests, z0[b], jac0[b]) -> (z, χ², converged,
held-out raw residuals)``, each with leading axes ``(b, q)``: base + the effects of each mask
fitted to each of ``b`` data sets (stacked pytrees; ``jac0`` the whitened training Jacobians
at ``z0``)."""


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
    z, chi2, last, raw_te = fit_masks_many(model, effects, masks, trains, w_tr, tests, z_base, jac_tr)
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
    """Training χ² of base + the effects of each mask, started from the base fits.

    NOTE: ``masks`` padded to the shape of :func:`fit_candidates`' masks (data sets ×
    ``(K + 1)``) reuse its compiled kernel."""
    _, chi2, _, _ = jax.device_get(
        fit_masks_many(model, effects, jnp.asarray(masks), trains, fits.w_tr, tests, fits.z[:, 0], fits.jac_tr)
    )
    return chi2

