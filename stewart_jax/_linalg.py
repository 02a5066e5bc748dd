"""Small dense linear algebra (a few rows) over any leading batch axes, in element-wise
operations: a Cholesky factor, the inverse of a lower-triangular matrix, and a solve by
Gaussian elimination with partial pivoting (Golub G. H., Van Loan C. F., *Matrix Computations*,
4th ed. (2013), Algorithms 4.2.1 (Cholesky), 3.1.3 (forward substitution) and 3.4.1 (Gaussian
elimination with partial pivoting)).

NOTE (why not ``jnp.linalg``; jaxlib 0.10.0 to 0.11.0, tested with 0.10.2). On CPU,
``jnp.linalg.cholesky``, ``solve`` and ``jax.scipy.linalg.solve_triangular`` of a batch of
matrices call jaxlib's LAPACK kernels. From jaxlib 0.10.0 (jax commit bfd9e1fbd3, "Add support
for parallelizing lapack invocations on the batch dimension") those split a batch whose
estimated cost exceeds 2·10⁵ flops (e.g. more than ~930 6 × 6 LU factorisations) into chunks,
schedule the chunks on XLA's intra-op thread pool and block the pool thread they run on until
the chunks are done. When XLA runs as many such calls at once as the pool has threads (two
independent solves of one program on a 2-core machine), every pool thread waits for chunks that
no thread is left to run: the program never finishes (main thread in ``BlockUntilReady``, all
threads idle). jax removed the parallel path from
open-source builds after the 0.11.0 release (jax commit 859992407d, "Don't try to parallelize
LAPACK kernels in opensource builds"); until a jaxlib with that commit is the oldest supported,
keep these routines. The discrepancy workflow's batched fits hit it on sessions of a few
hundred poses (``benchmarks/lapack_deadlock.py`` reproduces it); these routines keep such
programs free of LAPACK calls. A batch of unrelated tiny solves is slower this way than in
LAPACK (about 2× for 6 × 6), but inside the discrepancy fits, where the Jacobians dominate, the
difference is within the timing noise. The order ``n`` is unrolled at trace time: meant for ``n``
up to ~10.
"""

from __future__ import annotations

import jax.numpy as jnp
from jaxtyping import Array, Float


def cholesky(a: Float[Array, "... n n"]) -> Float[Array, "... n n"]:
    """The lower Cholesky factor ``L`` (``a = L Lᵀ``) of symmetric positive definite matrices;
    NaN in the columns from the first non-positive pivot on (as ``jnp.linalg.cholesky``)."""
    n = a.shape[-1]
    rows = jnp.arange(n)
    low = jnp.zeros_like(a)
    for j in range(n):
        v = a[..., :, j] - jnp.sum(low * low[..., j : j + 1, :], axis=-1)
        col = v / jnp.sqrt(v[..., j : j + 1])
        low = low.at[..., :, j].set(jnp.where(rows >= j, col, 0.0))
    return low


def lower_inverse(low: Float[Array, "... n n"]) -> Float[Array, "... n n"]:
    """``L⁻¹`` of lower-triangular matrices, by forward substitution of ``L X = I`` row by row."""
    n = low.shape[-1]
    eye = jnp.eye(n, dtype=low.dtype)
    x = jnp.zeros_like(low)
    for i in range(n):
        acc = eye[i] - jnp.sum(low[..., i, :, None] * x, axis=-2)  # the rows k < i of x are set
        x = x.at[..., i, :].set(acc / low[..., i, i, None])
    return x


def solve(a: Float[Array, "... n n"], b: Float[Array, "... n"]) -> Float[Array, "... n"]:
    """``a⁻¹ b`` for square matrices ``a`` and vectors ``b``, by Gaussian elimination with
    partial pivoting. As LAPACK's, no check: an exactly singular ``a`` gives non-finite values, a
    nearly singular one large errors (the caller's matrices are known to be well conditioned)."""
    n = a.shape[-1]
    rows = jnp.arange(n)
    m = jnp.concatenate([a, b[..., None]], axis=-1)  # the augmented matrix [a | b]
    for j in range(n):
        pivot = jnp.argmax(jnp.where(rows >= j, jnp.abs(m[..., :, j]), -1.0), axis=-1)
        at_pivot = (rows == pivot[..., None])[..., None]  # (..., n, 1)
        row_p = jnp.sum(jnp.where(at_pivot, m, 0.0), axis=-2)
        m = jnp.where(at_pivot, m[..., j : j + 1, :], m)  # row j into the pivot's place ...
        m = m.at[..., j, :].set(row_p)  # ... and the pivot row into row j
        factor = jnp.where(rows > j, m[..., :, j] / m[..., j : j + 1, j], 0.0)
        m = m - factor[..., :, None] * m[..., j : j + 1, :]
    x = jnp.zeros(m.shape[:-1], m.dtype)
    for i in reversed(range(n)):
        x = x.at[..., i].set((m[..., i, n] - jnp.sum(m[..., i, :n] * x, axis=-1)) / m[..., i, i])
    return x
