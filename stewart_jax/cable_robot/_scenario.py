"""The paper's simulation scenario and its Table 2 (Yin et al., §6, eqs. 61–66, Figs. 6–9).

The cabin starts at rest in static equilibrium at ``G t_C(0)`` with ``G R_C(0) = C R_B = I``
(eq. 61); the lower platform moves along B's x axis, ``B x_P(t) = (A sin(2π f t), 0, 0)``
with ``A = 0.01 m``, ``f = 5 Hz`` (eqs. 62–63). Outputs:

- planned lower-platform displacement ``G R_C(0) C R_B B x_P(t)``;
- actual lower-platform displacement ``G x_P(t)`` (eq. 65);
- extra error ``Δ G x_P = G x_P(t) − G R_C(0) C R_B B x_P(t)`` (eq. 66, Fig. 7);
- cabin vibration displacement ``G t_C(t) − G t_C(0)`` (Fig. 8) and angle (the rotation
  vector of ``G R_C(t) G R_C(0)ᵀ``, Fig. 9);
- per axis (Table 2): the correlation of extra error and vibration displacement, the
  standard deviation of their difference, and the amplitude ``max_t |Δ G x_P|``.

Choices where the paper is silent (see :func:`run_scenario`): the duration (default 2 s),
the time step (default 1 ms) and the initial velocity state. ``start="momentum"`` (default)
gives the cabin the initial velocity and angular velocity that make the total linear and
angular momentum of cabin + legs + lower platform zero, as if the motion had always been
running; ``start="rest"`` is the literal reading (cabin at rest while the platform starts with
eq. 62's velocity ``2π f A = 0.314 m/s`` at ``t = 0``): that impulsive start hands the
whole system a momentum which the cables turn into a ≈0.3 Hz swing of about 12 mm that never
decays (no damping in the model) and dominates every statistic.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ._coupled import CabinState, Trajectory, matrix_to_quat, simulate
from ._statics import static_equilibrium
from ._stewart import LowerMotion, leg_kinematics
from ._system import FastParams, check_position, upper_motion

PAPER_AMPLITUDE = 0.01
PAPER_FREQUENCY = 5.0
PAPER_POSITIONS = ((0.0, 0.0, 140.0), (30.0, 0.0, 142.8), (60.0, 0.0, 151.7), (90.0, 0.0, 167.7))
"""Cabin positions of Table 2 (m)."""

PAPER_TABLE2 = {
    (0.0, 0.0, 140.0): {"x": (3.1473e-4, 2.4109e-3), "y": (9.6015e-6, 7.0980e-5),
                        "z": (1.9002e-6, 2.9461e-5)},
    (30.0, 0.0, 142.8): {"x": (2.8730e-4, 2.1488e-3), "y": (6.9177e-5, 3.2554e-4),
                         "z": (5.4871e-5, 8.4557e-4)},
    (60.0, 0.0, 151.7): {"x": (2.2534e-4, 1.8852e-3), "y": (7.7976e-5, 3.8298e-4),
                         "z": (9.1149e-5, 1.1047e-3)},
    (90.0, 0.0, 167.7): {"x": (1.3522e-4, 1.5803e-3), "y": (9.9746e-5, 8.6194e-4),
                         "z": (9.1965e-5, 1.1049e-3)},
}
"""Table 2 of Yin et al.: per position and axis, (std of difference, amplitude) in metres."""

PAPER_CORRELATION_CENTRE = {"x": 0.9717, "y": 0.9915, "z": 0.9720}
"""Correlations quoted in §6 for ``[0, 0, 140]`` m."""


def sine_motion(h: float, amplitude: float = PAPER_AMPLITUDE, frequency: float = PAPER_FREQUENCY):
    """``t ↦`` :class:`LowerMotion` of eqs. 62–63 (``B R_P = I``)."""
    w = 2.0 * np.pi * frequency

    def motion(t):
        z3 = jnp.zeros(3, dtype=jnp.float64)
        e_x = jnp.array([1.0, 0.0, 0.0])
        pos = amplitude * jnp.sin(w * t) * e_x + jnp.array([0.0, 0.0, h])
        vel = amplitude * w * jnp.cos(w * t) * e_x
        acc = -amplitude * w**2 * jnp.sin(w * t) * e_x
        return LowerMotion(jnp.eye(3, dtype=jnp.float64), z3, z3, pos, vel, acc)

    return motion


def system_momentum(
    params: FastParams,
    R: Float[Array, "3 3"],
    vel: Float[Array, "3"],
    omega: Float[Array, "3"],
    lower: LowerMotion,
) -> Float[Array, "6"]:
    """Linear momentum and angular momentum about the origin of C of cabin + upper platform,
    legs and lower platform (legs rotating with ``W`` of eq. 45). Affine in ``(vel, omega)``."""
    sp = params.stewart
    zero = jnp.zeros(3, dtype=jnp.float64)
    legs = leg_kinematics(sp, upper_motion(params, R, omega, zero, zero), lower)
    G_tB = R @ params.C_t_B
    v_B0 = vel + jnp.cross(omega, G_tB)
    v_Bi = v_B0 + jnp.cross(omega, legs.G_B)
    # Leg parts: positions relative to C's origin, velocities, central inertias.
    x_U = G_tB + legs.G_B + legs.r_U
    x_D = G_tB + legs.G_B + legs.r_D
    v_U = v_Bi + jnp.cross(legs.W, legs.r_U)
    v_D = v_Bi + jnp.cross(legs.W, legs.r_D) + legs.L_dot[:, None] * legs.s
    RL = legs.R_L
    I_U = RL @ sp.I_U @ jnp.swapaxes(RL, -1, -2)
    I_D = RL @ sp.I_D @ jnp.swapaxes(RL, -1, -2)
    # Lower platform.
    R_P = upper_motion(params, R, omega, zero, zero).R @ lower.R
    G_tP = R @ lower.pos
    x_P = G_tB + G_tP + R_P @ sp.r_P0
    omega_P = omega + R @ lower.omega
    v_P = v_B0 + jnp.cross(omega, G_tP) + R @ lower.vel + jnp.cross(omega_P, R_P @ sp.r_P0)
    I_P = R_P @ sp.I_P @ R_P.T
    r_c = R @ params.r_CB0
    v_c = vel + jnp.cross(omega, r_c)
    I_C = R @ params.I_CB @ R.T
    p = (params.m_CB * v_c + sp.m_U * jnp.sum(v_U, 0) + sp.m_D * jnp.sum(v_D, 0)
         + sp.m_P * v_P)
    h = (
        params.m_CB * jnp.cross(r_c, v_c) + I_C @ omega
        + jnp.sum(sp.m_U * jnp.cross(x_U, v_U) + sp.m_D * jnp.cross(x_D, v_D), 0)
        + jnp.sum(jnp.einsum("nij,nj->ni", I_U + I_D, legs.W), 0)
        + sp.m_P * jnp.cross(x_P, v_P) + I_P @ omega_P
    )
    return jnp.concatenate([p, h])


class ScenarioResult(NamedTuple):
    """Output of :func:`run_scenario`; time series have a leading time axis.

    - ``time``: ``Float[Array, "n"]``.
    - ``planned``: ``Float[Array, "n 3"]``, planned lower-platform displacement (eq. 62 in G).
    - ``actual``: ``Float[Array, "n 3"]``, ``G x_P(t)`` (eq. 65, Fig. 6).
    - ``extra_error``: ``Float[Array, "n 3"]``, ``Δ G x_P`` (eq. 66, Fig. 7).
    - ``cabin_displacement``: ``Float[Array, "n 3"]``, ``G t_C(t) − G t_C(0)`` (Fig. 8).
    - ``cabin_angle``: ``Float[Array, "n 3"]``, rotation vector of the cabin (rad, Fig. 9).
    - ``correlation``, ``std``, ``amplitude``: ``Float[Array, "3"]``, Table 2 columns per axis.
    - ``s0``: ``Float[Array, "6"]``; ``tension0``: ``Float[Array, "6"]`` (N, lower end, t = 0).
    - ``static_ok``: ``Bool[Array, ""]``; ``n_failed``: ``Int[Array, ""]`` (see
      :class:`Trajectory`).
    """

    time: Float[Array, " n"]
    planned: Float[Array, "n 3"]
    actual: Float[Array, "n 3"]
    extra_error: Float[Array, "n 3"]
    cabin_displacement: Float[Array, "n 3"]
    cabin_angle: Float[Array, "n 3"]
    correlation: Float[Array, "3"]
    std: Float[Array, "3"]
    amplitude: Float[Array, "3"]
    s0: Float[Array, "6"]
    tension0: Float[Array, "6"]
    static_ok: Array
    n_failed: Array


def rotation_vector(R: Float[Array, "... 3 3"]) -> Float[Array, "... 3"]:
    """Rotation vector (axis × angle) of rotations below π."""
    c = jnp.clip((jnp.trace(R, axis1=-2, axis2=-1) - 1.0) / 2.0, -1.0, 1.0)
    angle = jnp.arccos(c)
    v = jnp.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0],
                   R[..., 1, 0] - R[..., 0, 1]], -1)
    s = jnp.sin(angle)
    # NOTE: angle/(2 sin angle) → 1/2 as the angle → 0; the cabin's angles are ~1e-4 rad,
    # where arccos loses half the digits, so the small-angle series is used below 1e-3.
    factor = jnp.where(angle < 1e-3, 0.5 + angle**2 / 12.0, angle / (2.0 * jnp.where(s > 0, s, 1.0)))
    return factor[..., None] * v


def table2_statistics(
    extra_error: Float[Array, "n 3"], displacement: Float[Array, "n 3"]
) -> tuple[Float[Array, "3"], Float[Array, "3"], Float[Array, "3"]]:
    """Per axis: Pearson correlation of extra error and cabin displacement, standard deviation
    of their difference, amplitude ``max |extra error|`` (the columns of Table 2)."""
    e = extra_error - jnp.mean(extra_error, 0)
    d = displacement - jnp.mean(displacement, 0)
    corr = jnp.sum(e * d, 0) / jnp.sqrt(jnp.sum(e * e, 0) * jnp.sum(d * d, 0))
    std = jnp.std(extra_error - displacement, axis=0)
    amp = jnp.max(jnp.abs(extra_error), axis=0)
    return corr, std, amp


def run_scenario(
    params: FastParams,
    position: Float[Array, "3"],
    *,
    duration: float = 2.0,
    dt: float = 1e-3,
    start: str = "momentum",
    amplitude: float = PAPER_AMPLITUDE,
    frequency: float = PAPER_FREQUENCY,
    method: str = "verlet",
    attitude: Float[Array, "3 3"] | None = None,
) -> ScenarioResult:
    """The §6 scenario at one cabin position (traceable in ``params`` and ``position``;
    ``duration``, ``dt``, ``start`` and ``method`` are static).

    **Arguments:**

    - ``params``: :class:`FastParams`; ``position``: ``Float[Array, "3"]``, ``G t_C(0)`` (m).
    - ``duration``: simulated time (s), 2 s by default (10 periods of the 5 Hz motion; the
      paper does not give it).
    - ``dt``: RK4 step (s), 1 ms by default (200 steps per period).
    - ``start``: ``"momentum"`` (default) or ``"rest"`` (see the module docstring).
    - ``amplitude``, ``frequency``: of the lower platform's motion (traceable; 0 amplitude
      holds the platform still).
    - ``method``: time integrator of :func:`simulate`.
    - ``attitude``: ``G R_C(0)`` (traceable); ``None`` is the paper's ``I`` (eq. 61). The
      lower platform then moves along the tilted B's x axis, and eq. 66 subtracts that
      planned motion.
    """
    if start not in ("rest", "momentum"):
        raise ValueError(f"start must be 'rest' or 'momentum', got {start!r}")
    check_position(position)
    if not (duration > 0 and dt > 0 and np.isfinite(duration) and np.isfinite(dt)):
        raise ValueError(f"duration and dt must be positive, got {duration}, {dt}")
    _check_inputs(params, position, dt, frequency, attitude)
    n_steps = int(round(duration / dt))
    position = jnp.asarray(position, jnp.float64)
    R0 = jnp.eye(3, dtype=jnp.float64) if attitude is None else jnp.asarray(attitude, jnp.float64)
    static = static_equilibrium(params, position, R0)
    motion = sine_motion(params.h, amplitude, frequency)
    zero = jnp.zeros(3, dtype=jnp.float64)
    vel0, omega0 = zero, zero
    if start == "momentum":
        lower0 = motion(jnp.asarray(0.0))

        def mom(v):
            return system_momentum(params, R0, v[:3], v[3:], lower0)

        m0, lin = jax.linearize(mom, jnp.zeros(6))
        M = jax.vmap(lin)(jnp.eye(6)).T
        v = jnp.linalg.solve(M, -m0)
        vel0, omega0 = v[:3], v[3:]
    state0 = CabinState(position, matrix_to_quat(R0), vel0, omega0)
    traj: Trajectory = simulate(params, static.s0, state0, static.force, motion, dt, n_steps,
                                  method)
    return scenario_outputs(params, traj, static, motion)


def scenario_outputs(params: FastParams, traj: Trajectory, static, motion) -> ScenarioResult:
    """Eqs. 64–66 and the Table 2 statistics from a simulated trajectory."""
    lower = jax.vmap(motion)(traj.time)
    C_tP = lower.pos @ params.C_R_B.T + params.C_t_B  # eq. 64
    R0 = traj.R[0]
    x_P = (traj.pos + jnp.einsum("nij,nj->ni", traj.R, C_tP)
           - (traj.pos[0] + R0 @ C_tP[0]))  # eq. 65
    B_x_P = lower.pos - lower.pos[0]  # eq. 62: the motion about the rest position (0, 0, h)
    planned = B_x_P @ (R0 @ params.C_R_B).T
    extra = x_P - planned  # eq. 66
    disp = traj.pos - traj.pos[0]
    angle = rotation_vector(jnp.einsum("nij,kj->nik", traj.R, R0))
    corr, std, amp = table2_statistics(extra, disp)
    return ScenarioResult(traj.time, planned, x_P, extra, disp, angle, corr, std, amp,
                          static.s0, static.tension[:, 0], static.converged, traj.n_failed)


def _check_inputs(params, position, dt, frequency, attitude) -> None:
    """Where the values are concrete: the position is one a cabin can take, and ``dt`` resolves
    the forcing and the cabin's highest mode (refused when too coarse, warned when marginal)."""
    from ._inputs import _concrete, highest_mode_bound_hz, position_problem, warn_time_step

    mode = None
    if _concrete(params, position, attitude):
        problem = position_problem(position, params.towers)
        if problem:
            raise ValueError(problem)
        mode = highest_mode_bound_hz(params, position, attitude)
    warn_time_step(dt, frequency, mode)


run_scenario_jit = jax.jit(run_scenario, static_argnames=("duration", "dt", "start", "method"))
"""``jax.jit`` of :func:`run_scenario` (``duration``, ``dt``, ``start``, ``method`` static)."""
