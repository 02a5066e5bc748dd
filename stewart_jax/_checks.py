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
    return jnp.asarray(a)


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


def field_array(x: ArrayLike, owner: str, name: str, shape: tuple[int, ...], *, positive: bool = False) -> Array:
    """A mechanism family's array field: float64 with trailing shape ``shape``, finite (and > 0
    with ``positive``), each failure naming ``owner.name``; a tracer (the family built under
    ``jit``/``vmap`` from checked values) passes unchecked."""
    if isinstance(x, jax.core.Tracer):
        return x
    a = np.asarray(x, dtype=np.float64)
    if a.shape[a.ndim - len(shape):] != shape or a.ndim < len(shape):
        raise ValueError(f"{owner}.{name} must have shape {shape}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{owner}.{name} contains NaN or inf: {a.tolist()}")
    if positive and np.any(a <= 0):
        bad = np.flatnonzero(a.reshape(-1) <= 0)
        raise ValueError(f"{owner}.{name} must be positive, got {a.reshape(-1)[bad].tolist()} at {bad.tolist()}")
    return jnp.asarray(a)
