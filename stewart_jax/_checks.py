"""Input checks shared by every layer: shapes, finiteness and angle units, raised before tracing.

A check runs on concrete values only; under ``jax.jit`` (a tracer) only the static shape is
checked, so the same function serves eager callers and jitted internals.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike

# Angles in the library are radians. A pose angle beyond this is taken as a unit mistake
# (degrees given where radians are expected): no optics hexapod tilts by ~29°, and the Euler
# parametrisation itself is singular at θ = ±90°.
MAX_ANGLE_RAD = 0.5


def is_traced(tree) -> bool:
    """Whether any leaf of ``tree`` is a JAX tracer (so its values cannot be checked)."""
    return any(isinstance(x, jax.core.Tracer) for x in jax.tree_util.tree_leaves(tree))


def array_module(*xs):
    """NumPy when every ``x`` is concrete, else ``jax.numpy``: for the small reshapes, slices and
    concatenations of a family's fields (:func:`on_host`).

    NOTE: outside ``jit`` each such JAX operation compiles a program of its own per shape (tracing,
    lowering and a cache lookup, about 10 ms each); on concrete values NumPy does the same
    operation exactly, and :func:`to_device` hands the result back as a JAX array."""
    return jnp if is_traced(xs) else np


def on_host(*xs):
    """``(np, xs as NumPy arrays)`` when every ``x`` is concrete (``None`` kept), else ``(jnp, xs)``
    (:func:`array_module`; a NumPy function given a JAX array would call the array's own method,
    an eager JAX operation)."""
    xp = array_module(*xs)
    return xp, tuple(x if xp is jnp or x is None else np.asarray(x) for x in xs)


def to_device(x) -> Array:
    """``x`` as a JAX array without compiling anything (``jnp.asarray`` of a NumPy array stages a
    copy program per shape; ``jax.device_put`` transfers it)."""
    return x if isinstance(x, jax.Array) else jax.device_put(x)


def check_array(x: ArrayLike, name: str, last_dim: int) -> Array:
    """Float64 array with last axis ``last_dim``, finite where the value is concrete."""
    if isinstance(x, jax.core.Tracer):
        if x.shape[-1:] != (last_dim,):
            raise ValueError(f"{name} must have a last axis of {last_dim}, got shape {x.shape}")
        return x
    a = np.asarray(x, dtype=np.float64)
    if a.shape[-1:] != (last_dim,):
        raise ValueError(f"{name} must have a last axis of {last_dim}, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        idx = tuple(int(i) for i in np.argwhere(~np.isfinite(a))[0])
        raise ValueError(f"{name} contains NaN or inf (first at index {idx})")
    return to_device(a)


def check_poses(poses: ArrayLike, name: str = "poses") -> Array:
    """Validate poses ``[dx, dy, dz, φ, θ, ψ]`` (mm, rad): shape, finiteness, radians."""
    p = check_array(poses, name, last_dim=6)
    if not isinstance(p, jax.core.Tracer):
        worst = float(np.max(np.abs(np.asarray(p)[..., 3:]), initial=0.0))
        if worst > MAX_ANGLE_RAD:
            raise ValueError(
                f"{name}: an angle of {worst:.4g} rad ({np.degrees(worst):.4g}°) exceeds "
                f"{MAX_ANGLE_RAD} rad; the library takes radians — were degrees passed?"
            )
    return p


def valid_poses(poses: Array) -> Array:
    """``Bool[Array, "..."]``: every component finite and every angle within ``MAX_ANGLE_RAD``;
    traceable, so that jitted kinematics report a NaN or degree-valued pose as unreachable."""
    return jnp.all(jnp.isfinite(poses), axis=-1) & jnp.all(jnp.abs(poses[..., 3:]) <= MAX_ANGLE_RAD, axis=-1)


def field_array(
    x: ArrayLike, owner: str, name: str, shape: tuple[int, ...], *, positive: bool = False, unit: str | None = None
) -> Array:
    """A mechanism family's array field: float64 with trailing shape ``shape``, finite (and > 0
    with ``positive``), each failure naming ``owner.name`` and its ``unit``; a tracer (the family
    built under ``jit``/``vmap`` from checked values) passes unchecked."""
    if isinstance(x, jax.core.Tracer):
        return x
    return to_device(field_numpy(x, owner, name, shape, positive=positive, unit=unit))


def field_numpy(
    x: ArrayLike, owner: str, name: str, shape: tuple[int, ...], *, positive: bool = False, unit: str | None = None,
    item: str = "leg",
) -> np.ndarray:
    """:func:`field_array`'s checks on a concrete value, returned as NumPy; a failing entry is
    named as the ``item`` it is, counted from 1.

    NOTE: checks stay in NumPy: under ``jit`` even ``jnp.asarray`` of a constant is staged out as
    a tracer, which a NumPy conversion would then reject."""
    in_unit = f" ({unit})" if unit else ""
    a = field_numbers(x, owner, name)
    if a.shape[a.ndim - len(shape):] != shape or a.ndim < len(shape):
        raise ValueError(f"{owner}.{name} must have shape {shape}{in_unit}, got {a.shape}")
    if positive and np.any(a <= 0):
        bad = np.flatnonzero(a.reshape(-1) <= 0)
        raise ValueError(f"{owner}.{name} must be positive{in_unit}: {item}(s) {(bad + 1).tolist()} have "
                         f"{a.reshape(-1)[bad].tolist()} (all: {a.tolist()})")
    return a


def field_numbers(x, owner: str, name: str) -> np.ndarray:
    """``x`` as a finite float64 NumPy array, or an error naming ``owner.name``."""
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{owner}.{name} must be numbers, got {x!r}") from None
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{owner}.{name} contains NaN or inf: {a.tolist()}")
    return a


def field_travel(x, owner: str, lengths: tuple[str, ...], angles: tuple[str, ...]) -> tuple[float, ...]:
    """A family's travel half-widths: the ``lengths`` (mm) then the ``angles`` (rad), every one
    positive, the angles checked against degrees."""
    a = field_numbers(x, owner, "travel")
    n = len(lengths) + len(angles)
    if a.shape != (n,) or not np.all(a > 0):
        raise ValueError(f"{owner}.travel must be {n} positive half-widths ({', '.join(lengths)} in mm, "
                         f"{', '.join(angles)} in rad), got {a.tolist()}")
    if np.any(a[len(lengths):] > MAX_ANGLE_RAD):
        raise ValueError(f"{owner}.travel angles are radians; {a[len(lengths):].tolist()} looks like degrees")
    return tuple(float(v) for v in a)
