"""Independent NumPy references shared by the tests (nothing here calls the library)."""

import numpy as np


def rotation(angles):
    """``Rz(ψ)·Ry(θ)·Rx(φ)`` (Wang et al. 2018, eq. 1) from the elementary rotations; ``angles``
    ``(..., 3)`` = ``[φ, θ, ψ]`` in radians → ``(..., 3, 3)``."""
    a = np.asarray(angles, dtype=float)
    f, t, p = a[..., 0], a[..., 1], a[..., 2]
    o, z = np.ones_like(f), np.zeros_like(f)
    rx = np.stack([o, z, z, z, np.cos(f), -np.sin(f), z, np.sin(f), np.cos(f)], -1).reshape(*f.shape, 3, 3)
    ry = np.stack([np.cos(t), z, np.sin(t), z, o, z, -np.sin(t), z, np.cos(t)], -1).reshape(*f.shape, 3, 3)
    rz = np.stack([np.cos(p), -np.sin(p), z, np.sin(p), np.cos(p), z, z, z, o], -1).reshape(*f.shape, 3, 3)
    return rz @ ry @ rx
