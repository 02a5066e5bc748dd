"""The 5 Hz, 10 mm scenario of Yin J., Jiang P., Chen M., Yao R., *Dynamic modeling of a
cable-driven parallel robot with a Stewart platform for use in FAST*, §6 (eqs. 61–66, Table 2),
with lumped-mass cables (:mod:`._lumped`, :mod:`._lumped_time`) in place of the quasi-static
catenaries.

The suspended assembly (cabin + upper platform, legs, lower platform) is the rigid body of the
lumped modes, with its mass matrix at rest; the lower platform's prescribed motion relative to
B (eqs. 62–63) enters as the generalised force it exerts on the cabin through the legs with the
cabin held still, ``f(t) = W(t) − W(0⁻)`` — the legs' wrench from the momentum balance of legs
+ lower platform (:func:`~stewart_jax.cable_robot._stewart.reaction_wrench`), moved to C's origin, less
its static value.

NOTE (what is linearised): the coupled quasi-static simulation
(:func:`~stewart_jax.cable_robot.run_scenario`) evaluates the legs' inertia along the moving
cabin at every step; here the cabin's motion couples to the legs and lower platform through
the constant mass matrix of the assembly at rest. The difference is of the order of the
platform's 10 mm stroke against the assembly's dimensions times the cabin's own millimetre
motion — second order. The cables are exact (nonlinear segment forces) and have mass. The
initial velocity follows the scenario's ``"momentum"`` start (zero total momentum of cabin,
legs and lower platform); the cable nodes start at rest in their static shape.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ._coupled import Trajectory
from ._lumped import check_segments, lumped_modes
from ._lumped_time import simulate_lumped
from ._modes import _exp
from ._scenario import PAPER_AMPLITUDE, PAPER_FREQUENCY, ScenarioResult, scenario_outputs, sine_motion, system_momentum
from ._statics import static_equilibrium_jit
from ._stewart import reaction_wrench
from ._system import FastParams, check_position, static_lower_motion, upper_motion


def _platform_force(params, R, motion, times):
    zero = jnp.zeros(3, jnp.float64)
    up = upper_motion(params, R, zero, zero, zero)
    G_tB = R @ params.C_t_B

    def wrench(t):
        F, M_B = reaction_wrench(params.stewart, up, motion(t))
        return jnp.concatenate([F, M_B + jnp.cross(G_tB, F)])

    F0, M0 = reaction_wrench(params.stewart, up, static_lower_motion(params.h))
    w0 = jnp.concatenate([F0, M0 + jnp.cross(G_tB, F0)])
    return jax.vmap(wrench)(times) - w0


def lumped_scenario(
    params: FastParams,
    position: Float[Array, "3"],
    n_segments: int,
    *,
    duration: float = 2.0,
    dt: float = 1e-3,
    damping_ratio: float = 0.0,
    amplitude: float = PAPER_AMPLITUDE,
    frequency: float = PAPER_FREQUENCY,
    attitude: Float[Array, "3 3"] | None = None,
) -> ScenarioResult:
    """The §6 scenario at one cabin position on ``n_segments`` lumped-mass segments per cable:
    Table 2's columns (``correlation``, ``std``, ``amplitude`` per axis) and the time series of
    :class:`~stewart_jax.cable_robot.ScenarioResult`, from the same eqs. 64–66 as the
    quasi-static run. ``n_failed`` is 0 (no cable solves); ``tension0`` is the catenary's.

    Raises ``ValueError`` for the lumped statics' bad inputs and for a ``dt`` above the explicit
    integrator's stability limit (:func:`~stewart_jax.cable_robot.simulate_lumped`).
    """
    check_position(position)
    n = check_segments(n_segments)
    if not (duration > 0 and dt > 0 and np.isfinite(duration) and np.isfinite(dt)):
        raise ValueError(f"duration and dt must be positive, got {duration}, {dt}")
    n_steps = int(round(duration / dt))
    pos = jnp.asarray(position, jnp.float64)
    R0 = jnp.eye(3, dtype=jnp.float64) if attitude is None else jnp.asarray(attitude, jnp.float64)
    static = static_equilibrium_jit(params, pos, R0)
    modes = lumped_modes(params, pos, n, R0, static)
    st = modes.statics
    motion = sine_motion(params.h, amplitude, frequency)
    times = jnp.arange(n_steps + 1) * dt
    force = _platform_force(params, st.R, motion, times)
    lower0 = motion(jnp.asarray(0.0))

    def mom(v):
        return system_momentum(params, st.R, v[:3], v[3:], lower0)

    m0, lin = jax.linearize(mom, jnp.zeros(6))
    M = jax.vmap(lin)(jnp.eye(6)).T
    v_cab = jnp.linalg.solve(M, -m0)
    velocity = jnp.zeros(modes.frequencies_hz.shape[0]).at[:6].set(v_cab)
    tr = simulate_lumped(params, modes, dt, n_steps, velocity=velocity, force=force,
                         damping_ratio=damping_ratio)
    R = jax.vmap(lambda phi: _exp(phi) @ st.R)(tr.cabin[:, 3:])
    traj = Trajectory(time=tr.time, pos=st.position + tr.cabin[:, :3], R=R, vel=tr.cabin_velocity[:, :3],
                      omega=tr.cabin_velocity[:, 3:], cable_force=jnp.zeros((n_steps + 1, 6, 3)),
                      n_failed=jnp.asarray(0), max_newton=jnp.asarray(0))
    return scenario_outputs(params, traj, static, motion)
