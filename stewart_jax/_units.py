"""Units and the labels of pose components in reports.

The library computes in mm and radians; reports and file columns give translations in µm and
rotations in arc-seconds.
"""

from __future__ import annotations

import numpy as np
from jaxtyping import ArrayLike

ARCSEC = np.pi / (180.0 * 3600.0)
"""One arc-second in radians."""
UM = 1e-3
"""One micrometre in mm."""

COMPONENTS = ("dx", "dy", "dz", "phi", "theta", "psi")
"""Pose components in report order; the first three in µm, the last three in arc-seconds."""


def error_in_report_units(errors: ArrayLike) -> np.ndarray:
    """Pose errors ``[..., 6]`` (mm, rad) → (µm, ″)."""
    e = np.asarray(errors, dtype=np.float64)
    return np.concatenate([e[..., :3] / UM, e[..., 3:] / ARCSEC], axis=-1)
