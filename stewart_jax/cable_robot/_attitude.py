"""Cabin attitude of the FAST feed support: the smallest tilt that makes a position feasible,
the attitude that maximises the least cable tension, and the tilt that points the feed axis
along the focal-surface normal.

Model: Yin J., Jiang P., Chen M., Yao R., *Dynamic modeling of a cable-driven parallel robot
with a Stewart platform for use in FAST* (elastic catenaries, eqs. 6–13; cabin statics,
eqs. 57–58; Table 1). The paper states the attitude only at the centre (``G R_C = I``, eq. 61);
off-centre the attitude is a free choice, and at its fourth Table 2 position a level cabin has
no equilibrium. Feasibility is :func:`~stewart_jax.cable_robot.cabin_statics`'s physical one.

- ``"level"``: ``G R_C = I``.
- ``"towards-centre"``: the cabin's z axis points at the reflector's centre of curvature, so the
  feed axis (−z_C) lies along the focal surface's normal, as the real cabin follows the focal
  surface; the rotation is the smallest one taking ``e_z`` to that direction (no yaw).
- ``"smallest-tilt"``: the least tilt (angle between z_C and the vertical; rotation about a
  horizontal axis, no yaw) at which the position is feasible. NOTE: feasibility is a yes/no
  answer of a Newton solve that fails outside the region, so there is no gradient to follow:
  for ``n_axes`` tilt axes the tilt is scanned on a grid, bracketed, and bisected (one
  batch of static solves per step); the best axis is then refined on a finer fan
  of axes about it. The result is the boundary of the feasible set to ``tol`` rad.
- ``"max-min-tension"``: the rotation vector (3 components, yaw included) maximising the least
  tension along any cable over the feasible attitudes, by a batched derivative-free pattern
  search on the exact catenary statics (see :func:`max_min_tension_attitude`).
"""

from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ._system import FastParams, check_position
from ._workspace import CURVATURE_CENTRE, CableStatics, assess

ATTITUDES = ("level", "towards-centre", "smallest-tilt", "max-min-tension")
"""The attitude readings :func:`solve_attitude` knows."""


class AttitudeSolution(NamedTuple):
    """An attitude and the statics there.

    - ``kind``: one of :data:`ATTITUDES`.
    - ``R``: ``Float[Array, "3 3"]``, ``G R_C``; ``rotation_vector``: ``Float[Array, "3"]``
      (rad, G); ``tilt_rad``: angle between the cabin's z axis and the vertical.
    - ``statics``: :class:`~stewart_jax.cable_robot.CableStatics` at that attitude.
    - ``found``: the search found a feasible attitude (always ``True`` for the fixed readings,
      whose feasibility is in ``statics.feasible``).
    - ``evaluations``: static solves used.
    """

    kind: str
    R: Float[Array, "3 3"]
    rotation_vector: Float[Array, "3"]
    tilt_rad: float
    statics: CableStatics
    found: bool
    evaluations: int


def rotation_from_vector(phi: Float[ArrayLike, "... 3"]) -> Float[Array, "... 3 3"]:
    """Rodrigues' formula, ``exp([φ]×)``, with its series below 1e-8 rad."""
    phi = jnp.asarray(phi, jnp.float64)
    a2 = jnp.sum(phi * phi, axis=-1)[..., None, None]
    small = a2 < 1e-16
    a = jnp.sqrt(jnp.where(small, 1.0, a2))
    s = jnp.where(small, 1.0 - a2 / 6.0, jnp.sin(a) / a)
    c = jnp.where(small, 0.5 - a2 / 24.0, (1.0 - jnp.cos(a)) / jnp.where(small, 1.0, a2))
    x, y, z = phi[..., 0], phi[..., 1], phi[..., 2]
    o = jnp.zeros_like(x)
    K = jnp.stack([jnp.stack([o, -z, y], -1), jnp.stack([z, o, -x], -1),
                   jnp.stack([-y, x, o], -1)], -2)
    return jnp.eye(3) + s * K + c * (K @ K)


def _rotation_vector(R: np.ndarray) -> np.ndarray:
    R = np.asarray(R, dtype=np.float64)
    angle = np.arccos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0))
    v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if angle < 1e-8:
        return 0.5 * v
    return angle / (2.0 * np.sin(angle)) * v


def tilt_angle(R: Float[ArrayLike, "... 3 3"]) -> Float[Array, "..."]:
    """Angle (rad) between the cabin's z axis ``G R_C e_z`` and the vertical."""
    return jnp.arccos(jnp.clip(jnp.asarray(R)[..., 2, 2], -1.0, 1.0))


def towards_centre_attitude(position: Float[ArrayLike, "3"]) -> Float[Array, "3 3"]:
    """The smallest rotation taking ``e_z`` to the unit vector from ``position`` to the centre
    of curvature (0, 0, 300) m: the cabin's z axis along the focal surface's normal."""
    check_position(position)
    d = jnp.asarray(CURVATURE_CENTRE) - jnp.asarray(position, jnp.float64)
    u = d / jnp.linalg.norm(d)
    axis = jnp.cross(jnp.array([0.0, 0.0, 1.0]), u)
    s = jnp.linalg.norm(axis)
    angle = jnp.arctan2(s, u[2])
    return rotation_from_vector(jnp.where(s > 1e-15, axis / jnp.where(s > 0, s, 1.0), 0.0) * angle)


BATCH = 24
"""Attitudes tried per iteration of the searches."""


def _batch(params, position, Rs, floor, clearance) -> list[CableStatics]:
    return [assess(params, position, R, tension_floor=floor, clearance=clearance)
            for R in np.asarray(Rs, dtype=np.float64)]


def _rotations(phi: np.ndarray) -> np.ndarray:
    # Rodrigues' formula in NumPy for the searches' candidate attitudes (no JAX dispatch or
    # per-shape compilation on this host-side path).
    phi = np.atleast_2d(np.asarray(phi, dtype=np.float64))
    a = np.linalg.norm(phi, axis=-1)[:, None, None]
    K = np.zeros((len(phi), 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -phi[:, 2], phi[:, 1], -phi[:, 0]
    K = K - np.swapaxes(K, 1, 2)
    safe = np.where(a > 1e-8, a, 1.0)
    s = np.where(a > 1e-8, np.sin(safe) / safe, 1.0 - a**2 / 6.0)
    c = np.where(a > 1e-8, (1.0 - np.cos(safe)) / safe**2, 0.5 - a**2 / 24.0)
    return np.eye(3) + s * K + c * (K @ K)


def _tilts(psi, theta):
    axis = np.stack([np.cos(psi), np.sin(psi), np.zeros_like(psi)], -1)
    return _rotations(axis * np.asarray(theta)[..., None])


def _single(params, position, R, floor, clearance) -> CableStatics:
    return assess(params, position, R, tension_floor=floor, clearance=clearance)


def _fixed(params, position, kind, R, floor, clearance) -> AttitudeSolution:
    st = _single(params, position, R, floor, clearance)
    return AttitudeSolution(kind, R, jnp.asarray(_rotation_vector(np.asarray(R))),
                            float(tilt_angle(R)), st, True, 1)


def smallest_feasible_tilt(
    params: FastParams,
    position: Float[ArrayLike, "3"],
    *,
    tension_floor: float = 0.0,
    clearance: float = 0.0,
    max_tilt: float = np.deg2rad(45.0),
    n_axes: int = 24,
    n_tilts: int = 15,
    n_fan: int = 8,
    tol: float = 1e-5,
) -> AttitudeSolution:
    """Least tilt (rad) about a horizontal axis that makes ``position`` feasible (see the
    module docstring for the search: ``n_axes`` axes, tilt grid of ``n_tilts`` steps up to
    ``max_tilt``, a fan of ``n_fan`` axes about the best, bisection to ``tol`` rad).
    ``found = False`` when no tilt up to ``max_tilt`` is feasible about any axis tried; then
    ``R`` is the identity."""
    check_position(position)
    if not (0 < max_tilt < np.pi / 2) or n_axes < 4 or n_tilts < 2 or n_fan < 2 or not tol > 0:
        raise ValueError("need 0 < max_tilt < π/2, n_axes ≥ 4, n_tilts ≥ 2, n_fan ≥ 2, tol > 0")
    evaluations = 0

    def feasible(psi, theta):
        nonlocal evaluations
        evaluations += len(psi)
        return np.array([bool(st.feasible) for st in _batch(params, position, _tilts(psi, theta),
                                                             tension_floor, clearance)])

    def bisect(psi, lo, hi):
        # lo infeasible, hi feasible, per axis
        while np.max(hi - lo) > tol:
            mid = 0.5 * (lo + hi)
            ok = feasible(psi, mid)
            hi, lo = np.where(ok, mid, hi), np.where(ok, lo, mid)
        return hi

    if feasible(np.zeros(1), np.zeros(1))[0]:
        return _fixed(params, position, "smallest-tilt", jnp.eye(3), tension_floor, clearance)
    psi = np.arange(n_axes) * 2.0 * np.pi / n_axes
    step = max_tilt / n_tilts
    for j in range(1, n_tilts + 1):
        ok = feasible(psi, np.full(n_axes, j * step))
        if ok.any():
            break
    if not ok.any():
        eye = jnp.eye(3)
        st = _single(params, position, eye, tension_floor, clearance)
        return AttitudeSolution("smallest-tilt", eye, jnp.zeros(3), 0.0, st, False, evaluations)
    # bisect the axes feasible on the grid, then a fan of axes about the best of them
    cand = psi[ok]
    hi = np.full(len(cand), j * step)
    theta = bisect(cand, hi - step, hi)
    best_psi, best_theta = cand[np.argmin(theta)], float(np.min(theta))
    fan = best_psi + np.linspace(-1.0, 1.0, n_fan) * (2.0 * np.pi / n_axes)
    lo = np.full(n_fan, max(best_theta - step, 0.0))
    hi = np.full(n_fan, best_theta + step)
    good = feasible(fan, hi) & ~feasible(fan, lo)
    theta = np.full(n_fan, np.inf)
    if good.any():
        theta[good] = bisect(fan[good], lo[good], hi[good])
    k = int(np.argmin(theta))
    if not np.isfinite(theta[k]) or theta[k] > best_theta:
        psi_k, theta_k = best_psi, best_theta
    else:
        psi_k, theta_k = fan[k], float(theta[k])
    phi = np.array([np.cos(psi_k), np.sin(psi_k), 0.0]) * theta_k
    R = jnp.asarray(_rotations(phi)[0])
    st = _single(params, position, R, tension_floor, clearance)
    return AttitudeSolution("smallest-tilt", R, jnp.asarray(phi), theta_k, st,
                            bool(st.feasible), evaluations + 1)


def _directions(rng: np.random.Generator) -> np.ndarray:
    # BATCH unit directions: ± the three axes and ± 9 random unit vectors.
    v = rng.normal(size=((BATCH - 6) // 2, 3))
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    return np.concatenate([np.eye(3), -np.eye(3), v, -v])


def max_min_tension_attitude(
    params: FastParams,
    position: Float[ArrayLike, "3"],
    start: Float[ArrayLike, "3 3"] | None = None,
    *,
    tension_floor: float = 0.0,
    clearance: float = 0.0,
    step: float = np.deg2rad(4.0),
    tol: float = 1e-5,
    max_iterations: int = 300,
    restarts: int = 2,
    seed: int = 0,
) -> AttitudeSolution:
    """Attitude (rotation vector, yaw included) maximising the least tension along any cable
    among feasible attitudes, from ``start`` (an attitude at which ``position`` is feasible;
    by default the best of level, towards-centre and smallest tilt). ``found = False`` when
    no feasible start exists.

    NOTE: the least tension is the minimum of six smooth functions, with a kink where two
    cables tie (at the optimum three or four do), and outside the feasible set there is no
    equilibrium to differentiate. So the search is derivative-free: a batched pattern search
    that tries ``BATCH`` moves of length ``step`` (± the axes and random directions drawn
    afresh each iteration, so that no ridge between tied cables stops it for good), keeps the
    best feasible one, and halves ``step`` when none improves, down to ``tol`` rad, then
    restarts ``restarts`` times with a quarter of the first step. One iteration is one batch
    of ``BATCH`` static solves. The optimum is a ridge where three to five cables tie; the
    search finds its value to about 1 % (seeds differ by that much).
    """
    check_position(position)
    pos = jnp.asarray(position, jnp.float64)
    evaluations = 0
    if start is None:
        cands = [jnp.eye(3), towards_centre_attitude(pos)]
        sts = _batch(params, pos, jnp.stack(cands), tension_floor, clearance)
        evaluations += 2
        ok = np.array([bool(st.feasible) for st in sts])
        if not ok.any():
            sm = smallest_feasible_tilt(params, pos, tension_floor=tension_floor,
                                        clearance=clearance)
            evaluations += sm.evaluations
            if not sm.found:
                return sm._replace(kind="max-min-tension", evaluations=evaluations)
            start = sm.R
        else:
            margin = np.where(ok, [float(st.slack_margin_n) for st in sts], -np.inf)
            start = cands[int(np.argmax(margin))]
    phi = _rotation_vector(np.asarray(start))
    best_st = _single(params, pos, _rotations(phi)[0], tension_floor, clearance)
    best = float(np.min(np.asarray(best_st.min_tension_n))) if bool(best_st.feasible) else -np.inf
    rng = np.random.default_rng(seed)
    step0 = step
    for _ in range(max_iterations):
        if step < tol:
            # restart once from the best point with a quarter of the first step: a ridge
            # between tied cables can stop the first descent short of the optimum
            if step0 < tol or restarts == 0:
                break
            restarts, step = restarts - 1, 0.25 * step0
        trial = phi + step * _directions(rng)
        sts = _batch(params, pos, _rotations(trial), tension_floor, clearance)
        evaluations += BATCH
        value = np.array([np.min(np.asarray(st.min_tension_n)) if bool(st.feasible) else -np.inf
                          for st in sts])
        k = int(np.argmax(value))
        if value[k] > best:
            best, phi, best_st = float(value[k]), trial[k], sts[k]
        else:
            step *= 0.5
    R = jnp.asarray(_rotations(phi)[0])
    return AttitudeSolution("max-min-tension", R, jnp.asarray(phi), float(tilt_angle(R)), best_st,
                            bool(best_st.feasible), evaluations)


def solve_attitude(
    params: FastParams,
    position: Float[ArrayLike, "3"],
    kind: str = "level",
    *,
    tension_floor: float = 0.0,
    clearance: float = 0.0,
) -> AttitudeSolution:
    """The attitude of reading ``kind`` (one of :data:`ATTITUDES`) at ``position``, and the
    statics there."""
    if kind not in ATTITUDES:
        raise ValueError(f"attitude must be one of {ATTITUDES}, got {kind!r}")
    check_position(position)
    if kind == "level":
        return _fixed(params, position, kind, jnp.eye(3), tension_floor, clearance)
    if kind == "towards-centre":
        return _fixed(params, position, kind, towards_centre_attitude(position), tension_floor,
                      clearance)
    if kind == "smallest-tilt":
        return smallest_feasible_tilt(params, position, tension_floor=tension_floor,
                                      clearance=clearance)
    return max_min_tension_attitude(params, position, tension_floor=tension_floor,
                                    clearance=clearance)


def attitude_summary(sol: AttitudeSolution) -> dict:
    """Plain-Python summary of an :class:`AttitudeSolution` (for JSON)."""
    return {
        "kind": sol.kind,
        "rotation_vector_rad": [float(v) for v in np.asarray(sol.rotation_vector)],
        "tilt_deg": float(np.rad2deg(sol.tilt_rad)),
        "R": np.asarray(sol.R).tolist(),
        "found": bool(sol.found),
        "feasible": bool(sol.statics.feasible),
    }
