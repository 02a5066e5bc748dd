"""The box contract of :func:`~stewart_jax.optimise.minimise`, checked before anything is
traced: finite bounds with ``lower <= upper`` (equal bounds fix a coordinate, as pycma's
``fixed_variables``), and a scalar real objective."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array

from ._result import RESULTS, OptimiseResult


def nan_to_inf(fn):
    """``fn`` with NaN values replaced by +inf (and the value cast to a scalar array)."""

    def wrapped(x):
        f = jnp.reshape(jnp.asarray(fn(x)), ())
        return jnp.where(jnp.isnan(f), jnp.inf, f)

    return wrapped


def fixed_coordinates(lower: Array, upper: Array) -> np.ndarray | None:
    """The indices of the free coordinates (``lower < upper``), or ``None`` where every
    coordinate is free or the bounds are traced (then the solver samples the box as given)."""
    if isinstance(lower, jax.core.Tracer) or isinstance(upper, jax.core.Tracer):
        return None
    is_free = np.asarray(lower) < np.asarray(upper)
    return None if is_free.all() else np.flatnonzero(is_free)


def all_fixed(fn, x):
    """The result where the box is one point: one evaluation, no search."""
    f = nan_to_inf(fn)(x)
    status = RESULTS.where(jnp.isfinite(f), RESULTS.successful, RESULTS.nonfinite)
    one = jnp.asarray(1, jnp.int32)
    return OptimiseResult(x, f, one, status, f[None], one[None])


def check_box(lower: Array, upper: Array) -> None:
    """Raise, naming the first offending coordinate, unless every bound is finite and
    ``lower <= upper`` (a coordinate with ``lower == upper`` is fixed; skipped for traced
    bounds, which cannot be read before tracing)."""
    if isinstance(lower, jax.core.Tracer) or isinstance(upper, jax.core.Tracer):
        return
    lo, hi = np.asarray(lower), np.asarray(upper)
    for name, v in (("lower", lo), ("upper", hi)):
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise ValueError(f"the box must be finite: {name}[{bad[0]}] = {v[bad[0]]} ({bad.size} coordinate(s) "
                             "not finite); a population method samples the box, so every bound must be a number")
    bad = np.flatnonzero(~(lo <= hi))
    if bad.size:
        i = bad[0]
        raise ValueError(f"the box is empty: lower[{i}] = {lo[i]} is above upper[{i}] = {hi[i]} "
                         f"({bad.size} coordinate(s)); every lower bound must be at or below its upper bound "
                         "(equal bounds fix a coordinate)")


def check_scalar_objective(fn, x: Array) -> None:
    """Raise unless ``fn(x)`` returns one real number (checked on shapes only, before tracing)."""
    leaves = jax.tree.leaves(jax.eval_shape(fn, x))
    shapes = [leaf.shape for leaf in leaves]
    if len(shapes) != 1 or shapes[0] not in ((), (1,)):
        raise ValueError(f"the objective must return one number per point (a scalar), got shape(s) {shapes}; "
                         "for a residual vector use least_squares, or return its sum of squares")
    dtype = leaves[0].dtype
    if not (jnp.issubdtype(dtype, jnp.floating) or jnp.issubdtype(dtype, jnp.integer)):
        raise ValueError(f"the objective must return a real number, got dtype {dtype}")
