"""Units and the labels of pose components, parameters and readings in reports.

The library computes in mm and radians; reports and file columns give translations in µm and
rotations in arc-seconds. A mechanism's calibration parameters and actuator readings carry their
own units (:attr:`~stewart_jax.mechanism.AbstractMechanism.param_units`,
:attr:`~stewart_jax.mechanism.AbstractMechanism.reading_unit`): a length in mm is reported in
µm, an angle (rad, or mrad where a family stores it so) in µrad.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from jaxtyping import ArrayLike

ARCSEC = np.pi / (180.0 * 3600.0)
"""One arc-second in radians."""
UM = 1e-3
"""One micrometre in mm."""

TRAVEL_MM = 1.0
"""The default translation travel, ±1 mm (Wang et al. 2018, §4): the pose box of simulated
measurements and of the unit-slip checks when a mechanism publishes no travel."""
TRAVEL_RAD = float(np.deg2rad(1.0))
"""The default rotation travel, ±1° (Wang et al. 2018, §4)."""

COMPONENTS = ("dx", "dy", "dz", "phi", "theta", "psi")
"""Pose components in report order; the first three in µm, the last three in arc-seconds."""

LENGTH_UNITS = ("mm",)
"""Library units of a length parameter or reading."""
ANGLE_UNITS = {"rad": 1.0, "mrad": 1e-3}
"""Library units of an angle parameter or reading → its size in rad."""
READING_UNITS = ("mm", "rad")
"""An actuator reading is a length (a slider's stroke, a strut's change of length) or an angle
(a crank's turn)."""

_REPORT = {"mm": ("µm", 1e3), "rad": ("µrad", 1e6), "mrad": ("µrad", 1e3)}
_ASCII = {"µm": "um", "µrad": "urad"}


def check_unit(unit: str, what: str, allowed: Sequence[str] = ("mm", "rad", "mrad")) -> str:
    """``unit`` if it is one of ``allowed``, else a ``ValueError`` naming ``what``."""
    if unit not in allowed:
        raise ValueError(f"{what}: unit {unit!r} is not one of {list(allowed)}")
    return unit


def is_angle(unit: str) -> bool:
    """Whether a library unit measures an angle (rad, mrad) rather than a length (mm)."""
    return check_unit(unit, "is_angle") in ANGLE_UNITS


def report_unit(unit: str) -> str:
    """The report unit of a library unit: µm for mm, µrad for rad and mrad."""
    return _REPORT[check_unit(unit, "report_unit")][0]


def report_factor(unit: str) -> float:
    """Library unit → report unit: 1e3 for mm → µm and mrad → µrad, 1e6 for rad → µrad."""
    return _REPORT[check_unit(unit, "report_factor")][1]


def ascii_unit(unit: str) -> str:
    """A unit as it appears in JSON keys and CSV column names: ``µm`` → ``um``, ``µrad`` →
    ``urad`` (others unchanged)."""
    return _ASCII.get(unit, unit)


def per_parameter(units: Sequence[str], length: float, angle_mrad: float) -> np.ndarray:
    """Per parameter of units ``units``, ``length`` (mm) for a length and ``angle_mrad`` (mrad)
    for an angle, each expressed in the parameter's own unit: the size of a perturbation or of a
    feasible box's half-width (a millimetre and a milliradian are the same number by default)."""
    sizes = {"mm": length, "mrad": angle_mrad, "rad": angle_mrad * 1e-3}  # exact for mm and mrad
    return np.array([sizes[check_unit(u, "per_parameter")] for u in units], dtype=np.float64)


def error_in_report_units(errors: ArrayLike) -> np.ndarray:
    """Pose errors ``[..., 6]`` (mm, rad) → (µm, ″)."""
    e = np.asarray(errors, dtype=np.float64)
    return np.concatenate([e[..., :3] / UM, e[..., 3:] / ARCSEC], axis=-1)
