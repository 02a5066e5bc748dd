"""The 6-UPS presets: the Rubin Observatory's camera and M2 hexapods (published strut ends) and
the Stewart platform of the FAST feed cabin (Yin, Jiang, Chen, Yao, "Dynamic modeling of a
cable-driven parallel robot with a Stewart platform for use in FAST", Table 1)."""

from __future__ import annotations

import numpy as np

from . import _pss  # noqa: F401  (the paper's presets first: presets() lists them in registration order)
from ._registry import register_preset
from ._ups import UPSMechanism

# Strut-end coordinates published with the Rubin Observatory's hexapod control software (µm there,
# mm here). The moving ends turn about the pivot; platform = moving − pivot, base = fixed,
# v0 = pivot.
_RUBIN_CAMERA_MOVING = np.array(
    [
        [227600, 653800, -525000],
        [-227600, 653800, -525000],
        [-680000, -129700, -525000],
        [-452300, -524000, -525000],
        [452300, -524000, -525000],
        [680000, -129700, -525000],
    ],
    dtype=np.float64,
) / 1000.0
_RUBIN_CAMERA_FIXED = np.array(
    [
        [472800, 512200, -121400],
        [-472800, 512200, -121400],
        [-680000, 153300, -121400],
        [-207200, -665500, -121400],
        [207200, -665500, -121400],
        [680000, 153300, -121400],
    ],
    dtype=np.float64,
) / 1000.0
_RUBIN_CAMERA_PIVOT = np.array([0.0, 0.0, -2758400.0]) / 1000.0

_RUBIN_M2_MOVING = np.array(
    [
        [0, 1701800, 114300],
        [-1542350, -719210, 114300],
        [1542350, -719210, 114300],
        [790, 1460490, 228600],
        [-1503370, 7660, 228600],
        [1503370, 7660, 228600],
    ],
    dtype=np.float64,
) / 1000.0
_RUBIN_M2_FIXED = np.array(
    [
        [0, 1701800, 607300],
        [-1542350, -719210, 607300],
        [1542350, -719210, 607300],
        [493790, 1460490, 228600],
        [-1256870, -419290, 228600],
        [1256870, -419290, 228600],
    ],
    dtype=np.float64,
) / 1000.0
_RUBIN_M2_PIVOT = np.array([0.0, 0.0, -703000.0]) / 1000.0


@register_preset("rubin_camera")
def rubin_camera() -> UPSMechanism:
    """The Rubin Observatory camera hexapod (published strut ends, µm → mm): readings ±14.1 mm;
    travel |x|, |y| ≤ 11.4 mm, |z| ≤ 13.1 mm, tilts ≤ 0.36°, rotation about z ≤ 0.10°."""
    return UPSMechanism(
        _RUBIN_CAMERA_FIXED,
        _RUBIN_CAMERA_MOVING - _RUBIN_CAMERA_PIVOT,
        _RUBIN_CAMERA_PIVOT,
        stroke_limits=(-14.1, 14.1),
        travel=(11.4, 11.4, 13.1, float(np.deg2rad(0.36)), float(np.deg2rad(0.36)), float(np.deg2rad(0.10))),
    )


@register_preset("rubin_m2")
def rubin_m2() -> UPSMechanism:
    """The Rubin Observatory M2 hexapod (three axial and three lateral struts; published strut
    ends, µm → mm): travel |x|, |y| ≤ 10.5 mm, |z| ≤ 8.9 mm, tilts ≤ 0.175°, z rotation ≤ 0.05°.
    No stroke limits are published with the coordinates; none are set."""
    return UPSMechanism(
        _RUBIN_M2_FIXED,
        _RUBIN_M2_MOVING - _RUBIN_M2_PIVOT,
        _RUBIN_M2_PIVOT,
        travel=(10.5, 10.5, 8.9, float(np.deg2rad(0.175)), float(np.deg2rad(0.175)), float(np.deg2rad(0.05))),
    )


def _joint_circle(radius: float, short_edge: float, centres_deg: tuple[float, ...], first_low: bool) -> np.ndarray:
    """Six joints on a circle in three pairs of chord ``short_edge`` about ``centres_deg`` (m);
    the numbering of the FAST Stewart platform's joints (see :func:`fast_stewart`)."""
    alpha = np.arcsin(short_edge / (2.0 * radius))
    c = np.deg2rad(np.asarray(centres_deg))
    if first_low:
        ang = np.array([c[0] - alpha, c[0] + alpha, c[1] - alpha, c[1] + alpha, c[2] - alpha, c[2] + alpha])
    else:
        ang = np.array([c[0] + alpha, c[1] - alpha, c[1] + alpha, c[2] - alpha, c[2] + alpha, c[0] - alpha])
    return np.stack([radius * np.cos(ang), radius * np.sin(ang), np.zeros(6)], axis=-1)


FAST_STEWART_TRAVEL = (10.0, 10.0, 10.0, float(np.deg2rad(1.0)), float(np.deg2rad(1.0)), float(np.deg2rad(1.0)))
"""The ``fast_stewart`` preset's travel (our choice; Yin et al. give none): ±10 mm on each axis,
the 0.01 m amplitude of the lower platform's motion in their simulation, and ±1° on each angle,
the angular travel the library uses for the 2018 calibration study."""


@register_preset("fast_stewart")
def fast_stewart() -> UPSMechanism:
    """The Stewart platform in the FAST feed cabin (Yin, Jiang, Chen, Yao, Table 1) as a 6-UPS
    in mm: base = the upper platform B fixed to the cabin, joints on ``r_B = 2.0 m`` in pairs
    ``(B6, B1), (B2, B3), (B4, B5)`` of chord 0.349 m centred at 30°, 150°, 270°; platform = the
    lower platform P, joints on ``r_P = 0.98 m`` in pairs ``(P1, P2), (P3, P4), (P5, P6)`` of
    chord 0.256 m centred at 90°, 210°, 330° (the layout the cable-robot model uses); v0 = P's
    origin in B, ``(0, 0, h)`` with ``h = −1.7 m``. Struts ≈ 2.0 m. Travel:
    :data:`FAST_STEWART_TRAVEL`. No limits are given in the paper; none are set."""
    return UPSMechanism(
        _joint_circle(2.0, 0.349, (30.0, 150.0, 270.0), first_low=False) * 1e3,
        _joint_circle(0.98, 0.256, (90.0, 210.0, 330.0), first_low=True) * 1e3,
        (0.0, 0.0, -1700.0),
        travel=FAST_STEWART_TRAVEL,
    )
