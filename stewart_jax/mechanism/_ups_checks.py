"""The 6-UPS geometry file's own checks: layouts no strut hexapod can have, refused naming the
leg and the value, and warnings for plausible unit slips (metres or micrometres in a file of mm,
radians typed for degrees, limits that cut the reachable travel by more than
:data:`TRAVEL_CUT_FACTOR`). :meth:`UPSMechanism.from_dict` calls them around the generic
:func:`~stewart_jax.mechanism._registry.check_geometry`."""

from __future__ import annotations

import itertools
import warnings
from typing import TYPE_CHECKING

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array

from .._units import TRAVEL_MM, TRAVEL_RAD

if TYPE_CHECKING:
    from ._ups import UPSMechanism

TRAVEL_CUT_FACTOR = 4.0
"""A file whose limits shrink the reachable travel box more than this factor (against the same
geometry without limits) gets a warning naming the limit and the likely unit slip."""


# ---- geometry-file checks -----------------------------------------------------------------------


def check_layout(m: UPSMechanism) -> None:
    """Physically impossible layouts, refused naming the leg and the value (the generic
    :func:`~stewart_jax.mechanism._registry.check_geometry` follows: duplicate legs, the zero
    pose, the Jacobian)."""
    base, platform, v0 = np.asarray(m.base), np.asarray(m.platform), np.asarray(m.v0)
    lengths0 = np.asarray(m.lengths0)
    strut = platform + v0 - base
    length = np.linalg.norm(strut, axis=-1)
    size = max(float(np.max(np.linalg.norm(np.concatenate([base, platform + v0]), axis=-1))), 1e-300)
    short = np.flatnonzero(length <= 1e-9 * size)
    if short.size:
        i = int(short[0])
        raise ValueError(f"strut {i + 1} has zero length at the zero pose: its base joint {base[i].tolist()} mm is "
                         f"its platform joint + v0 {(platform[i] + v0).tolist()} mm")
    bad = np.flatnonzero(lengths0 <= 0)
    if bad.size:
        raise ValueError(f"lengths0 (the strut lengths at zero reading) must be > 0 mm: strut(s) "
                         f"{(bad + 1).tolist()} have {lengths0[bad].tolist()} mm")
    if np.all(np.abs(strut[:, 2]) <= 1e-9 * length):
        raise ValueError("every strut is horizontal at the zero pose (no z component): the struts cannot hold "
                         "the platform up (dz is free); check the z coordinates of base and platform")
    for side, pts in (("base", base), ("platform", platform)):
        centred = pts - pts.mean(axis=0)
        sv = np.linalg.svd(centred, compute_uv=False)
        if sv[1] <= 1e-9 * max(sv[0], 1e-300):
            raise ValueError(f"the six {side} joints lie on one line ({pts.tolist()} mm): the struts cannot "
                             "stop the platform turning about it; check the file's joint coordinates")


def warn_unit_slips(m: UPSMechanism) -> None:
    """Warnings for plausible unit slips: a mechanism of centimetre size (metres in a file
    labelled mm) or of a hundred metres (µm), and limits that cut the travel by more than
    :data:`TRAVEL_CUT_FACTOR` (radians typed for degrees, metres for mm)."""
    joints = np.concatenate([np.asarray(m.base), np.asarray(m.platform) + np.asarray(m.v0)])
    size = float(np.max(np.linalg.norm(joints, axis=-1)))
    if size < 20.0:
        warnings.warn(f"6-UPS geometry: the joints lie within {size:.3g} mm of the origin — a hexapod of "
                      f"{size / 10:.2g} cm? Lengths are mm: a file in metres needs every length × 1000",
                      UserWarning, stacklevel=3)
    elif size > 1e5:
        warnings.warn(f"6-UPS geometry: joints {size / 1e3:.3g} m from the origin — lengths are mm: a file in "
                      "µm needs every length ÷ 1000", UserWarning, stacklevel=3)
    if m.stroke_limits is not None:
        span = max(hi - lo for lo, hi in m.stroke_limits)
        longest = float(np.max(np.asarray(m.lengths0)))
        if span > 2 * longest:
            warnings.warn(f"6-UPS geometry: stroke_limits spanning {span:.4g} mm, more than twice the longest strut "
                          f"({longest:.4g} mm): micrometres typed where mm are expected?", UserWarning, stacklevel=3)
    if m.stroke_limits is None and m.joint_angle_limit is None:
        return
    full = _reachable_scale(type(m)(m.base, m.platform, m.v0, m.lengths0, travel=m.travel))
    limited = _reachable_scale(m)
    if limited * TRAVEL_CUT_FACTOR >= full:
        return
    causes = []
    if m.joint_angle_limit is not None:
        deg = float(np.rad2deg(min(m.joint_angle_limit)))
        only_angle = type(m)(m.base, m.platform, m.v0, m.lengths0, joint_angle_limit=m.joint_angle_limit,
                                  travel=m.travel)
        if _reachable_scale(only_angle) * TRAVEL_CUT_FACTOR < full:
            causes.append(f"joint_angle_limits of {deg:.3g}° (radians typed where degrees are expected? "
                          f"{deg:.3g} rad = {np.rad2deg(deg):.3g}°)" if deg < 3.0 else
                          f"joint_angle_limits of {deg:.3g}°")
    if m.stroke_limits is not None:
        only_stroke = type(m)(m.base, m.platform, m.v0, m.lengths0, stroke_limits=m.stroke_limits,
                                   travel=m.travel)
        if _reachable_scale(only_stroke) * TRAVEL_CUT_FACTOR < full:
            span = min(hi - lo for lo, hi in m.stroke_limits)
            causes.append(f"stroke_limits spanning {span:.3g} mm (metres typed where mm are expected? "
                          f"{span:.3g} m = {span * 1e3:.3g} mm)" if span < 1.0 else
                          f"stroke_limits spanning {span:.3g} mm")
    cut = f"{full / limited:.3g}×" if limited > 0 else "to nothing"
    warnings.warn(
        f"6-UPS geometry: the limits cut the reachable travel {cut} (more than {TRAVEL_CUT_FACTOR:g}×) against "
        f"the same struts without limits: {'; '.join(causes) or 'the limits together'}", UserWarning, stacklevel=3)


_SCALES = 2.0 ** (-np.arange(41) / 4.0)  # 1 … 1/1024 in steps of 19%


@jax.jit
def _reachable_jit(m: UPSMechanism, poses: Array) -> Array:
    return m.solve_inverse_kinematics(poses).reachable  # jitted: one compilation, not one per op


def _reachable_scale(m: UPSMechanism) -> float:
    """The largest ``s`` of :data:`_SCALES` for which the corners and axis ends of ``s`` × the
    travel box (default ±1 mm / ±1°) are reachable, and those of every smaller ``s`` (0 if none):
    one batched inverse kinematics (the bisection of ``reachable_travel`` would compile op by
    op at each file load)."""
    half = m.travel_half_widths
    half = np.array([TRAVEL_MM] * 3 + [TRAVEL_RAD] * 3) if half is None else half
    unit = np.concatenate([np.array(list(itertools.product((1.0, -1.0), repeat=6))),
                           np.eye(6), -np.eye(6)]) * half
    ok = np.asarray(_reachable_jit(m, jnp.asarray(_SCALES[:, None, None] * unit))).all(axis=1)
    bad = np.flatnonzero(~ok)
    last_bad = bad.max() if bad.size else -1
    return float(_SCALES[last_bad + 1]) if last_bad + 1 < len(_SCALES) else 0.0
