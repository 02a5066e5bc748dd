"""Coupled time simulation of the cable-suspended cabin and the Stewart platform (Yin et al.,
§5, eqs. 54–60, Fig. 5).

The cabin + upper platform is one rigid body with state ``(G t_C, q_C, G ṫ_C, G ω_C)`` (unit
quaternion ``q_C`` for ``G R_C``, scalar first). At every evaluation of the right-hand side:

1. the six cable forces come from the elastic catenary at the current pose with ``s0`` fixed
   (eq. 54; :func:`solve_catenary`, warm-started from the previous evaluation; Verlet
   extrapolates the last two steps' forces linearly);
2. the lower platform's motion relative to B is prescribed (a function of time);
3. eqs. 57–58 with the Stewart reactions of eq. 29 are solved exactly for ``(G ẗ_C, G ε_C)``
   by one 6×6 linear solve (they are affine in the accelerations; the legs' total wrench comes
   from the momentum balance of legs + lower platform; see :mod:`._system`).

Time stepping is inside ``jax.lax.scan``: velocity Verlet on the rotation group (default, one
model evaluation per step) or the classical Runge–Kutta method (RK4, four); the quaternion is
renormalised after each step. The cables are quasi-static as in the paper
(the cable's own inertia is neglected, §2).

NOTE: a catenary solve that fails to converge in any stage is not hidden: the count of
failed cable solves and the largest Newton iteration count are carried through the scan and
returned in :class:`Trajectory`.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import NamedTuple

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float, Int

from ._catenary import solve_catenary
from ._stewart import LowerMotion
from ._system import FastParams, cabin_accelerations_only, cable_deltas


class CabinState(NamedTuple):
    """Rigid-body state of cabin + upper platform.

    - ``pos``: ``Float[Array, "3"]``, ``G t_C`` (m); ``quat``: ``Float[Array, "4"]``, ``q_C``
      (w, x, y, z); ``vel``: ``Float[Array, "3"]``, ``G ṫ_C`` (m/s); ``omega``:
      ``Float[Array, "3"]``, ``G ω_C`` (rad/s).
    """

    pos: Float[Array, "3"]
    quat: Float[Array, "4"]
    vel: Float[Array, "3"]
    omega: Float[Array, "3"]


class Trajectory(NamedTuple):
    """Output of :func:`simulate`; leading axis: the ``n_steps + 1`` sample times.

    - ``time``: ``Float[Array, "n"]`` (s); ``pos``: ``Float[Array, "n 3"]``, ``G t_C``;
      ``R``: ``Float[Array, "n 3 3"]``, ``G R_C``; ``vel``, ``omega``: ``Float[Array, "n 3"]``.
    - ``cable_force``: ``Float[Array, "n 6 3"]``, lower-end cable forces (N) of the last model
      evaluation of each step (Verlet: at the step's end pose).
    - ``n_failed``: ``Int[Array, ""]``, catenary solves (cable × stage) that missed the
      tolerance; 0 for a trustworthy run.
    - ``max_newton``: ``Int[Array, ""]``, largest Newton iteration count of any solve.
    """

    time: Float[Array, " n"]
    pos: Float[Array, "n 3"]
    R: Float[Array, "n 3 3"]
    vel: Float[Array, "n 3"]
    omega: Float[Array, "n 3"]
    cable_force: Float[Array, "n 6 3"]
    n_failed: Int[Array, ""]
    max_newton: Int[Array, ""]


def quat_to_matrix(q: Float[Array, "4"]) -> Float[Array, "3 3"]:
    """Rotation matrix of a unit quaternion (w, x, y, z)."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    return jnp.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def matrix_to_quat(R: Float[Array, "3 3"]) -> Float[Array, "4"]:
    """Unit quaternion (w, x, y, z) of a rotation matrix near the identity (w > 0 branch)."""
    w = 0.5 * jnp.sqrt(jnp.maximum(1.0 + jnp.trace(R), 1e-30))
    return jnp.array(
        [w, (R[2, 1] - R[1, 2]) / (4 * w), (R[0, 2] - R[2, 0]) / (4 * w), (R[1, 0] - R[0, 1]) / (4 * w)]
    )


def _quat_rate(q, omega):
    # q̇ = ½ (0, ω) ⊗ q for the angular velocity ω expressed in G.
    w, x, y, z = q[0], q[1], q[2], q[3]
    a, b, c = omega[0], omega[1], omega[2]
    return 0.5 * jnp.array(
        [-a * x - b * y - c * z, a * w + b * z - c * y, b * w + c * x - a * z, c * w + a * y - b * x]
    )


LowerMotionFn = Callable[[Float[Array, ""]], LowerMotion]


def _quat_exp(theta):
    # Unit quaternion of the rotation vector θ (series below 1e-8 rad).
    a = jnp.sqrt(jnp.sum(theta * theta))
    small = a < 1e-8
    a_safe = jnp.where(small, 1.0, a)
    half = jnp.where(small, 0.5 - a**2 / 48.0, jnp.sin(0.5 * a_safe) / a_safe)
    return jnp.concatenate([jnp.cos(0.5 * a)[None], half * theta])


def _quat_mul(p, q):
    pw, pv = p[0], p[1:]
    qw, qv = q[0], q[1:]
    return jnp.concatenate(
        [(pw * qw - jnp.sum(pv * qv))[None], pw * qv + qw * pv + jnp.cross(pv, qv)]
    )


def cabin_rate(
    params: FastParams,
    s0: Float[Array, "6"],
    lower_motion: LowerMotionFn,
    t: Float[Array, ""],
    state: CabinState,
    force_guess: Float[Array, "6 3"],
) -> tuple[Float[Array, "6"], Float[Array, "6 3"], Array, Array]:
    """Accelerations ``(G ẗ_C, G ε_C)`` of eqs. 54–60 at ``(t, state)``, the cable forces used,
    the number of cable solves that failed and the Newton iterations taken."""
    R = quat_to_matrix(state.quat)
    cab = solve_catenary(params.cable, cable_deltas(params, state.pos, R), s0, force_guess)
    a = cabin_accelerations_only(params, R, state.omega, cab.force, lower_motion(t))
    return a, cab.force, jnp.sum(~cab.converged), cab.steps


METHODS = ("verlet", "rk4")


def simulate(
    params: FastParams,
    s0: Float[Array, "6"],
    state0: CabinState,
    force0: Float[Array, "6 3"],
    lower_motion: LowerMotionFn,
    dt: float,
    n_steps: int,
    method: str = "verlet",
) -> Trajectory:
    """Integrate the coupled cabin dynamics for ``n_steps`` steps of ``dt`` seconds.

    **Arguments:**

    - ``params``: :class:`FastParams`; ``s0``: ``Float[Array, "6"]``, unstretched lengths
      (fixed, from :func:`static_equilibrium`).
    - ``state0``: :class:`CabinState` at ``t = 0``; ``force0``: ``Float[Array, "6 3"]``,
      cable forces at ``t = 0`` (warm start).
    - ``lower_motion``: ``t ↦`` :class:`LowerMotion` of the lower platform relative to B.
    - ``dt``, ``n_steps``: step (s) and number of steps (``n_steps`` static under jit).
    - ``method``: ``"verlet"`` (default; one model evaluation per step) or ``"rk4"`` (four).

    ``"verlet"`` is velocity Verlet on the Lie group: ``t_C += v dt + ½ a dt²``,
    ``q_C ← exp(ω dt + ½ ε dt²) ⊗ q_C``, then the accelerations at the new pose with the
    predicted velocities ``v + a dt``, ``ω + ε dt`` (the only velocity dependence is through
    ``ω`` in the gyroscopic and Stewart terms), and ``v += ½(a + a_new) dt`` (same for ``ω``).
    Second order, like RK4 at a quarter of the cost; the two agree to the accuracy shown in
    the tests and the README.
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    dt = jnp.asarray(dt, jnp.float64)

    def f(t, y, guess):
        return cabin_rate(params, s0, lower_motion, t, y, guess)

    a0, g0, nf0, nn0 = f(jnp.asarray(0.0), state0, jnp.asarray(force0, jnp.float64))
    if method == "verlet":
        init, step = (state0, a0, (g0, g0), nf0, nn0), functools.partial(_verlet_step, f, dt)
    else:
        init, step = (state0, a0, g0, nf0, nn0), functools.partial(_rk4_step, f, dt)
    (_, _, _, n_fail, n_newton), (ys, gs) = jax.lax.scan(
        step, init, jnp.arange(n_steps, dtype=jnp.float64)
    )
    cat = lambda a, b: jnp.concatenate([a[None], b], axis=0)  # noqa: E731
    quat = cat(state0.quat, ys.quat)
    return Trajectory(
        time=jnp.arange(n_steps + 1, dtype=jnp.float64) * dt,
        pos=cat(state0.pos, ys.pos),
        R=jax.vmap(quat_to_matrix)(quat),
        vel=cat(state0.vel, ys.vel),
        omega=cat(state0.omega, ys.omega),
        cable_force=cat(g0, gs),
        n_failed=n_fail,
        max_newton=n_newton,
    )


def _rk4_step(f, dt, carry, i):
    """Step ``i`` of :func:`simulate` by the classical Runge–Kutta method, ``f(t, state, forces)``
    the model (:func:`cabin_rate`). ``carry`` is ``(state, accelerations (6,), cable forces
    (6, 3) (N) of the last evaluation, failed cable solves, largest Newton count)``; returns
    the new carry and ``(state, cable forces)`` of the step's end."""
    y, a_prev, guess, n_fail, n_newton = carry
    del a_prev
    t = i * dt

    def rate(ti, yi, gi):
        a, g, nf, nn = f(ti, yi, gi)
        return CabinState(yi.vel, _quat_rate(yi.quat, yi.omega), a[:3], a[3:]), g, nf, nn

    k1, g1, f1, n1 = rate(t, y, guess)
    k2, g2, f2, n2 = rate(t + 0.5 * dt, _axpy(0.5 * dt, k1, y), g1)
    k3, g3, f3, n3 = rate(t + 0.5 * dt, _axpy(0.5 * dt, k2, y), g2)
    k4, g4, f4, n4 = rate(t + dt, _axpy(dt, k3, y), g3)
    incr = jax.tree.map(lambda a, b, c, d: (a + 2.0 * b + 2.0 * c + d) / 6.0, k1, k2, k3, k4)
    y_new = _axpy(dt, incr, y)
    y_new = y_new._replace(quat=y_new.quat / jnp.linalg.norm(y_new.quat))
    n_fail = n_fail + f1 + f2 + f3 + f4
    n_newton = jnp.maximum(n_newton, jnp.max(jnp.stack([n1, n2, n3, n4])))
    a_new = jnp.concatenate([k4.vel, k4.omega])
    return (y_new, a_new, g4, n_fail, n_newton), (y_new, g4)


def _verlet_step(f, dt, carry, i):
    """Step ``i`` of :func:`simulate` by velocity Verlet on the rotation group, ``f(t, state,
    forces)`` the model (:func:`cabin_rate`). ``carry`` is ``(state, accelerations (6,), the
    cable forces (6, 3) (N) of the last two steps, failed cable solves, largest Newton count)``;
    returns the new carry and ``(state, cable forces)`` of the step's end."""
    y, a, (g_last, g_before), n_fail, n_newton = carry
    t_new = (i + 1.0) * dt
    pos = y.pos + y.vel * dt + 0.5 * a[:3] * dt**2
    quat = _quat_mul(_quat_exp(y.omega * dt + 0.5 * a[3:] * dt**2), y.quat)
    quat = quat / jnp.linalg.norm(quat)
    pred = CabinState(pos, quat, y.vel + a[:3] * dt, y.omega + a[3:] * dt)
    # The cable forces' warm start is extrapolated linearly from the last two steps: the
    # first Newton step then lands within the tolerance far more often than from the
    # last step's forces, and the solver's convergence test is unchanged.
    a_new, g, nf, nn = f(t_new, pred, 2.0 * g_last - g_before)
    y_new = CabinState(pos, quat, y.vel + 0.5 * (a[:3] + a_new[:3]) * dt,
                       y.omega + 0.5 * (a[3:] + a_new[3:]) * dt)
    return (y_new, a_new, (g, g_last), n_fail + nf, jnp.maximum(n_newton, nn)), (y_new, g)


def _axpy(a, x: CabinState, y: CabinState) -> CabinState:
    return jax.tree.map(lambda xi, yi: yi + a * xi, x, y)
