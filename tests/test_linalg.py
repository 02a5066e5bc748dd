"""The element-wise small-matrix routines (``stewart_jax._linalg``) against NumPy's LAPACK, and
the reason they exist: a jitted program of batched LAPACK calls can deadlock XLA's CPU thread
pool with jaxlib 0.10 (see the module's NOTE)."""

from __future__ import annotations

import re

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from stewart_jax import _linalg

RNG = np.random.default_rng(12)
A = RNG.normal(size=(40, 6, 6))
SPD = A @ np.swapaxes(A, -1, -2) + 0.05 * np.eye(6)


def test_cholesky_and_lower_inverse_match_lapack():
    low = np.asarray(_linalg.cholesky(jnp.asarray(SPD)))
    np.testing.assert_allclose(low, np.linalg.cholesky(SPD), rtol=0, atol=1e-12 * np.abs(low).max())
    inv = np.asarray(_linalg.lower_inverse(jnp.asarray(low)))
    np.testing.assert_allclose(inv @ low, np.broadcast_to(np.eye(6), inv.shape), atol=1e-12)
    np.testing.assert_allclose(inv, np.linalg.inv(np.linalg.cholesky(SPD)), rtol=1e-9, atol=1e-12)
    assert np.all(np.triu(inv, 1) == 0.0)


def test_cholesky_of_a_matrix_that_is_not_positive_definite_is_nan():
    bad = SPD[:2].copy()
    bad[1] -= 2 * np.linalg.eigvalsh(bad[1])[-1] * np.eye(6)  # indefinite
    low = np.asarray(_linalg.cholesky(jnp.asarray(bad)))
    assert np.all(np.isfinite(low[0])) and np.isnan(low[1]).any()


def test_solve_pivots_and_matches_lapack():
    a = A.copy()
    a[:20, 0, 0] = 0.0  # elimination without row exchanges divides by zero here ...
    a[20:, 0, 0] = 1e-14  # ... and loses every digit here, although the matrices are well conditioned
    assert np.linalg.cond(a).max() < 1e4
    b = RNG.normal(size=(40, 6))
    x = np.asarray(_linalg.solve(jnp.asarray(a), jnp.asarray(b)))
    want = np.linalg.solve(a, b[..., None])[..., 0]
    np.testing.assert_allclose(x, want, rtol=0, atol=1e-10 * np.abs(want).max())


def test_solve_derivative_matches_lapacks():
    b = jnp.asarray(RNG.normal(size=(40, 6)))
    da = jnp.asarray(RNG.normal(size=A.shape))
    _, ours = jax.jvp(lambda m: _linalg.solve(m, b), (jnp.asarray(A),), (da,))
    _, ref = jax.jvp(lambda m: jnp.linalg.solve(m, b[..., None])[..., 0], (jnp.asarray(A),), (da,))
    np.testing.assert_allclose(np.asarray(ours), np.asarray(ref), rtol=1e-7, atol=1e-9)


def test_exactly_singular_solve_is_not_finite():
    a = A[:1].copy()
    a[0, :, 3] = 0.0  # a zero column: a zero pivot however the rows are exchanged
    assert not np.all(np.isfinite(np.asarray(_linalg.solve(jnp.asarray(a), jnp.ones((1, 6))))))


def batched_lapack_calls(lowered_text: str) -> list[str]:
    """The LAPACK custom calls of a lowered program that act on a batch of matrices (the ones
    jaxlib 0.10 may split over the thread pool)."""
    calls = re.findall(r"custom_call @(lapack_\w+)\(.*?num_batch_dims = \"(\d+)\"", lowered_text)
    return [name for name, nb in calls if int(nb) > 0]


def test_the_batched_lapack_detector_sees_jnp_linalg():
    """The check used on the discrepancy kernels finds what it looks for (and not the unbatched
    case), so that its empty answer there means something."""
    a = jnp.asarray(SPD)
    assert batched_lapack_calls(jax.jit(jnp.linalg.cholesky).lower(a).as_text())
    assert not batched_lapack_calls(jax.jit(jnp.linalg.cholesky).lower(a[0]).as_text())
    assert not batched_lapack_calls(jax.jit(_linalg.cholesky).lower(a).as_text())


@pytest.mark.parametrize("n", [1, 3, 8])
def test_other_orders(n):
    a = RNG.normal(size=(5, n, n)) + 3 * np.eye(n)
    b = RNG.normal(size=(5, n))
    np.testing.assert_allclose(np.asarray(_linalg.solve(jnp.asarray(a), jnp.asarray(b))),
                               np.linalg.solve(a, b[..., None])[..., 0], rtol=1e-10, atol=1e-12)
    spd = a @ np.swapaxes(a, -1, -2)
    np.testing.assert_allclose(np.asarray(_linalg.cholesky(jnp.asarray(spd))), np.linalg.cholesky(spd),
                               rtol=1e-10, atol=1e-12)
