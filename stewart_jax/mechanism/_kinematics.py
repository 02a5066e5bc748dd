"""Kinematics of the 6-PSS Stewart mechanism.

Wang H., Cao X. et al., "Improved cuckoo calibration method of space telescope secondary
mirror adjusting mechanism", Infrared and Laser Engineering 47(5), 2018, §1.1:
rotation (eq. 1), leg vector (eq. 2), inverse kinematics (eq. 4), forward kinematics as the
root of ``IK(P) - q`` (eqs. 5–6). Conventions and the typo fix in eq. 1 follow SPEC §1–2.

A pose is ``P = [dx, dy, dz, φ, θ, ψ]`` in mm and radians; the rotation is
``T = Rz(ψ)·Ry(θ)·Rx(φ)``; slider i moves the lower joint to ``Bc_i + q_i·e_z``.
"""

from __future__ import annotations

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Int

from .._checks import (
    MAX_ANGLE_RAD as MAX_ANGLE_RAD,
    check_array as check_array,
    check_poses as check_poses,
    is_traced as _is_traced,
)
from .._math import euler_angles as euler_angles, rotation_matrix as rotation_matrix
from ._pss import Geometry


class IKSolution(NamedTuple):
    """Result of :func:`solve_inverse_kinematics` for poses of batch shape ``...``.

    - ``strokes``: ``Float[Array, "... 6"]``, slider strokes q (mm). Where a leg is
      unreachable the square root is taken of 0, so the value is finite but meaningless.
    - ``margin``: ``Float[Array, "... 6"]``, the square-root argument of eq. 4,
      ``L_i² − (Bc_ix − a_ix)² − (Bc_iy − a_iy)²`` (mm²); negative means unreachable.
    - ``reachable``: ``Bool[Array, "..."]``, every leg's margin is ≥ 0.
    """

    strokes: Float[Array, "... 6"]
    margin: Float[Array, "... 6"]
    reachable: Bool[Array, "..."]


def upper_joints_in_base(geometry: Geometry, poses: Float[Array, "... 6"]) -> Float[Array, "... 6 3"]:
    """``a_i = T·Ac_i + d + v0``: the upper joint centres in B (eq. 2)."""
    rot = rotation_matrix(poses[..., 3:])
    return (
        jnp.einsum("...jk,ik->...ij", rot, geometry.upper)
        + poses[..., None, :3]
        + geometry.v0
    )


class _IKParts(NamedTuple):
    rot: Array  # T, (..., 3, 3)
    w: Array  # T·Ac_i, (..., 6, 3)
    ell: Array  # rod vector at zero stroke, T·Ac_i + d + v0 − Bc_i, (..., 6, 3)
    growth: Array  # δ(2e + δ), (..., 6, 3)
    margin: Array  # (..., 6)
    root: Array  # sqrt(max(margin, 0)), (..., 6)
    strokes: Array  # (..., 6)


def _ik_parts(geometry: Geometry, poses: Float[Array, "... 6"]) -> _IKParts:
    rot = rotation_matrix(poses[..., 3:])
    upper = geometry.upper
    w = jnp.einsum("...jk,ik->...ij", rot, upper)
    delta = w - upper + poses[..., None, :3]
    e = upper + geometry.v0 - geometry.lower
    growth = delta * (2.0 * e + delta)
    margin = e[:, 2] ** 2 - growth[..., 0] - growth[..., 1]
    root = jnp.sqrt(jnp.maximum(margin, 0.0))
    ell = e + delta
    denom = ell[..., 2] + root
    rationalised = jnp.sum(growth, axis=-1) / jnp.where(denom > 0, denom, 1.0)
    strokes = jnp.where(denom > 0, rationalised, ell[..., 2] - root)
    return _IKParts(rot, w, ell, growth, margin, root, strokes)


def solve_inverse_kinematics(geometry: Geometry, poses: Float[Array, "... 6"]) -> IKSolution:
    """Inverse kinematics (eq. 4) with its reachability margin; pure and jittable.

    ``q_i = a_iz − Bc_iz − sqrt(L_i² − (Bc_ix − a_ix)² − (Bc_iy − a_iy)²)``, the root with the
    slider below the upper joint. ``poses`` may have any leading batch shape; batch over
    geometries with ``jax.vmap``.

    NOTE: eq. 4 is evaluated in a cancellation-free form. With ``e_i = Ac_i + v0 − Bc_i`` the
    zero-pose leg and ``δ_i = T·Ac_i − Ac_i + d`` the joint's displacement,
    ``L² − ℓx² − ℓy² = e_z² − δx(2e_x + δx) − δy(2e_y + δy)`` and, rationalising
    ``q = ℓz − sqrt(m)``, ``q = Σ_k δ_k(2e_k + δ_k) / (ℓz + sqrt(m))``. Strokes of a few mm
    then keep full relative precision instead of being the difference of two ~200 mm
    numbers, and ``q`` is exactly 0 at the zero pose for any geometry.
    """
    parts = _ik_parts(geometry, poses)
    return IKSolution(parts.strokes, parts.margin, jnp.all(parts.margin >= 0.0, axis=-1))


def ik_and_jacobian(geometry: Geometry, poses: Float[Array, "... 6"]):
    """Strokes, margins (``(..., 6)``) and the analytic Jacobian ``∂q_i/∂P_k`` (``(..., 6, 6)``).

    With the rod vector at zero stroke ``ℓ = T·Ac + d + v0 − Bc`` and ``h = sqrt(m)`` its
    z-extent once the slider has moved, ``q = ℓz − h`` gives ``∂q = ∂ℓz + (ℓx·∂ℓx + ℓy·∂ℓy)/h``
    with ``∂ℓ/∂d = I``, ``∂ℓ/∂φ = T·(e_x × Ac)``, ``∂ℓ/∂θ = (Rz(ψ)·e_y) × T·Ac`` and
    ``∂ℓ/∂ψ = e_z × T·Ac``.
    """
    parts = _ik_parts(geometry, poses)
    rot, w, ell, h = parts.rot, parts.w, parts.ell, parts.root
    upper = geometry.upper
    ax, ay = ell[..., 0] / h, ell[..., 1] / h  # ∂q/∂dx, ∂q/∂dy
    dphi = -upper[:, 2:3] * rot[..., None, :, 1] + upper[:, 1:2] * rot[..., None, :, 2]
    sp, cp = jnp.sin(poses[..., 5:6]), jnp.cos(poses[..., 5:6])
    wx, wy, wz = w[..., 0], w[..., 1], w[..., 2]
    jac = jnp.stack(
        [
            ax,
            ay,
            jnp.ones_like(ax),
            dphi[..., 2] + ax * dphi[..., 0] + ay * dphi[..., 1],
            -sp * wy - cp * wx + (ax * cp + ay * sp) * wz,
            ay * wx - ax * wy,
        ],
        axis=-1,
    )
    return parts.strokes, parts.margin, jac


def inverse_kinematics(geometry: Geometry, poses: ArrayLike) -> Float[Array, "... 6"]:
    """Slider strokes (mm) for poses ``[dx, dy, dz, φ, θ, ψ]`` (mm, rad), eq. 4.

    Raises ``ValueError`` for a malformed, non-finite or degree-valued pose and for an
    unreachable pose (naming it). Under ``jit`` the same checks run at run time through
    ``equinox.error_if``. Use :func:`solve_inverse_kinematics` to get the reachability as a
    status instead.
    """
    poses = check_poses(poses)
    sol = solve_inverse_kinematics(geometry, poses)
    if isinstance(poses, jax.core.Tracer) or _is_traced(geometry):
        return eqx.error_if(
            sol.strokes,
            ~sol.reachable[..., None],
            "inverse_kinematics: unreachable pose (a rod cannot span the joints)",
        )
    reachable = np.asarray(sol.reachable)
    if not reachable.all():
        bad = np.argwhere(~reachable) if reachable.ndim else np.zeros((1, 0), int)
        first = tuple(int(i) for i in bad[0])
        raise ValueError(
            f"inverse_kinematics: {len(bad)} unreachable pose(s), first at index {first}: "
            f"{np.asarray(poses)[first].tolist()} (mm, rad); no rod of that length spans the joints"
        )
    return sol.strokes


def kinematic_jacobian(geometry: Geometry, pose: Float[Array, "... 6"]) -> Float[Array, "... 6 6"]:
    """``∂q/∂P`` (mm per mm / mm per rad), analytic (:func:`ik_and_jacobian`); any batch shape."""
    return ik_and_jacobian(geometry, pose)[2]


class FKSolution(NamedTuple):
    """Result of :func:`forward_kinematics` for strokes of batch shape ``...``.

    - ``poses``: ``Float[Array, "... 6"]``, the pose (mm, rad); the last iterate where the
      solve failed.
    - ``converged``: ``Bool[Array, "..."]``, ``max |IK(P) − q| ≤ tol`` was reached and the
      pose is reachable.
    - ``residual``: ``Float[Array, "..."]``, ``max_i |IK(P)_i − q_i|`` at the returned pose (mm).
    - ``steps``: ``Int[Array, "..."]``, Newton steps taken.
    """

    poses: Float[Array, "... 6"]
    converged: Bool[Array, "..."]
    residual: Float[Array, "..."]
    steps: Int[Array, "..."]


def _fk_one(
    geometry: Geometry,
    strokes: Float[Array, "6"],
    initial_pose: Float[Array, "6"],
    tol: float,
    max_steps: int,
) -> FKSolution:
    """Newton's method on ``F(P) = IK(P) − q = 0`` (eqs. 5–6) for one pose.

    NOTE: eq. 6 poses FK as least squares; with six legs and six pose components the
    problem is square, so Gauss–Newton is Newton's method with the 6×6 Jacobian, and
    converges quadratically from the zero pose anywhere in a ±1 mm, ±1° travel (3–4 steps).
    """

    def residual(p):
        sol = solve_inverse_kinematics(geometry, p)
        f = sol.strokes - strokes
        ok = sol.reachable & jnp.all(jnp.isfinite(f))
        return f, jnp.where(ok, jnp.max(jnp.abs(f)), jnp.inf)

    def cond(carry):
        _, _, err, k, stalled = carry
        return (k < max_steps) & (err > tol) & ~stalled

    def backtrack(p, step, err):
        # The first of 1/2, ..., 1/16 of the Newton step that stays in the workspace and
        # lowers max|F|; none does → the solve stops (reported as not converged).
        alphas = 0.5 ** jnp.arange(1.0, 5.0)
        cand = p - alphas[:, None] * step
        cf, cerr = jax.vmap(residual)(cand)
        better = cerr < err
        i = jnp.argmax(better)
        return cand[i], cf[i], cerr[i], better[i]

    def body(carry):
        p, f, err, k, _ = carry
        jac = ik_and_jacobian(geometry, p)[2]
        step = jnp.linalg.solve(jac, f)
        full = p - step
        f_full, err_full = residual(full)
        p, f, err_new, accept = jax.lax.cond(
            err_full < err,
            lambda: (full, f_full, err_full, jnp.asarray(True)),
            lambda: backtrack(p, step, err),
        )
        accept = accept & jnp.all(jnp.isfinite(step))
        err = jnp.where(accept, err_new, err)
        return p, f, err, k + accept.astype(k.dtype), ~accept

    f0, err0 = residual(initial_pose)
    init = (initial_pose, f0, err0, jnp.asarray(0), jnp.asarray(False))
    pose, f, err, steps, _ = jax.lax.while_loop(cond, body, init)
    return FKSolution(pose, err <= tol, jnp.max(jnp.abs(f)), steps)


@eqx.filter_jit
def _fk_batched(geometry, strokes, initial_poses, tol, max_steps):
    flat_q = strokes.reshape(-1, 6)
    flat_p0 = jnp.broadcast_to(initial_poses, strokes.shape).reshape(-1, 6)
    sol = jax.vmap(_fk_one, in_axes=(None, 0, 0, None, None))(geometry, flat_q, flat_p0, tol, max_steps)
    batch = strokes.shape[:-1]
    return FKSolution(
        sol.poses.reshape(*batch, 6),
        sol.converged.reshape(batch),
        sol.residual.reshape(batch),
        sol.steps.reshape(batch),
    )


def forward_kinematics(
    geometry: Geometry,
    strokes: ArrayLike,
    initial_pose: ArrayLike | None = None,
    *,
    tol: float = 1e-12,
    max_steps: int = 30,
    throw: bool = False,
) -> FKSolution:
    """Forward kinematics (eqs. 5–6): the pose that produces ``strokes`` (mm).

    ``strokes`` may have any leading batch shape; each pose is solved independently by
    Newton's method (batched with vmap) from ``initial_pose`` (default: the zero pose).
    Per-pose convergence is reported in :class:`FKSolution`; with ``throw=True`` a
    non-converged pose raises instead (``equinox.error_if`` under jit).

    ``tol`` (mm) is on ``max |IK(P) − q|``; float64 rounding of eq. 4 is ~1e-15 mm.
    """
    q = check_array(strokes, "strokes", last_dim=6)
    p0 = jnp.zeros(6) if initial_pose is None else check_poses(initial_pose)
    sol = _fk_batched(geometry, q, p0, tol, max_steps)
    if throw:
        poses = eqx.error_if(
            sol.poses,
            ~sol.converged[..., None],
            "forward_kinematics: Newton did not converge (strokes outside the workspace?)",
        )
        sol = sol._replace(poses=poses)
    return sol
