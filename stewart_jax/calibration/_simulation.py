"""Simulated measurements for the calibration study and the sampling plan.

Wang H., Cao X. et al., Infrared and Laser Engineering 47(5), 2018: §3 (simulation
protocol: 8 random target poses, strokes from the nominal model, actual pose from the true
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
from jaxtyping import Array, Bool, Float, PRNGKeyArray

from .._math import euler_angles, rotation_matrix
from ..mechanism._abstract import AbstractMechanism
from ..mechanism._kinematics import forward_kinematics
from ._problem import ARCSEC, UM, CalibrationData

TRAVEL_MM = 1.0
"""Translation travel ±1 mm (Wang et al. 2018, §4)."""
TRAVEL_RAD = float(np.deg2rad(1.0))
"""Rotation travel ±1° (Wang et al. 2018, §4)."""

PLANS = ("paper8", "plan120", "validation42")


def random_poses(
    key: PRNGKeyArray, n: int, travel_mm: float = TRAVEL_MM, travel_rad: float = TRAVEL_RAD
) -> Float[Array, "n 6"]:
    """``n`` poses uniform in the travel box ``±travel_mm`` × ``±travel_rad``."""
    half = jnp.array([travel_mm] * 3 + [travel_rad] * 3)
    return jax.random.uniform(key, (n, 6), minval=-half, maxval=half, dtype=jnp.float64)


def sampling_plan_120(
    inner_mm: float = 0.5, outer_mm: float = 1.0, angle_rad: float = float(np.deg2rad(0.5))
) -> Float[Array, "120 6"]:
    """The 120-pose sampling plan (Wang et al. 2018, §4, Fig. 5, Table 3;
    our reading of its points, see ``docs/conventions.md``).

    15 displacement points — the 8 corners of the ±``inner_mm`` cube, the centre, and
    ±``outer_mm`` on each axis — each combined with the 8 sign combinations of
    ±``angle_rad`` on (φ, θ, ψ).
    """
    corners = list(itertools.product((inner_mm, -inner_mm), repeat=3))
    axes = [tuple(s * outer_mm * (i == k) for k in range(3)) for i in range(3) for s in (1, -1)]
    points = corners + [(0.0, 0.0, 0.0)] + axes
    signs = list(itertools.product((angle_rad, -angle_rad), repeat=3))
    return jnp.array([p + s for p in points for s in signs], dtype=jnp.float64)


def validation_poses(
    key: PRNGKeyArray, n: int = 42, exclude: Float[Array, "k 6"] | None = None
) -> Float[Array, "n 6"]:
    """``n`` poses uniform in the travel, none on the sampling plan (Wang et al. (2018) §4: 42
    non-sampling points). A draw within 1e-6 (mm or rad) of an excluded pose is redrawn."""
    exclude = sampling_plan_120() if exclude is None else exclude
    out = np.empty((0, 6))
    while out.shape[0] < n:
        key, sub = jax.random.split(key)
        cand = np.asarray(random_poses(sub, n))
        dist = np.min(np.max(np.abs(cand[:, None, :] - np.asarray(exclude)[None]), axis=-1), axis=-1)
        out = np.concatenate([out, cand[dist > 1e-6]])
    return jnp.asarray(out[:n])


def plan_poses(plan: str, key: PRNGKeyArray) -> Float[Array, "n 6"]:
    """Target poses of a named plan: ``paper8`` (8 random, §3), ``plan120`` (§4),
    ``validation42`` (42 random off the plan, §4)."""
    if plan == "paper8":
        return random_poses(key, 8)
    if plan == "plan120":
        return sampling_plan_120()
    if plan == "validation42":
        return validation_poses(key, 42)
    raise ValueError(f"unknown plan {plan!r}; choose one of {PLANS}")


class LaserTracker(eqx.Module):
    """A laser tracker measuring target balls fixed on the moving platform (Wang et al. 2018, §4).

    - ``balls``: ``Float[Array, "k 3"]``, ball centres in frame A (mm), ``k ≥ 3``.
    - ``sigma_mm``: standard deviation of each measured coordinate (mm); 3 µm in the paper.
    """

    balls: Float[Array, "k 3"]
    sigma_mm: float = 3e-3


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

    - ``data``: :class:`CalibrationData`, commanded strokes and measured poses.
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
    q = nominal.solve_inverse_kinematics(targets).strokes
    fk = forward_kinematics(actual, q, targets)
    pa = fk.poses
    if tracker is None:
        scale = jnp.array([sigma_um * UM] * 3 + [sigma_arcsec * ARCSEC] * 3)
        measured = pa + scale * jax.random.normal(key, pa.shape, dtype=jnp.float64)
    else:
        keys = jax.random.split(key, pa.shape[0])
        measured = jax.vmap(tracker_measure, in_axes=(0, None, 0, None))(keys, tracker, pa, actual.v0)
    return SimulatedMeasurement(CalibrationData(q, measured), targets, pa, fk.converged)
