"""Simulated laser-tracker runs for the points model of :mod:`._points`: a default placement of
the tracker and of its targets, and the measurements of a true mechanism at commanded poses with
the tracker's anisotropic noise."""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, PRNGKeyArray

from .._math import rotation_matrix
from ..mechanism._abstract import AbstractMechanism
from ..mechanism._kinematics import forward_kinematics
from ._points import DEFAULT_TRACKER_SIGMA, PointData, TrackerTargets, tracker_covariance


def default_registration(mechanism: AbstractMechanism) -> tuple[np.ndarray, np.ndarray]:
    """A tracker placement for simulations: the platform's zero-pose centre 2.9 m from the head
    (2.5 m, 1.2 m, −0.9 m in the tracker's frame), the frame turned by (0.3°, −0.2°, 115°) from B."""
    rot = np.asarray(rotation_matrix(jnp.radians(jnp.array([0.3, -0.2, 115.0]))))
    centre = np.array([2500.0, 1200.0, -900.0])
    return rot, centre - rot @ np.asarray(mechanism.v0)


def default_targets(mechanism: AbstractMechanism) -> TrackerTargets:
    """Targets for simulations: six on the platform (two rings of three at its joints' radius and
    mean height, one ring 10 % inside and 20 mm higher) and four on the base (on a circle 10 %
    outside its joints, one 50 mm up)."""
    joints = np.asarray(mechanism.moving_joints(jnp.zeros(6))) - np.asarray(mechanism.v0)
    fixed = mechanism.fixed_joints()
    lower = np.asarray(mechanism.moving_joints(jnp.zeros(6)) if fixed is None else fixed)
    radius = float(np.mean(np.linalg.norm(joints[:, :2], axis=-1)))
    height = float(np.mean(joints[:, 2]))
    ang = np.radians([90.0, 210.0, 330.0])
    ring = np.stack([np.cos(ang), np.sin(ang), np.zeros(3)], -1)
    platform = np.concatenate([ring * radius + [0, 0, height], np.roll(ring, 1, 0) @ _rz(60) * 0.9 * radius
                               + [0, 0, height + 20.0]])
    b_radius = 1.1 * float(np.mean(np.linalg.norm(lower[:, :2], axis=-1)))
    b_height = float(np.mean(lower[:, 2]))
    bang = np.radians([0.0, 90.0, 180.0, 270.0])
    base = np.stack([b_radius * np.cos(bang), b_radius * np.sin(bang), np.full(4, b_height) + [0, 0, 0, 50.0]], -1)
    return TrackerTargets(tuple(f"P{i + 1}" for i in range(6)), platform, tuple(f"B{i + 1}" for i in range(4)), base)


def _rz(deg: float) -> np.ndarray:
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, s, 0], [-s, c, 0], [0, 0, 1.0]])


class SimulatedPoints(NamedTuple):
    """A simulated tracker run: ``data`` (:class:`PointData`), the poses the true mechanism
    reached (``true_poses``, mm, rad), the commanded ``targets`` and the true registration."""

    data: PointData
    true_poses: np.ndarray
    commanded: np.ndarray
    rotation: np.ndarray
    translation: np.ndarray


def simulate_points(
    key: PRNGKeyArray,
    nominal: AbstractMechanism,
    true: AbstractMechanism,
    targets: TrackerTargets,
    commanded: Float[Array, "m 6"],
    *,
    range_um: float = DEFAULT_TRACKER_SIGMA[0],
    across_um_per_m: float = DEFAULT_TRACKER_SIGMA[1],
    registration: tuple[np.ndarray, np.ndarray] | None = None,
    visible: float = 0.7,
) -> SimulatedPoints:
    """Readings ``q = IK(P0, nominal)``, reached poses ``FK(q, true)``, and each platform target seen
    with probability ``visible`` (at least one per pose) at its true position in the tracker's frame
    plus the anisotropic tracker noise; every base reference measured once the same way."""
    if not 0 < visible <= 1:
        raise ValueError(f"visible must be a probability in (0, 1], got {visible}")
    rot, t = default_registration(nominal) if registration is None else registration
    q = np.asarray(nominal.solve_inverse_kinematics(jnp.asarray(commanded)).readings)
    fk = forward_kinematics(true, jnp.asarray(q), jnp.asarray(commanded))
    if not np.all(np.asarray(fk.converged)):
        raise ValueError("forward kinematics of the true mechanism failed at a commanded pose")
    poses = np.asarray(fk.poses)
    k_vis, k_pts, k_refs = jax.random.split(key, 3)
    m, k = len(poses), len(targets.platform)
    seen = np.asarray(jax.random.uniform(k_vis, (m, k))) < visible
    seen[np.arange(m), np.asarray(jax.random.randint(k_vis, (m,), 0, k))] = True
    pidx, tidx = np.nonzero(seen)
    rots = np.asarray(rotation_matrix(jnp.asarray(poses[pidx, 3:])))
    in_b = np.einsum("nij,nj->ni", rots, targets.platform[tidx]) + poses[pidx, :3] + np.asarray(true.v0)
    exact = in_b @ rot.T + t
    refs_exact = targets.base @ rot.T + t
    noisy = exact + _tracker_noise(k_pts, exact, range_um, across_um_per_m)
    refs = refs_exact + _tracker_noise(k_refs, refs_exact, range_um, across_um_per_m)
    data = PointData(tuple(str(j + 1) for j in range(m)), q, pidx, tidx, noisy, np.arange(len(targets.base)), refs)
    return SimulatedPoints(data, poses, np.asarray(commanded), rot, t)


def _tracker_noise(key, points, range_um, across_um_per_m) -> np.ndarray:
    chol = np.linalg.cholesky(tracker_covariance(points, range_um, across_um_per_m))
    z = np.asarray(jax.random.normal(key, points.shape, dtype=jnp.float64))
    return np.einsum("nij,nj->ni", chol, z)
