"""A Levenberg–Marquardt for batches of small least-squares problems, written for ``vmap``.

Levenberg K., "A method for the solution of certain non-linear problems in least squares",
Quart. Appl. Math. 2 (1944) 164–168; Marquardt D. W., "An algorithm for least-squares estimation
of nonlinear parameters", J. SIAM 11 (1963) 431–441 (damping scaled by ``diag(JᵀJ)``);
Moré J. J., "The Levenberg–Marquardt algorithm: implementation and theory", Numerical Analysis,
Lecture Notes in Mathematics 630 (1978) 105–116 (the scaling ``D_k = max(D_{k−1}, diag(J_kᵀJ_k))``,
eq. 6.3); Nielsen H. B., "Damping parameter in Marquardt's method", IMM-REP-1999-05, DTU (1999),
and Madsen K., Nielsen H. B., Tingleff O., *Methods for non-linear least squares problems*, 2nd ed.
(2004), §3.2, Algorithm 3.16 (the gain ratio ``ϱ`` of eq. 2.18, the damping update of eq. 3.16
and the stopping tests of eqs. 3.9a–b). For calibration it is applied to the residual vector
E(u) of Wang et al. (2018), eq. 8.

One iteration from ``y`` with residual ``r = fn(y)`` and Jacobian ``J = ∂r/∂y`` (``m × n``):

1. ``A = JᵀJ``, ``g = Jᵀr``; solve ``(A + μ·diag(D))·h = −g`` by Cholesky;
2. ``ϱ = (‖r‖² − ‖r(y + h)‖²) / (hᵀ(μ·D⊙h − g))`` (actual over predicted decrease of ``‖r‖²``;
   the factor ½ of Madsen et al.'s ``F = ½‖r‖²`` cancels);
3. ``ϱ > 0``: accept, ``μ ← μ·max(1/3, 1 − (2ϱ − 1)³)``, ``ν ← 2``; else reject,
   ``μ ← μ·ν``, ``ν ← 2ν`` (Nielsen's rule: few iterations, no oscillation of ``μ``).

It stops (status ``successful``) when ``‖g‖∞ ≤ gtol`` (eq. 3.9a), when the step is negligible,
``‖h‖ ≤ xtol·(‖y‖ + xtol)`` (eq. 3.9b), or when an accepted step lowered ``‖r‖²`` by at most
``ftol·‖r‖²`` (MINPACK's relative-reduction test); after ``max_steps`` iterations it reports
``max_steps_reached``. A step whose residual or Jacobian is not finite is rejected (``μ`` grows);
a start whose residual is not finite reports ``nonfinite`` at once.

Separable problems. Where the residual splits into ``K`` groups of rows, each depending only on its
own group of parameters (a parallel mechanism's readings: leg ``i``'s readings depend only on leg
``i``'s joints), ``blocks=(rows, cols)`` says so and the solver runs ``K`` independent LMs in one
loop — ``JᵀJ`` is block-diagonal, so each block gets its own ``m_k × n_k`` normal equations,
damping, gain ratio and stopping tests; one evaluation of the residual (and of the Jacobian) serves
every block. Without a Jacobian the ``n_k`` columns of each block are found by ``n_k`` forward-mode
directions, each seeding one parameter of every block at once (column compression, Curtis A. R.,
Powell M. J. D., Reid J. K., "On the estimation of sparse Jacobian matrices", J. Inst. Math. Appl.
13 (1974) 117–119). For the 36-parameter 6-PSS this is 6 × (6 × 6) normal equations instead of one
36 × 36 and 6 directions instead of 36. The unstructured problem is the case ``K = 1``.

Batching: :func:`least_squares_batch` vmaps one problem's ``while_loop``. Under ``vmap`` JAX runs
the loop while *any* trial is unfinished and keeps a finished trial's state by a select, so a
converged trial (or block) is never changed again (it still costs its share of each batched
iteration: the batch costs as many iterations as its slowest trial). Each iteration is a handful of batched
kernels — the Jacobian, one batched ``JᵀJ`` and one batched Cholesky — so per-calibration time
falls as the batch grows.

NOTE (Cholesky, not QR, on the normal equations). Forming ``JᵀJ`` squares the condition number,
which is what QR of ``[J; √(μD)]`` avoids, at twice the flops. Measured on the 8-pose
calibration (48 residuals, 36 parameters; ``benchmarks/batched_lm.py --conditioning``): the
singular values of ``J`` run from 3.2e-2 down to 1.6e-5 (24 well determined, 12 weakly — poses of
±1 mm / ±1° barely see them), so ``cond(JᵀJ + μD) ≤ 3.7e6`` for every ``μ`` from 1e-3 down to 1e-12;
the Cholesky step agrees with the QR solution to ≤ 1e-11 relative and the cost after either step
to ≤ 3e-11 relative — below the cost's own rounding floor (see ``ftol``). With ``cond ≪ 1/ε``
there is nothing for QR to buy. ``μ`` is still floored at ``min_damping`` (1e-12), so that a
rank-deficient ``JᵀJ`` (a parameter no residual sees) keeps the factorisation definite.
"""

from __future__ import annotations

from typing import Any, Literal, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax import lax
from jax.flatten_util import ravel_pytree
from jaxtyping import Array, Bool, Float, Int

from ._driver import materialize
from ._levenberg_marquardt import sum_of_squares
from ._objective import AbstractOptimiser, Objective, needs_residuals
from ._result import RESULTS, OptimiseResult


class BatchedLMState(NamedTuple):
    """State of one problem of ``K`` blocks of ``m_k`` residuals and ``n_k`` parameters (a
    leading batch axis on every leaf under ``vmap``).

    - ``y``: ``Float[Array, "n"]``, the current point (the best so far, per block).
    - ``cost``: ``Float[Array, "K"]``, ``‖r‖²`` of each block's residuals.
    - ``jtj``: ``Float[Array, "K n_k n_k"]``, ``J_kᵀJ_k`` at ``y``.
    - ``gradient``: ``Float[Array, "K n_k"]``, ``J_kᵀr_k`` at ``y`` (half the cost's gradient).
    - ``scale``: ``Float[Array, "K n_k"]``, the damping's diagonal ``D``.
    - ``damping``: ``Float[Array, "K"]``, ``μ``; ``nu``: ``Float[Array, "K"]``, Nielsen's ``ν``.
    - ``block_done``: ``Bool[Array, "K"]``, a stopping test held for the block.
    - ``steps``: ``Int[Array, ""]``, iterations done (each one residual and one Jacobian).
    - ``finite_start``: ``Bool[Array, ""]``, the start's residual and Jacobian are finite.
    """

    y: Float[Array, " n"]
    cost: Float[Array, " K"]
    jtj: Float[Array, "K n_k n_k"]
    gradient: Float[Array, "K n_k"]
    scale: Float[Array, "K n_k"]
    damping: Float[Array, " K"]
    nu: Float[Array, " K"]
    block_done: Bool[Array, " K"]
    steps: Int[Array, ""]
    finite_start: Bool[Array, ""]


class Blocks(NamedTuple):
    """A separable residual: block ``k``'s residual rows ``rows[k]`` depend only on its parameters
    ``cols[k]`` (indices into the raveled residual and parameters; each a partition).

    - ``rows``: ``Int[np.ndarray, "K m_k"]``; ``cols``: ``Int[np.ndarray, "K n_k"]`` (NumPy: static).
    """

    rows: np.ndarray
    cols: np.ndarray


def check_blocks(blocks: Blocks | tuple | None, m: int, n: int) -> Blocks:
    """``blocks`` validated against ``m`` residuals and ``n`` parameters (``None``: one block)."""
    if blocks is None:
        return Blocks(np.arange(m)[None], np.arange(n)[None])
    rows, cols = (np.asarray(b) for b in blocks)
    if rows.ndim != 2 or cols.ndim != 2 or rows.shape[0] != cols.shape[0] or not (
            np.issubdtype(rows.dtype, np.integer) and np.issubdtype(cols.dtype, np.integer)):
        raise ValueError(f"blocks must be two integer arrays (K, m_k) and (K, n_k), got shapes {rows.shape}, "
                         f"{cols.shape}")
    for name, idx, size in (("rows", rows, m), ("cols", cols, n)):
        if not np.array_equal(np.sort(idx.ravel()), np.arange(size)):
            raise ValueError(f"blocks.{name} must hold each of the {size} indices exactly once")
    return Blocks(rows, cols)


class BatchedLevenbergMarquardt(AbstractOptimiser):
    """Hyper-parameters of the batched LM.

    - ``max_steps``: iteration budget; each iteration evaluates the residual and its Jacobian
      once (at the trial point).
    - ``ftol``: a block stops when an accepted step lowers its ``‖r‖²`` by at most ``ftol·‖r‖²``
      (or the actual and predicted reductions are both that small). 1e-10: the rounding floor
      of a calibration cost (residuals of ~0.1 µm computed from ~200 mm legs carry relative
      rounding errors of ~1e-10); stricter only adds iterations that move the cost by rounding.
    - ``xtol``: a block stops when its step is negligible, ``‖h‖ ≤ xtol·(‖y‖ + xtol)``.
    - ``gtol``: a block stops when ``‖Jᵀr‖∞ ≤ gtol`` (residual² per parameter unit; 0 disables).
    - ``initial_damping``: ``μ₀``, relative to the scale ``D`` (Madsen et al.'s ``τ``; 1e-3 for a
      start believed close to the solution).
    - ``min_damping``: floor of ``μ``, so that Cholesky never meets a zero pivot on a
      rank-deficient ``JᵀJ`` (see the module's NOTE).
    - ``scaling``: ``"more"`` (``D_k = max(D_{k−1}, diag JᵀJ)``, Moré 1978) or ``"marquardt"``
      (``D = diag JᵀJ`` at the current point, Marquardt 1963).
    - ``working_set``: in :func:`least_squares_batch`, how many problems are iterated together;
      a finished one is replaced by the next (see its NOTE). ``None``: the whole batch, until
      its slowest problem is done (``vmap`` of a ``while_loop``). 64: on 1000 8-pose
      calibrations (2 cores) 0.21 ms per calibration, against 0.24 (32), 0.43 (128) and 0.90
      (the whole batch).
    """

    max_steps: int = 100
    ftol: float = 1e-10
    xtol: float = 1e-12
    gtol: float = 0.0
    initial_damping: float = 1e-3
    min_damping: float = 1e-12
    scaling: Literal["more", "marquardt"] = "more"
    working_set: int | None = 64

    def __check_init__(self):
        if not (int(self.max_steps) == self.max_steps and self.max_steps >= 1):
            raise ValueError(f"BatchedLevenbergMarquardt.max_steps must be a positive integer, got {self.max_steps!r}")
        for name in ("ftol", "xtol", "gtol"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"BatchedLevenbergMarquardt.{name} must be >= 0, got {getattr(self, name)!r}")
        if not self.initial_damping > 0:
            raise ValueError(
                f"BatchedLevenbergMarquardt.initial_damping must be > 0, got {self.initial_damping!r}")
        if not 0 < self.min_damping <= self.initial_damping:
            raise ValueError(
                f"BatchedLevenbergMarquardt.min_damping must be in (0, initial_damping], got {self.min_damping!r}")
        if self.working_set is not None and not (int(self.working_set) == self.working_set and self.working_set >= 1):
            raise ValueError(
                f"BatchedLevenbergMarquardt.working_set must be a positive integer or None, got {self.working_set!r}")
        if self.scaling not in ("more", "marquardt"):
            raise ValueError(
                f"BatchedLevenbergMarquardt.scaling must be 'more' or 'marquardt', got {self.scaling!r}")

    # ---- one problem: init / step / terminate ----------------------------------------------

    def init(self, linearise, y: Float[Array, " n"], blocks: Blocks) -> BatchedLMState:
        """The state at ``y``; ``linearise(y) -> (r_k, J_k)`` per block, ``(K, m_k)``, ``(K, m_k, n_k)``."""
        r, j = linearise(y)
        jtj, g = _normal_equations(j, r)
        cost = jnp.sum(r**2, axis=-1)
        finite = _finite(cost, jtj, g)
        k = blocks.cols.shape[0]
        return BatchedLMState(
            y=y, cost=cost, jtj=jtj, gradient=g, scale=_floor_scale(jnp.diagonal(jtj, axis1=-2, axis2=-1)),
            damping=jnp.full(k, self.initial_damping, y.dtype), nu=jnp.full(k, 2.0, y.dtype),
            block_done=~finite | (jnp.max(jnp.abs(g), axis=-1) <= self.gtol) | (cost == 0.0),
            steps=jnp.asarray(0, jnp.int32), finite_start=jnp.all(finite),
        )

    def step(self, linearise, state: BatchedLMState, blocks: Blocks) -> BatchedLMState:
        """One iteration of every unfinished block (a no-op where all are done)."""
        s = state
        damp = s.damping[:, None] * s.scale
        h = _cholesky_solve(s.jtj + _diag(damp), -s.gradient)
        h = jnp.where(s.block_done[:, None], 0.0, h)
        h = jnp.where(jnp.isfinite(h), h, 0.0)  # a failed factorisation: rejected below
        y_new = s.y.at[blocks.cols].add(h)
        r_new, j_new = linearise(y_new)
        r_new, j_new = materialize(r_new), materialize(j_new)
        jtj_new, g_new = _normal_equations(j_new, r_new)
        jtj_new, g_new = materialize(jtj_new), materialize(g_new)
        cost_new = jnp.sum(r_new**2, axis=-1)
        predicted = jnp.sum(h * (damp * h - s.gradient), axis=-1)
        rho = (s.cost - cost_new) / jnp.where(predicted > 0, predicted, 1.0)
        accept = _finite(cost_new, jtj_new, g_new) & (predicted > 0) & (rho > 0) & ~s.block_done
        mu_accept = s.damping * jnp.maximum(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
        damping = jnp.maximum(jnp.where(accept, mu_accept, s.damping * s.nu), self.min_damping)
        diag_new = jnp.diagonal(jtj_new, axis1=-2, axis2=-1)
        scale_new = jnp.maximum(s.scale, diag_new) if self.scaling == "more" else _floor_scale(diag_new)
        y_blocks = s.y[blocks.cols]
        small_step = jnp.linalg.norm(h, axis=-1) <= self.xtol * (jnp.linalg.norm(y_blocks, axis=-1) + self.xtol)
        # MINPACK's test: the actual and the predicted reductions are both negligible (the
        # second catches a minimum where rounding makes every further step a rejection).
        actual = s.cost - cost_new
        small_gain = (accept & (actual <= self.ftol * s.cost)) | (
            (jnp.abs(actual) <= self.ftol * s.cost) & (predicted <= self.ftol * s.cost) & (rho <= 2.0))
        small_grad = accept & (jnp.max(jnp.abs(g_new), axis=-1) <= self.gtol)
        a1, a2, a3 = accept[:, None], accept[:, None, None], accept[:, None]
        new = s._replace(
            y=s.y.at[blocks.cols].add(jnp.where(a1, h, 0.0)),
            cost=jnp.where(accept, cost_new, s.cost),
            jtj=jnp.where(a2, jtj_new, s.jtj),
            gradient=jnp.where(a3, g_new, s.gradient),
            scale=jnp.where(a3, scale_new, s.scale),
            damping=jnp.where(s.block_done, s.damping, damping),
            nu=jnp.where(s.block_done, s.nu, jnp.where(accept, 2.0, 2.0 * s.nu)),
            block_done=s.block_done | small_step | small_gain | small_grad | (accept & (cost_new == 0.0)),
            steps=s.steps + 1,
        )
        # NOTE: a finished problem is frozen whole (its step count too); blocks that finished
        # earlier are frozen by the masks above (h = 0, nothing accepted).
        done = jnp.all(s.block_done)
        return jax.tree.map(lambda old, nw: jnp.where(done, old, nw), s, new)

    def terminate(self, state: BatchedLMState) -> tuple[Bool[Array, ""], RESULTS]:
        """Every block stopped (``successful``), or the budget is spent (``max_steps_reached``)."""
        converged = jnp.all(state.block_done)
        return converged | (state.steps >= self.max_steps), RESULTS.where(
            converged, RESULTS.successful, RESULTS.max_steps_reached)

    # ---- the protocol ----------------------------------------------------------------------

    def solve(self, objective: Objective, y0, lower, upper, key, args, max_evaluations: int) -> OptimiseResult:
        """:meth:`run` on ``objective.residuals`` (with its Jacobian and blocks) from ``y0``
        (unbounded; the budget is ``max_steps``)."""
        del lower, upper, key, max_evaluations
        return self.run(needs_residuals(self, objective), y0, args, objective.cost, objective.jacobian,
                        objective.blocks)

    def solve_batch(self, objective: Objective, y0s, lowers, uppers, keys, args, max_evaluations: int
                    ) -> OptimiseResult:
        """:func:`least_squares_batch`: finished problems stop costing (not ``vmap`` of :meth:`solve`)."""
        del lowers, uppers, keys, max_evaluations
        return least_squares_batch(needs_residuals(self, objective), self, y0s, args=args, jac=objective.jacobian,
                                   cost=objective.cost, blocks=objective.blocks)

    # ---- the driver of one problem ---------------------------------------------------------

    def run(self, fn, y0, args=None, cost=None, jac=None, blocks=None) -> OptimiseResult:
        """Minimise ``Σ fn(y, args)²`` from ``y0`` (any pytree; ``fn`` returns a vector or any
        pytree of arrays).

        - ``jac(y, args)``: the ``(m, n)`` Jacobian of the raveled residual with respect to the
          raveled ``y`` (default: forward-mode autodiff, column-compressed over ``blocks``), or
          with ``blocks`` just its blocks, ``(K, m_k, n_k)``: ``[k, a, b]`` is the derivative of
          residual ``rows[k, a]`` by parameter ``cols[k, b]``.
        - ``cost(y, args)``: the value reported (default ``Σ fn²``; a caller may mark
          infeasible points +inf, which reports ``nonfinite``).
        - ``blocks``: a :class:`Blocks` (or ``(rows, cols)``) where the residual is separable.

        Pure and jittable. For many problems use :func:`least_squares_batch` (not ``vmap`` of
        this), whose loop lets finished problems stop costing.
        """
        y0_flat, unravel = ravel_pytree(y0)
        problem = _Problem.make(fn, jac, unravel, jnp.asarray(y0_flat, jnp.float64), args, blocks)
        state = self.init(problem.lineariser(args), problem.y0, problem.blocks)
        state = lax.while_loop(lambda s: ~self.terminate(s)[0],
                               lambda s: self.step(problem.lineariser(args), s, problem.blocks), state)
        return _result(state, unravel, args, fn, cost)


class _Problem(NamedTuple):
    """One problem's raveled residual, Jacobian and blocks (shared by every problem of a batch)."""

    fn: Any  # (y_flat, args) -> r_flat
    jac: Any  # (y_flat, args) -> (m, n), or None
    y0: Array
    blocks: Blocks

    @staticmethod
    def make(fn, jac, unravel, y0_flat, args, blocks) -> _Problem:
        def flat_fn(y, a):
            r, _ = ravel_pytree(fn(unravel(y), a))
            return jnp.asarray(r, y.dtype)

        m = jax.eval_shape(flat_fn, y0_flat, args).shape[0]
        flat_jac = None if jac is None else (lambda y, a: jnp.asarray(jac(unravel(y), a), y.dtype))
        return _Problem(flat_fn, flat_jac, y0_flat, check_blocks(blocks, m, y0_flat.shape[0]))

    def lineariser(self, args):
        return _lineariser(lambda y: self.fn(y, args),
                           None if self.jac is None else (lambda y: self.jac(y, args)), self.blocks)


def _result(state: BatchedLMState, unravel, args, fn, cost) -> OptimiseResult:
    """The :class:`OptimiseResult` of one problem's final state."""
    cost_fn = sum_of_squares(fn) if cost is None else cost
    params = unravel(state.y)
    reported = jnp.asarray(cost_fn(params, args))
    status = RESULTS.where(
        ~(jnp.isfinite(reported) & state.finite_start),
        RESULTS.nonfinite,
        RESULTS.where(jnp.all(state.block_done), RESULTS.successful, RESULTS.max_steps_reached),
    )
    n = jnp.asarray(state.steps + 1, jnp.int32)
    return OptimiseResult(params, reported, n, status, reported[None], n[None])


def _lineariser(fn, jac, blocks: Blocks):
    """``y -> (r_k, J_k)``: the residual and Jacobian cut into blocks, ``(K, m_k)``, ``(K, m_k, n_k)``.
    ``jac`` may return the dense ``(m, n)`` Jacobian or its blocks ``(K, m_k, n_k)`` directly."""
    rows, cols = blocks
    if jac is not None:
        def linearise(y):
            j = jnp.asarray(jac(y), y.dtype)
            if j.ndim == 3:
                if j.shape != rows.shape + cols.shape[1:]:
                    raise ValueError(f"a block Jacobian must have shape (K, m_k, n_k) = "
                                     f"{rows.shape + cols.shape[1:]}, got {j.shape}")
                return fn(y)[rows], j
            return fn(y)[rows], j[rows[:, :, None], cols[:, None, :]]
        return linearise
    # Column compression: direction k moves parameter cols[b, k] of every block b at once; a row
    # of block b sees only its own block's parameter.
    seeds = np.zeros((cols.shape[1], int(cols.size)))
    for k in range(cols.shape[1]):
        seeds[k, cols[:, k]] = 1.0

    def linearise(y):
        r, jvp = jax.linearize(fn, y)
        jc = jax.vmap(jvp)(jnp.asarray(seeds, y.dtype))  # (n_k, m)
        return r[rows], jnp.moveaxis(jc[:, rows], 0, -1)

    return linearise


def _normal_equations(j: Float[Array, "K m n"], r: Float[Array, "K m"]):
    """``(JᵀJ, Jᵀr)`` per block."""
    jtj = jnp.einsum("kmi,kmj->kij", j, j, precision=lax.Precision.HIGHEST)
    return jtj, jnp.einsum("kmi,km->ki", j, r, precision=lax.Precision.HIGHEST)


def _finite(cost, jtj, g) -> Bool[Array, " K"]:
    return jnp.isfinite(cost) & jnp.all(jnp.isfinite(jtj), axis=(-2, -1)) & jnp.all(jnp.isfinite(g), axis=-1)


def _diag(d: Float[Array, "K n"]) -> Float[Array, "K n n"]:
    return d[..., :, None] * jnp.eye(d.shape[-1], dtype=d.dtype)


def _floor_scale(diag: Float[Array, "K n"]) -> Float[Array, "K n"]:
    """``diag(JᵀJ)`` with zero (or tiny) entries raised to ``1e-16·max`` of the block (a
    parameter that no residual sees still gets some damping, so the matrix stays definite)."""
    top = jnp.max(diag, axis=-1, keepdims=True)
    return jnp.maximum(diag, 1e-16 * jnp.where(top > 0, top, 1.0))


def _cholesky_solve(a: Float[Array, "K n n"], b: Float[Array, "K n"]) -> Float[Array, "K n"]:
    """``a⁻¹b`` per block for symmetric positive definite ``a``; NaN where a pivot is not positive.

    NOTE: written out column by column in element-wise operations over every leading axis
    (the blocks and, under ``vmap``, the batch) rather than calling LAPACK per matrix: for
    the 6 × 6 and 7 × 7 blocks of a calibration, XLA:CPU then runs each column step as one
    vectorised loop over all problems, where ``jnp.linalg.cholesky`` and
    ``lax.linalg.triangular_solve`` loop over thousands of tiny matrices (and the latter's
    expansion made compilation several times slower). ``n`` steps of ``O(n²)`` each.
    """
    n = a.shape[-1]
    rows = jnp.arange(n)
    low = jnp.zeros_like(a)
    for j in range(n):
        v = a[..., :, j] - jnp.einsum("...ik,...k->...i", low, low[..., j, :])
        col = v / jnp.sqrt(v[..., j:j + 1])
        low = low.at[..., :, j].set(jnp.where(rows >= j, col, 0.0))
    z = jnp.zeros_like(b)
    for i in range(n):
        z = z.at[..., i].set((b[..., i] - jnp.sum(low[..., i, :] * z, axis=-1)) / low[..., i, i])
    h = jnp.zeros_like(b)
    for i in reversed(range(n)):
        h = h.at[..., i].set((z[..., i] - jnp.sum(low[..., :, i] * h, axis=-1)) / low[..., i, i])
    return h


def least_squares_batch(fn, solver: BatchedLevenbergMarquardt, y0s, *, args=None, jac=None, cost=None,
                        blocks=None) -> OptimiseResult:
    """Solve a batch of independent problems ``min Σ fn(y, args_b)²`` from ``y0s[b]``: every leaf of
    ``y0s`` and ``args`` has a leading batch axis (the optimistix argument order, as
    :func:`~stewart_jax.optimise.least_squares`). ``jac(y, args) -> (m, n)`` is the Jacobian of
    one problem (default: forward-mode autodiff); ``cost(y, args)`` the value reported;
    ``blocks`` a :class:`Blocks` where every problem's residual is separable (see
    :meth:`BatchedLevenbergMarquardt.run`).

    Returns an :class:`OptimiseResult` with the same leading batch axis (a status per problem);
    each problem's result is what :meth:`BatchedLevenbergMarquardt.run` returns for it alone.
    Pure and jittable (wrap it in ``jax.jit`` or ``eqx.filter_jit`` to reuse the compilation).

    NOTE (finished problems stop costing). ``vmap`` of a ``while_loop`` iterates the whole batch
    until its slowest problem is done (on the 8-pose calibration: 49 iterations for a median of
    21). Here the loop iterates a working set of ``solver.working_set`` slots: when a problem in a
    slot stops, its state is written out and the slot is refilled with the next problem not yet
    started (its initial state and ``args`` gathered by index). The shapes are static, so the
    step compiles once; the cost is about the *sum* of the problems' iterations plus one
    working set's tail, instead of ``batch × slowest``. Measured in ``benchmarks/batched_lm.py``.
    """
    if not isinstance(solver, BatchedLevenbergMarquardt):
        raise TypeError(f"solver must be a BatchedLevenbergMarquardt, got {type(solver).__name__}")
    sizes = {x.shape[0] for x in jax.tree.leaves((y0s, args)) if getattr(x, "ndim", 0)}
    if len(sizes) != 1:
        raise ValueError(f"every leaf of y0s and args needs the same leading batch axis, got sizes {sorted(sizes)}")
    if blocks is not None:  # hashable, so that the compiled solve is cached by it
        blocks = tuple(tuple(map(tuple, np.asarray(b).tolist())) for b in blocks)
    return _solve_batch(fn, solver, y0s, args, jac, cost, blocks)


@eqx.filter_jit
def _solve_batch(fn, solver, y0s, args, jac, cost, blocks):
    """:func:`least_squares_batch`, compiled as one program (called eagerly, each of its
    operations would otherwise be compiled on its own)."""
    blocks = None if blocks is None else Blocks(*(np.asarray(b) for b in blocks))
    (batch,) = {x.shape[0] for x in jax.tree.leaves((y0s, args)) if getattr(x, "ndim", 0)}
    first = jax.tree.map(lambda x: x[0], (y0s, args))
    y_first, unravel = ravel_pytree(first[0])
    problem = _Problem.make(fn, jac, unravel, jnp.asarray(y_first, jnp.float64), first[1], blocks)
    y0_flat = jax.vmap(lambda y: jnp.asarray(ravel_pytree(y)[0], jnp.float64))(y0s)

    def init(y, a):
        return solver.init(problem.lineariser(a), y, problem.blocks)

    def step(s, a):
        return solver.step(problem.lineariser(a), s, problem.blocks)

    width = batch if solver.working_set is None else min(batch, solver.working_set)
    # one working set at a time, so that the initial Jacobians of a large batch never all sit in memory
    state = lax.map(lambda ya: init(*ya), (y0_flat, args), batch_size=width)
    state = _refill_loop(lambda s: solver.terminate(s)[0], jax.vmap(step), state, args, batch, width)
    return jax.vmap(lambda s, a: _result(s, unravel, a, fn, cost))(state, args)


def _refill_loop(terminate, step, initial, args, batch: int, width: int):
    """Iterate every problem of ``initial`` (batch axis first) to its end in ``width`` slots, a
    finished slot refilled with the next problem (see :func:`least_squares_batch`'s NOTE)."""
    terminate = jax.vmap(terminate)

    def take(tree, idx):
        return jax.tree.map(lambda x: x[idx], tree)

    def body(c):
        out, slots, slot_args, idx, next_ = c
        slots = step(slots, slot_args)
        live = idx < batch
        fin = terminate(slots) & live
        out = jax.tree.map(lambda o, x: o.at[jnp.where(fin, idx, batch)].set(x, mode="drop"), out, slots)
        new = jnp.where(fin, next_ + jnp.cumsum(fin) - 1, idx)
        new = jnp.where(fin & (new >= batch), batch, new)
        refill = fin & (new < batch)
        src = jnp.minimum(new, batch - 1)
        slots = jax.tree.map(lambda x, y: jnp.where(_expand(refill, x), y, x), slots, take(initial, src))
        slot_args = jax.tree.map(lambda x, y: jnp.where(_expand(refill, x), y, x), slot_args, take(args, src))
        return out, slots, slot_args, new, next_ + jnp.sum(refill)

    def cond(c):
        _, slots, _, idx, next_ = c
        return jnp.any(~terminate(slots) & (idx < batch)) | (next_ < batch)

    idx = jnp.arange(width)
    carry = (initial, take(initial, idx), take(args, idx), idx, jnp.asarray(width))
    # ``out`` starts as the initial states: a problem finished at its start (a non-finite start)
    # is already final there, whether or not a body writes it again.
    return lax.while_loop(cond, body, carry)[0]


def _expand(mask, x):
    return mask.reshape(mask.shape + (1,) * (x.ndim - 1))
