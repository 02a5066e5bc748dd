"""From a table's offsets to the library's poses and the struts' length changes.

Rubin Observatory, *MTHexapod CSC* (``lsst-ts/ts_mthexapod``, ``simple_hexapod.py``, 2020–2025):
the controller's position ``(x, y, z, u, v, w)`` is in µm and degrees about the pivot, and its
inverse kinematics turns the moving strut ends about the pivot by ``Rx(u)·Ry(v)·Rz(w)``. The
library's pose ``[dx, dy, dz, φ, θ, ψ]`` is in mm and radians with ``T = Rz(ψ)·Ry(θ)·Rx(φ)``
(Wang et al. 2018, eq. 1). :func:`offsets_to_poses` converts exactly, through the rotation matrix
(the two orders differ by the products of the angles: 0.07 µm of strut length at the v7 camera
table's offsets, 39 µm at the corners of the camera hexapod's tilt travel).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._math import euler_angles
from ..mechanism._abstract import AbstractMechanism


def _axis_rotation(angle: Float[Array, "..."], axis: int) -> Float[Array, "... 3 3"]:
    c, s = jnp.cos(angle), jnp.sin(angle)
    one, zero = jnp.ones_like(angle), jnp.zeros_like(angle)
    if axis == 0:
        rows = [[one, zero, zero], [zero, c, -s], [zero, s, c]]
    elif axis == 1:
        rows = [[c, zero, s], [zero, one, zero], [-s, zero, c]]
    else:
        rows = [[c, -s, zero], [s, c, zero], [zero, zero, one]]
    return jnp.stack([jnp.stack(r, axis=-1) for r in rows], axis=-2)


def rubin_rotation(uvw_deg: Float[Array, "... 3"]) -> Float[Array, "... 3 3"]:
    """``Rx(u)·Ry(v)·Rz(w)``, the controller's rotation of its angles ``u, v, w`` (degrees)."""
    a = jnp.deg2rad(jnp.asarray(uvw_deg, dtype=jnp.float64))
    return _axis_rotation(a[..., 0], 0) @ _axis_rotation(a[..., 1], 1) @ _axis_rotation(a[..., 2], 2)


def offsets_to_poses(offsets: ArrayLike) -> Float[Array, "... 6"]:
    """Controller positions ``[x_um, y_um, z_um, u_deg, v_deg, w_deg]`` as library poses
    ``[dx, dy, dz, φ, θ, ψ]`` (mm, rad; ``Rz(ψ)·Ry(θ)·Rx(φ)`` is the controller's rotation)."""
    o = jnp.asarray(offsets, dtype=jnp.float64)
    return jnp.concatenate([o[..., :3] * 1e-3, euler_angles(rubin_rotation(o[..., 3:]))], axis=-1)


def poses_to_offsets(poses: ArrayLike) -> Float[Array, "... 6"]:
    """Library poses (mm, rad) as controller positions (µm, deg): the inverse of
    :func:`offsets_to_poses` for angles below 90°."""
    from .._math import rotation_matrix

    p = jnp.asarray(poses, dtype=jnp.float64)
    r = rotation_matrix(p[..., 3:])
    # Rx(u)·Ry(v)·Rz(w): r[0, 2] = sin v, r[1, 2] = −sin u·cos v, r[0, 1] = −cos v·sin w
    v = jnp.arcsin(jnp.clip(r[..., 0, 2], -1.0, 1.0))
    u = jnp.arctan2(-r[..., 1, 2], r[..., 2, 2])
    w = jnp.arctan2(-r[..., 0, 1], r[..., 0, 0])
    return jnp.concatenate([p[..., :3] * 1e3, jnp.rad2deg(jnp.stack([u, v, w], axis=-1))], axis=-1)


@jax.jit
def _strut_solution(mechanism: AbstractMechanism, offsets: Float[Array, "n 6"]):
    sol = mechanism.solve_inverse_kinematics(offsets_to_poses(offsets))
    zero = mechanism.solve_inverse_kinematics(jnp.zeros(6))
    return (sol.readings - zero.readings) * 1e3, sol.margin, sol.reachable


def strut_changes(mechanism: AbstractMechanism, offsets: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The struts' length changes (µm) of the compensated poses ``offsets`` (controller positions,
    µm and deg, about the zero pose) from the zero pose, by the mechanism's inverse kinematics,
    with each pose's margins (``(..., 6)``, mm; negative where a leg is beyond a limit) and
    reachability (``(...)``). The reading unit must be mm (a strut hexapod or a 6-PSS)."""
    if mechanism.reading_unit != "mm":
        raise ValueError(f"strut length changes need a mechanism whose readings are lengths (mm); a "
                         f"{mechanism.family} reads {mechanism.reading_unit}")
    o = np.asarray(offsets, dtype=np.float64)
    flat = o.reshape(-1, 6)
    dq, margin, ok = _strut_solution(mechanism, jnp.asarray(flat))
    return (np.asarray(dq).reshape(o.shape), np.asarray(margin).reshape(o.shape),
            np.asarray(ok).reshape(o.shape[:-1]))


def travel_limits(mechanism: AbstractMechanism) -> np.ndarray | None:
    """The mechanism's travel as controller half-widths ``[x_um, y_um, z_um, u_deg, v_deg,
    w_deg]``, or ``None`` where the geometry states none."""
    half = mechanism.travel_half_widths
    if half is None:
        return None
    half = np.asarray(half, dtype=np.float64)
    return np.concatenate([half[:3] * 1e3, np.rad2deg(half[3:])])
