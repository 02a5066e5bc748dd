"""Initial static equilibrium of the suspended FAST cabin (Yin et al., §2 after eq. 13, and §5).

At a cabin pose ``(G t_C, G R_C)`` with the Stewart platform at rest, the 24 unknowns are, for
each of the six cables, the lower-end force ``F[i]`` (3) and the unstretched length ``s0[i]``
(1). The 24 equations are the catenary end conditions (eqs. 1, 11–13; 18 equations) and the
cabin's equilibrium, eqs. 57–58 with every velocity and acceleration zero (6 equations), in
which the Stewart legs and lower platform act through ``F_U`` of eq. 29 at rest. The same
functions as the time simulation are used, so a cabin started at this equilibrium with the
platform held still stays at rest.

NOTE (start and scaling): Newton's method runs on the scaled unknowns ``F/F_ref`` and
``s0/ℓ`` (``F_ref`` = total weight / 6, ``ℓ`` the chord lengths) with residuals scaled to
metres/``ℓ`` and newtons/``F_ref·ℓ``. The start is a straight-cable equilibrium: tensions ``T[i]``
along the chords from a 6×6 solve of the rest equations with half of each cable's weight at
the cabin; each cable is then taken as the inextensible catenary with the horizontal force
``H = T·l/chord`` through both ends (its arc length and end slope are closed-form), stretched
at tension ``T``. Newton runs on ``log(s0/chord)`` so that ``s0`` stays positive (eqs. 11–13
also have roots with ``s0 < 0``, which a start far off, e.g. a parabolic-sag estimate for a
slack cable, can reach).
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import optimistix as optx
from jaxtyping import Array, Bool, Float

from ._catenary import catenary_upper_end
from ._system import (
    FastParams,
    cabin_residual,
    cable_deltas,
    check_position,
    static_lower_motion,
)


class StaticSolution(NamedTuple):
    """Result of :func:`static_equilibrium`.

    - ``s0``: ``Float[Array, "6"]``, unstretched cable lengths (m).
    - ``force``: ``Float[Array, "6 3"]``, lower-end forces on the cables (N, G).
    - ``tension``: ``Float[Array, "6 2"]``, cable tension at the lower and upper end (N).
    - ``converged``: ``Bool[Array, ""]``, Newton met its tolerance.
    - ``residual``: ``Float[Array, "24"]``, unscaled residual: 18 end-point errors (m) then
      the cabin's force (N) and moment (N·m) balance.
    """

    s0: Float[Array, "6"]
    force: Float[Array, "6 3"]
    tension: Float[Array, "6 2"]
    converged: Bool[Array, ""]
    residual: Float[Array, "24"]


def static_residual(
    params: FastParams,
    pos: Float[Array, "3"],
    R: Float[Array, "3 3"],
    force: Float[Array, "6 3"],
    s0: Float[Array, "6"],
) -> Float[Array, "24"]:
    """The 24 equations (unscaled): catenary end errors (18, m) and eqs. 57–58 at rest (6)."""
    ends = catenary_upper_end(params.cable, force, s0) - cable_deltas(params, pos, R)
    zero3 = jnp.zeros(3, dtype=jnp.float64)
    balance, _ = cabin_residual(
        params, R, zero3, force, static_lower_motion(params.h), jnp.zeros(6, jnp.float64)
    )
    return jnp.concatenate([ends.reshape(18), balance])


def straight_cable_start(
    params: FastParams, pos: Float[Array, "3"], R: Float[Array, "3 3"]
) -> tuple[Float[Array, "6 3"], Float[Array, "6"]]:
    """Straight-cable equilibrium (forces, unstretched lengths), see the module NOTE."""
    delta = cable_deltas(params, pos, R)
    chord = jnp.linalg.norm(delta, axis=-1)
    u = delta / chord[:, None]
    w = params.cable.rho * jnp.abs(params.cable.g)
    half_weight = 0.5 * params.cable.rho * params.cable.g * chord  # signed, on the cabin
    ez = jnp.array([0.0, 0.0, 1.0])
    # Force on the cabin by cable i: T_i u_i + half_weight_i e_z. Balance of what remains:
    base_force = -half_weight[:, None] * ez  # lower-end force on the cable if T = 0
    r0, _ = cabin_residual(params, R, jnp.zeros(3), base_force, static_lower_motion(params.h),
                           jnp.zeros(6))
    r_A = params.anchors @ R.T
    # Residual is -Σ F + ...; F_i = -T_i u_i + base_i adds T_i u_i (force) and r_A × T_i u_i.
    A = jnp.concatenate([u.T, jnp.cross(r_A, u).T], axis=0)
    T = jnp.linalg.solve(A, -r0)
    # Each cable as an inextensible catenary with the straight-cable horizontal force
    # H = T·l/chord: parameter a = H/w, its arc length between the ends, and the lower-end
    # slope, then the elastic stretch at the mean tension.
    span = jnp.linalg.norm(delta[:, :2], axis=-1)
    z = delta[:, 2]
    H = jnp.maximum(T * span / chord, 1e-3 * w * chord)
    a = H / w
    half = jnp.sinh(span / (2.0 * a))
    arc = jnp.sqrt(z**2 + (2.0 * a * half) ** 2)
    x0 = 0.5 * span - a * jnp.arcsinh(z / (2.0 * a * half))
    u_h = delta[:, :2] / span[:, None]
    force = jnp.concatenate([-H[:, None] * u_h, (H * jnp.sinh(x0 / a))[:, None]], axis=-1)
    s0 = arc / (1.0 + T / params.cable.EA)
    return force, s0


def static_equilibrium(
    params: FastParams,
    pos: Float[Array, "3"],
    R: Float[Array, "3 3"] | None = None,
    *,
    rtol: float = 1e-13,
    max_steps: int = 50,
    start: tuple[Float[Array, "6 3"], Float[Array, "6"]] | None = None,
) -> StaticSolution:
    """Unstretched lengths and forces of the six cables holding the cabin at rest at
    ``G t_C = pos`` with attitude ``G R_C = R`` (identity by default): the 24×24 system.

    Solved with ``optimistix.Newton`` (implicit differentiation through ``ImplicitAdjoint``);
    non-convergence is reported in ``converged``, never raised inside a trace. ``start``
    (forces, unstretched lengths) replaces the straight-cable start, e.g. for continuation
    from a nearby pose.
    """
    check_position(pos, "pos")
    pos = jnp.asarray(pos, jnp.float64)
    R = jnp.eye(3, dtype=jnp.float64) if R is None else jnp.asarray(R, jnp.float64)
    force0, s00 = straight_cable_start(params, pos, R) if start is None else start
    chord = jnp.linalg.norm(cable_deltas(params, pos, R), axis=-1)
    weight = (params.m_CB + params.stewart.m_P
              + 6.0 * (params.stewart.m_U + params.stewart.m_D)) * jnp.linalg.norm(params.gravity)
    f_ref = weight / 6.0
    l_ref = jnp.mean(chord)
    scale = jnp.concatenate(
        [jnp.repeat(chord, 3), jnp.full(3, f_ref), jnp.full(3, f_ref * l_ref)]
    )

    # s0 = chord·exp(y) keeps the unstretched lengths positive along the Newton path (a
    # negative s0 is a spurious root of eqs. 11–13).
    def fn(y, _):
        force = y[:18].reshape(6, 3) * f_ref
        s0 = chord * jnp.exp(y[18:])
        return static_residual(params, pos, R, force, s0) / scale

    y0 = jnp.concatenate([force0.reshape(18) / f_ref, jnp.log(s00 / chord)])
    solver = optx.Newton(rtol=rtol, atol=rtol)
    sol = optx.root_find(fn, solver, y0, max_steps=max_steps, throw=False)
    force = sol.value[:18].reshape(6, 3) * f_ref
    s0 = chord * jnp.exp(sol.value[18:])
    residual = static_residual(params, pos, R, force, s0)
    top = force + jnp.array([0.0, 0.0, 1.0]) * (params.cable.rho * params.cable.g * s0)[:, None]
    tension = jnp.stack([jnp.linalg.norm(force, axis=-1), jnp.linalg.norm(top, axis=-1)], -1)
    ok = (sol.result == optx.RESULTS.successful) & jnp.all(jnp.isfinite(residual))
    return StaticSolution(s0, force, tension, ok, residual)


static_equilibrium_jit = jax.jit(static_equilibrium)
"""``jax.jit`` of :func:`static_equilibrium` (``rtol``, ``max_steps`` at their defaults)."""
