"""Lowest layer, numerics shared by every package: the pose rotation and its inverse.

Wang H., Cao X. et al., "Improved cuckoo calibration method of space telescope secondary mirror
adjusting mechanism", Infrared and Laser Engineering 47(5), 2018, eq. 1 defines the rotation
``T = Rz(ψ)·Ry(θ)·Rx(φ)`` of a pose ``[dx, dy, dz, φ, θ, ψ]``; the cable robot of Yin et al.
uses the same Z-Y-X convention for its cabin and platform.
"""

from __future__ import annotations

import jax.numpy as jnp
from jaxtyping import Array, Float


def rotation_matrix(angles: Float[Array, "... 3"]) -> Float[Array, "... 3 3"]:
    """``T = Rz(ψ)·Ry(θ)·Rx(φ)`` for ``angles = [φ, θ, ψ]`` (Wang et al. 2018, eq. 1).

    NOTE: eq. 1 as printed has ``sψ·sθ·sφ − cψ·cφ`` in element (2,2); the product of the
    elementary rotations gives ``+ cψ·cφ``, which is what is built here (a typo in the paper).
    """
    phi, theta, psi = angles[..., 0], angles[..., 1], angles[..., 2]
    cf, sf = jnp.cos(phi), jnp.sin(phi)
    ct, st = jnp.cos(theta), jnp.sin(theta)
    cp, sp = jnp.cos(psi), jnp.sin(psi)
    rows = [
        [cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf],
        [sp * ct, sp * st * sf + cp * cf, sp * st * cf - cp * sf],
        [-st, ct * sf, ct * cf],
    ]
    return jnp.stack([jnp.stack(r, axis=-1) for r in rows], axis=-2)


def euler_angles(rotation: Float[Array, "... 3 3"]) -> Float[Array, "... 3"]:
    """Inverse of :func:`rotation_matrix` for ``|θ| < π/2``: ``[φ, θ, ψ]``."""
    phi = jnp.arctan2(rotation[..., 2, 1], rotation[..., 2, 2])
    theta = -jnp.arcsin(jnp.clip(rotation[..., 2, 0], -1.0, 1.0))
    psi = jnp.arctan2(rotation[..., 1, 0], rotation[..., 0, 0])
    return jnp.stack([phi, theta, psi], axis=-1)
