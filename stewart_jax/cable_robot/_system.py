"""The whole FAST feed-support model: towers, cable anchors, cabin and Stewart platform, and
the cabin's Newton–Euler equations (Yin et al., eqs. 1–2, 54–60, Table 1).

The cabin and the upper platform are one rigid body (frame C; B is fixed in C by ``C R_B``
and ``C t_B``). Its equations of motion about the origin of C (eqs. 57–58) are

    -Σ F_C[i] + F_stew + m g = m (ẗ_C + a_CB)
    -Σ (R_C r_A[i]) × F_C[i] + M_stew + m (R_C r_CB0) × g
        = I_G ε_C + ω_C × I_G ω_C + m (R_C r_CB0) × (ẗ_C + a_CB),

with ``a_CB = ε_C × (R_C r_CB0) + ω_C × (ω_C × R_C r_CB0)`` (eq. 59), ``I_G = R_C I_CB R_Cᵀ``
(eq. 60; ``I_CB`` read as central, see :mod:`._stewart`) and ``(F_stew, M_stew)`` the wrench of
the six legs on the upper platform, moved to the origin of C.

NOTE (how the implicit dependence is solved): ``F_U`` (eq. 29) depends on the cabin's own
accelerations ``(ẗ_C, ε_C)`` through eqs. 34, 47–50 and 52–53, and it depends on them
*affinely* (positions and velocities fixed). The residual of eqs. 57–58 is therefore affine in
``a = (ẗ_C, ε_C)``: the residual at ``a = 0`` and at the six unit vectors gives ``J`` exactly
(``J e_k = r(e_k) − r(0)``), and one 6×6 linear solve gives the exact accelerations,
``a = -J⁻¹ r(0)``. No fixed-point iteration between the cable model and
the Stewart model is needed (the paper's Fig. 5 iterates). Only the legs' total wrench on the
upper platform enters eqs. 57–58, so the time loop takes it from the momentum balance of legs +
lower platform (:func:`~stewart_jax.cable_robot._stewart.reaction_wrench`), which equals eq. 29 summed without
solving eq. 22 for the six leg forces; the leg forces are computed where they are reported.

The acceleration of B's origin is ``ẗ_B = ẗ_C + ε_C × (R_C t_B) + ω_C × (ω_C × R_C t_B)``;
eq. 56 writes ``ẗ_B = ẗ_C``, which drops the lever arm ``C t_B`` (0.155 m).
"""

from __future__ import annotations

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ._catenary import CableParams
from ._stewart import (
    LowerMotion,
    StewartForces,
    StewartParams,
    UpperMotion,
    mm,
    mv,
    paper_stewart_params,
    reaction_wrench,
    rows_times_T,
    stewart_inverse_dynamics,
    upper_platform_wrench,
)


def _f64(x):
    return jnp.asarray(x, jnp.float64)


class FastParams(eqx.Module):
    """The FAST feed support of Yin et al., Table 1; SI units.

    - ``cable``: :class:`CableParams` (the six cables are alike).
    - ``towers``: ``Float[Array, "6 3"]``, tower tops ``T[i]`` in G (eq. 1).
    - ``anchors``: ``Float[Array, "6 3"]``, cable anchors ``C r_A[i]`` on the cabin (eq. 2).
    - ``stewart``: :class:`StewartParams`.
    - ``m_CB``: mass of cabin + upper platform (kg); ``I_CB``: ``Float[Array, "3 3"]``, its
      central inertia in C; ``r_CB0``: ``Float[Array, "3"]``, its centre of mass in C.
    - ``C_t_B``: ``Float[Array, "3"]``, origin of B in C; ``C_R_B``: ``Float[Array, "3 3"]``.
    - ``h``: height of the lower platform's origin below B at rest (m), -1.7.
    - ``gravity``: ``Float[Array, "3"]``, gravity vector in G.
    """

    cable: CableParams
    towers: Float[Array, "6 3"] = eqx.field(converter=_f64)
    anchors: Float[Array, "6 3"] = eqx.field(converter=_f64)
    stewart: StewartParams
    m_CB: Float[Array, ""] = eqx.field(converter=_f64)
    I_CB: Float[Array, "3 3"] = eqx.field(converter=_f64)
    r_CB0: Float[Array, "3"] = eqx.field(converter=_f64)
    C_t_B: Float[Array, "3"] = eqx.field(converter=_f64)
    C_R_B: Float[Array, "3 3"] = eqx.field(converter=_f64)
    h: Float[Array, ""] = eqx.field(converter=_f64)
    gravity: Float[Array, "3"] = eqx.field(converter=_f64)

    def __check_init__(self):
        from ._inputs import check_fast_params

        check_fast_params(self)


def tower_positions(r_T: float = 300.0, H: float = 270.0) -> np.ndarray:
    """Tower tops ``(r_T cos((i−1)π/3), r_T sin((i−1)π/3), H)``, eq. 1."""
    a = np.arange(6) * np.pi / 3.0
    return np.stack([r_T * np.cos(a), r_T * np.sin(a), np.full(6, H)], axis=-1)


def anchor_positions(r_A: float = 6.5) -> np.ndarray:
    """Cabin anchors ``r_A (cos(π/6 + ⌊(i−1)/2⌋ 2π/3), sin(…), 0)`` in C, eq. 2 (cables
    ``2k+1`` and ``2k+2`` share an anchor)."""
    a = np.pi / 6.0 + (np.arange(6) // 2) * 2.0 * np.pi / 3.0
    return np.stack([r_A * np.cos(a), r_A * np.sin(a), np.zeros(6)], axis=-1)


def paper_fast_params(g: float = -9.8) -> FastParams:
    """Table 1 of Yin et al. (``g`` is the signed vertical gravity, Table 1 writes -9.8)."""
    gravity = np.array([0.0, 0.0, g])
    return FastParams(
        cable=CableParams(EA=1.243e8, rho=13.898, g=g),
        towers=tower_positions(),
        anchors=anchor_positions(),
        stewart=paper_stewart_params(gravity),
        m_CB=25731.0,
        I_CB=np.array(
            [[328.68, 3.9237, 2.5993], [3.9237, 391.18, -20.831], [2.5993, -20.831, 213.01]]
        )
        * 1e3,
        r_CB0=np.array([0.0, 0.0, -0.2551]),
        C_t_B=np.array([0.0, 0.0, -0.1554]),
        C_R_B=np.eye(3),
        h=-1.7,
        gravity=gravity,
    )


def cable_deltas(
    params: FastParams, pos: Float[Array, "3"], R: Float[Array, "3 3"]
) -> Float[Array, "6 3"]:
    """Upper end of each cable relative to its lower end, eq. 1:
    ``T[i] − (G R_C C r_A[i] + G t_C)``."""
    return params.towers - (rows_times_T(params.anchors, R) + pos)


class CabinDynamics(NamedTuple):
    """Output of :func:`cabin_accelerations`.

    - ``acc``: ``Float[Array, "3"]``, ``G ẗ_C``; ``eps``: ``Float[Array, "3"]``, ``G ε_C``.
    - ``stewart``: :class:`StewartForces` at those accelerations.
    - ``residual``: ``Float[Array, "6"]``, eqs. 57–58 evaluated at the solution (N, N·m).
    """

    acc: Float[Array, "3"]
    eps: Float[Array, "3"]
    stewart: StewartForces
    residual: Float[Array, "6"]


def upper_motion(
    params: FastParams,
    R: Float[Array, "3 3"],
    omega: Float[Array, "3"],
    acc: Float[Array, "3"],
    eps: Float[Array, "3"],
) -> UpperMotion:
    """Motion of B from the cabin's (eq. 56, with the lever arm ``C t_B``)."""
    G_tB = mv(R, params.C_t_B)
    acc_B = acc + jnp.cross(eps, G_tB) + jnp.cross(omega, jnp.cross(omega, G_tB))
    return UpperMotion(mm(R, params.C_R_B), omega, eps, acc_B)


def _cabin_balance(params, R, omega, cable_forces, a, F_leg, M_leg_B):
    # Eqs. 57–58 given the legs' wrench on the upper platform (G; moment about B's origin).
    acc, eps = a[:3], a[3:]
    m = params.m_CB
    G_tB = mv(R, params.C_t_B)
    r_c = mv(R, params.r_CB0)
    a_CB = jnp.cross(eps, r_c) + jnp.cross(omega, jnp.cross(omega, r_c))  # eq. 59
    I_G = mm(mm(R, params.I_CB), R.T)  # eq. 60
    r_A = rows_times_T(params.anchors, R)
    acc_c = acc + a_CB - params.gravity
    force = -jnp.sum(cable_forces, axis=0) + F_leg - m * acc_c  # eq. 57
    moment = (
        -jnp.sum(jnp.cross(r_A, cable_forces), axis=0)
        + M_leg_B
        + jnp.cross(G_tB, F_leg)
        - (mv(I_G, eps) + jnp.cross(omega, mv(I_G, omega)) + m * jnp.cross(r_c, acc_c))
    )  # eq. 58
    return jnp.concatenate([force, moment])


def cabin_residual(
    params: FastParams,
    R: Float[Array, "3 3"],
    omega: Float[Array, "3"],
    cable_forces: Float[Array, "6 3"],
    lower: LowerMotion,
    a: Float[Array, "6"],
) -> tuple[Float[Array, "6"], StewartForces]:
    """Residual of eqs. 57–58 (force; moment about C's origin) at accelerations
    ``a = (G ẗ_C, G ε_C)``; zero when the cabin moves as Newton–Euler requires."""
    forces = stewart_inverse_dynamics(
        params.stewart, upper_motion(params, R, omega, a[:3], a[3:]), lower
    )
    F_leg, M_leg_B = upper_platform_wrench(forces)
    return _cabin_balance(params, R, omega, cable_forces, a, F_leg, M_leg_B), forces


def cabin_accelerations(
    params: FastParams,
    R: Float[Array, "3 3"],
    omega: Float[Array, "3"],
    cable_forces: Float[Array, "6 3"],
    lower: LowerMotion,
) -> CabinDynamics:
    """Cabin accelerations from eqs. 57–58 by one exact 6×6 solve (see the module NOTE).

    **Arguments:** cabin attitude ``R`` (``G R_C``), angular velocity ``omega`` (G), the
    lower-end cable forces ``cable_forces`` (``Float[Array, "6 3"]``, on the cables, eq. 54),
    and the lower platform's motion relative to B.
    """
    a = cabin_accelerations_only(params, R, omega, cable_forces, lower)
    res, forces = cabin_residual(params, R, omega, cable_forces, lower, a)
    return CabinDynamics(a[:3], a[3:], forces, res)


def _gauss_jordan(M: Float[Array, "n n+1"]) -> Float[Array, " n"]:
    # Solution of [A | b] by Gauss–Jordan elimination without pivoting, unrolled.
    # NOTE: A here is minus the generalised inertia of cabin + Stewart platform about C's
    # origin: nearly symmetric and negative definite (eigenvalues ≈ -2.9e4 … -4.1e5 for
    # Table 1), so no pivoting is needed, and six rank-one updates of a 6×7 array are several
    # times cheaper on CPU than the LU factorisation and two triangular solves of
    # ``jnp.linalg.solve`` (three library calls per step).
    n = M.shape[0]
    eye = jnp.eye(n, dtype=M.dtype)
    for k in range(n):
        row = M[k] / M[k, k]
        M = M - (M[:, k] - eye[:, k])[:, None] * row[None, :]
    return M[:, n]


def cabin_accelerations_only(
    params: FastParams,
    R: Float[Array, "3 3"],
    omega: Float[Array, "3"],
    cable_forces: Float[Array, "6 3"],
    lower: LowerMotion,
) -> Float[Array, "6"]:
    """``(G ẗ_C, G ε_C)`` as :func:`cabin_accelerations` (equal up to rounding), the time
    loop's fast path: the legs' wrench comes from :func:`reaction_wrench` (momentum balance of
    legs + lower platform, no solve for the leg forces) and the Stewart forces are not
    evaluated at the solution."""

    def legs(a):
        upper = upper_motion(params, R, omega, a[:3], a[3:])
        return jnp.concatenate(reaction_wrench(params.stewart, upper, lower))

    # NOTE: the legs' wrench is affine in a, so its derivative along e_k is w(e_k) − w(0)
    # exactly, up to rounding (|w| ≲ 3e5 N against derivatives ~ 1e3 kg: 1e-15 relative).
    # One vmapped evaluation at the 7 points (the position-only work is not batched) is no
    # slower on CPU than jax.linearize with 6 tangents. The cabin's own terms enter J through
    # their linear part, written out below, which keeps the gyroscopic and centripetal terms
    # out of the batched evaluation.
    points = jnp.concatenate([jnp.zeros((1, 6)), jnp.eye(6)]).astype(jnp.float64)
    w = jax.vmap(legs)(points)
    zero = jnp.zeros(6, dtype=jnp.float64)
    r0 = _cabin_balance(params, R, omega, cable_forces, zero, w[0, :3], w[0, 3:])
    G_tB = mv(R, params.C_t_B)
    r_c = mv(R, params.r_CB0)
    I_G = mm(mm(R, params.I_CB), R.T)  # eq. 60
    m = params.m_CB

    def column(a, dw):
        # ∂(eqs. 57–58)/∂a along a, with dw the legs' wrench along a (moment about B).
        acc, eps = a[:3], a[3:]
        dF, dM = dw[:3], dw[3:]
        lin = acc + jnp.cross(eps, r_c)
        return jnp.concatenate([dF - m * lin,
                                dM + jnp.cross(G_tB, dF) - mv(I_G, eps) - m * jnp.cross(r_c, lin)])

    J = jax.vmap(column, out_axes=1)(points[1:], w[1:] - w[0])
    return _gauss_jordan(jnp.concatenate([J, -r0[:, None]], axis=1))


def static_lower_motion(h: float | ArrayLike = -1.7) -> LowerMotion:
    """Lower platform at rest at ``B t_P = (0, 0, h)`` with ``B R_P = I``."""
    z = jnp.zeros(3, dtype=jnp.float64)
    return LowerMotion(jnp.eye(3, dtype=jnp.float64), z, z,
                       jnp.array([0.0, 0.0, h], dtype=jnp.float64), z, z)


def check_position(position: ArrayLike, name: str = "position") -> None:
    """Raise ``ValueError`` unless ``position`` is a finite 3-vector (metres); no-op on tracers."""
    if isinstance(position, jax.core.Tracer):
        return
    a = np.asarray(position, dtype=np.float64)
    if a.shape != (3,):
        raise ValueError(f"{name} must be a 3-vector (x, y, z) in metres, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite, got {a.tolist()}")
