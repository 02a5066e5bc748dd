"""Simulated measurements for the calibration study and the sampling plan.

Wang H., Cao X. et al., Infrared and Laser Engineering 47(5), 2018: §3 (simulation
protocol: 8 random target poses, readings from the nominal model, actual pose from the true
model, Gaussian pose noise), §4 (travel ±1 mm / ±1°, the 120-pose sampling plan of Fig. 5 and
Table 3, 42 validation poses, a laser tracker with 3 µm error seeing 3 target balls).
The paper's pose noise "±0.1 µm, ±0.1°" is read as Gaussian σ = 0.1 µm and σ = 0.1″ (0.1° is
larger than the errors the paper reports after calibration); ``docs/conventions.md`` lists this
and the plan's points.

All functions are pure and take explicit PRNG keys; vmap them over keys for Monte Carlo.
"""

from __future__ import annotations

import itertools
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, PRNGKeyArray

from .._math import euler_angles, rotation_matrix
from .._units import TRAVEL_MM, TRAVEL_RAD
from ..mechanism._abstract import AbstractMechanism
from ..mechanism._kinematics import forward_kinematics, solve_inverse_kinematics
from ._problem import ARCSEC, UM, CalibrationData

PLANS = ("paper8", "plan120", "validation42")


def random_poses(
    key: PRNGKeyArray, n: int, travel_mm: float = TRAVEL_MM, travel_rad: float = TRAVEL_RAD, *,
    half: ArrayLike | None = None,
) -> Float[Array, "n 6"]:
    """``n`` poses uniform in the travel box ``±travel_mm`` × ``±travel_rad``, or in ``±half``
    (six half-widths, mm and rad, e.g. :func:`reachable_travel` of a mechanism)."""
    half = jnp.array([travel_mm] * 3 + [travel_rad] * 3) if half is None else jnp.asarray(half, jnp.float64)
    return jax.random.uniform(key, (n, 6), minval=-half, maxval=half, dtype=jnp.float64)


def sampling_plan_120(
    inner_mm: float = 0.5, outer_mm: float = 1.0, angle_rad: float = float(np.deg2rad(0.5)), *,
    half: ArrayLike | None = None,
) -> Float[Array, "120 6"]:
    """The 120-pose sampling plan (Wang et al. 2018, §4, Fig. 5, Table 3;
    our reading of its points, see ``docs/conventions.md``).

    15 displacement points — the 8 corners of the ±``inner_mm`` cube, the centre, and
    ±``outer_mm`` on each axis — each combined with the 8 sign combinations of
    ±``angle_rad`` on (φ, θ, ψ). With ``half`` (a mechanism's travel, six half-widths) the
    same plan scaled per axis: corners at ``half/2``, axis points at ``half``, angles ``half/2``
    (for the paper's ±1 mm / ±1° travel this is the plan above).
    """
    if half is None:
        inner, outer, angle = (inner_mm,) * 3, (outer_mm,) * 3, (angle_rad,) * 3
    else:
        h = np.asarray(half, dtype=np.float64)
        if h.shape != (6,) or not np.all(h > 0):
            raise ValueError(f"half must be six positive half-widths (mm, rad), got {h.tolist()}")
        inner, outer, angle = tuple(0.5 * h[:3]), tuple(h[:3]), tuple(0.5 * h[3:])
    corners = [tuple(sg * v for sg, v in zip(signs, inner, strict=True))
               for signs in itertools.product((1, -1), repeat=3)]
    axes = [tuple(s * outer[k] * (i == k) for k in range(3)) for i in range(3) for s in (1, -1)]
    points = corners + [(0.0, 0.0, 0.0)] + axes
    signs = [tuple(sg * v for sg, v in zip(sgn, angle, strict=True)) for sgn in itertools.product((1, -1), repeat=3)]
    return jnp.array([p + s for p in points for s in signs], dtype=jnp.float64)


def validation_poses(
    key: PRNGKeyArray, n: int = 42, exclude: Float[Array, "k 6"] | None = None, *,
    half: ArrayLike | None = None,
) -> Float[Array, "n 6"]:
    """``n`` poses uniform in the travel (or ``±half``), none on the sampling plan (Wang et al.
    (2018) §4: 42 non-sampling points). A draw within 1e-6 (mm or rad) of an excluded pose is
    redrawn."""
    exclude = sampling_plan_120(half=half) if exclude is None else exclude
    out = np.empty((0, 6))
    while out.shape[0] < n:
        key, sub = jax.random.split(key)
        cand = np.asarray(random_poses(sub, n, half=half))
        dist = np.min(np.max(np.abs(cand[:, None, :] - np.asarray(exclude)[None]), axis=-1), axis=-1)
        out = np.concatenate([out, cand[dist > 1e-6]])
    return jnp.asarray(out[:n])


def plan_poses(plan: str, key: PRNGKeyArray, half: ArrayLike | None = None) -> Float[Array, "n 6"]:
    """Target poses of a named plan: ``paper8`` (8 random, §3), ``plan120`` (§4),
    ``validation42`` (42 random off the plan, §4); inside ``±half`` when given (a mechanism's
    :func:`reachable_travel`), else the paper's ±1 mm / ±1°."""
    if plan == "paper8":
        return random_poses(key, 8, half=half)
    if plan == "plan120":
        return sampling_plan_120(half=half)
    if plan == "validation42":
        return validation_poses(key, 42, half=half)
    raise ValueError(f"unknown plan {plan!r}; choose one of {PLANS}")


def reachable_travel(mechanism: AbstractMechanism, *, iterations: int = 40) -> np.ndarray:
    """Six half-widths (mm, rad) of a travel box whose corners and axis points the mechanism
    reaches: its ``travel_half_widths`` (default the paper's ±1 mm / ±1°) scaled by the largest
    factor s ≤ 1 for which all 64 corners and 12 axis end points are reachable (bisection on s).

    NOTE: a published travel is usually a per-axis limit, not a box: the Rubin camera hexapod
    reaches each axis's limit alone but none of the box's corners (they need ~34 mm of strut
    reading against ±14.1 mm). Plans and random poses drawn from the scaled box stay reachable
    for a reachable set that contains the box's convex hull of corners, which holds for these
    small travels; the simulation still checks every pose (forward kinematics status).
    """
    half = mechanism.travel_half_widths
    half = np.array([TRAVEL_MM] * 3 + [TRAVEL_RAD] * 3) if half is None else np.asarray(half, np.float64)
    corners = np.array(list(itertools.product((1.0, -1.0), repeat=6)))
    axes = np.concatenate([np.eye(6), -np.eye(6)])
    unit = np.concatenate([corners, axes]) * half

    def ok(scale: float) -> bool:
        return bool(np.all(np.asarray(solve_inverse_kinematics(mechanism, jnp.asarray(scale * unit)).reachable)))

    if ok(1.0):
        return half
    lo, hi = 0.0, 1.0
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    if lo == 0.0:
        raise ValueError(f"{mechanism.family} mechanism: no pose box around the zero pose is reachable")
    return lo * half


class LaserTracker(eqx.Module):
    """A laser tracker measuring target balls fixed on the moving platform (Wang et al. 2018, §4).

    - ``balls``: ``Float[Array, "k 3"]``, ball centres in frame A (mm), ``k ≥ 3``.
    - ``sigma_mm``: standard deviation of each measured coordinate (mm); 3 µm in the paper.
    """

    balls: Float[Array, "k 3"]
    sigma_mm: float = 3e-3


def perturbed(
    mechanism: AbstractMechanism, key: PRNGKeyArray, sigma_mm: float, sigma_mrad: float | None = None
) -> AbstractMechanism:
    """A "true" mechanism for a simulation: every calibration parameter moved by an independent
    Gaussian error of σ = ``sigma_mm`` (mm) for a length and ``sigma_mrad`` (mrad; default the
    same number as ``sigma_mm``) for an angle, each in the parameter's own unit
    (:meth:`~stewart_jax.mechanism.AbstractMechanism.natural_scales`)."""
    sigma_mrad = sigma_mm if sigma_mrad is None else sigma_mrad
    if not (sigma_mm >= 0 and sigma_mrad >= 0):
        raise ValueError(f"sigma_mm and sigma_mrad must be >= 0 (mm, mrad), got {sigma_mm}, {sigma_mrad}")
    u = mechanism.params
    scale = jnp.asarray(mechanism.natural_scales(sigma_mm, sigma_mrad))
    return mechanism.with_params(u + scale * jax.random.normal(key, u.shape, dtype=jnp.float64))


def tracker_for(mechanism: AbstractMechanism, sigma_um: float = 3.0) -> LaserTracker:
    """Three target balls on the moving platform, 120° apart on the circle of its joints and at
    their mean height in frame A (for the paper's mechanism: 100 mm from A's z axis at 90°, 210°
    and 330°, 90 mm above A's origin)."""
    layout = mechanism.tracker_layout()
    if layout is not None:
        return default_tracker(*layout, sigma_um=sigma_um)
    joints = np.asarray(mechanism.moving_joints(jnp.zeros(6))) - np.asarray(mechanism.v0)
    radius = float(np.mean(np.linalg.norm(joints[:, :2], axis=-1)))
    return default_tracker(radius, float(np.mean(joints[:, 2])), sigma_um)


def default_tracker(
    radius_mm: float = 100.0, height_mm: float = 90.0, sigma_um: float = 3.0
) -> LaserTracker:
    """Three balls ``radius_mm`` from A's z axis, 120° apart, ``height_mm`` above A's origin
    (the paper gives no layout; this is our default), each coordinate measured with σ = ``sigma_um``."""
    ang = np.deg2rad([90.0, 210.0, 330.0])
    balls = np.stack([radius_mm * np.cos(ang), radius_mm * np.sin(ang), np.full(3, height_mm)], -1)
    return LaserTracker(jnp.asarray(balls), sigma_um * UM)


def rigid_fit(
    body: Float[Array, "k 3"], measured: Float[Array, "k 3"]
) -> tuple[Float[Array, "3 3"], Float[Array, "3"]]:
    """Least-squares ``R, t`` with ``measured ≈ R·body + t`` (Kabsch / SVD)."""
    cb = jnp.mean(body, axis=0)
    cm = jnp.mean(measured, axis=0)
    h = (body - cb).T @ (measured - cm)
    u, _, vt = jnp.linalg.svd(h)
    d = jnp.sign(jnp.linalg.det(vt.T @ u.T))
    rot = vt.T @ jnp.diag(jnp.array([1.0, 1.0, d])) @ u.T
    return rot, cm - rot @ cb


def tracker_measure(
    key: PRNGKeyArray, tracker: LaserTracker, pose: Float[Array, "6"], v0: Float[Array, "3"]
) -> Float[Array, "6"]:
    """Measured pose: the balls at ``T·b + d + v0`` seen with Gaussian noise, then the
    rigid fit of the measured points to the balls' platform coordinates."""
    pts = tracker.balls @ rotation_matrix(pose[3:]).T + pose[:3] + v0
    noisy = pts + tracker.sigma_mm * jax.random.normal(key, pts.shape, dtype=jnp.float64)
    rot, t = rigid_fit(tracker.balls, noisy)
    return jnp.concatenate([t - v0, euler_angles(rot)])


class SimulatedMeasurement(NamedTuple):
    """A simulated calibration run (Wang et al. 2018, §3).

    - ``data``: :class:`CalibrationData`, commanded readings and measured poses.
    - ``targets``: ``Float[Array, "m 6"]``, the commanded target poses ``P0``.
    - ``true_poses``: ``Float[Array, "m 6"]``, the poses the true mechanism reached ``Pa``.
    - ``converged``: ``Bool[Array, "m"]``, forward kinematics of the true mechanism converged.
    """

    data: CalibrationData
    targets: Float[Array, "m 6"]
    true_poses: Float[Array, "m 6"]
    converged: Bool[Array, " m"]


def simulate_measurements(
    key: PRNGKeyArray,
    nominal: AbstractMechanism,
    actual: AbstractMechanism,
    targets: Float[Array, "m 6"],
    sigma_um: float = 0.1,
    sigma_arcsec: float = 0.1,
    tracker: LaserTracker | None = None,
) -> SimulatedMeasurement:
    """Wang et al. (2018) §3: readings ``q = IK(P0, u_nominal)`` (no control error), actual pose
    ``Pa = FK(q, u_actual)``, measured pose ``Pa`` + noise.

    Pose noise is Gaussian with σ = ``sigma_um`` µm per translation and ``sigma_arcsec`` ″ per
    angle (our reading of the paper's "±0.1 µm, ±0.1°"). With a ``tracker`` the pose is
    instead measured through it (3 balls, rigid fit) and the two sigmas are not used.
    """
    q = solve_inverse_kinematics(nominal, targets).readings
    fk = forward_kinematics(actual, q, targets)
    pa = fk.poses
    if tracker is None:
        scale = jnp.array([sigma_um * UM] * 3 + [sigma_arcsec * ARCSEC] * 3)
        measured = pa + scale * jax.random.normal(key, pa.shape, dtype=jnp.float64)
    else:
        keys = jax.random.split(key, pa.shape[0])
        measured = jax.vmap(tracker_measure, in_axes=(0, None, 0, None))(keys, tracker, pa, actual.v0)
    return SimulatedMeasurement(CalibrationData(q, measured), targets, pa, fk.converged)
