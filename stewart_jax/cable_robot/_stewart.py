"""Stewart platform inside the FAST feed cabin: geometry, leg kinematics and Newton–Euler
inverse dynamics in the moving (non-inertial) cabin frame (Yin et al., §3–§4, eqs. 3–5 and
14–53, parameters of Table 1).

Frames: G global (inertial), B upper platform (fixed to the cabin), P lower platform, L[i]
leg ``i`` (origin at the upper joint ``B[i]``, x along the leg, eqs. 35–38). Vectors carry
the frame they are expressed in as a prefix in the names (``G_``, ``B_``, ``L_``).

Readings of the paper (where it is ambiguous or misprinted):

- Joint layout (Table 1, Fig. 4 is not in the text): upper joints ``B[i]`` on the circle
  ``r_B = 2.0 m`` in pairs ``(B6, B1), (B2, B3), (B4, B5)`` of chord ``|B1B6| = 0.349 m``,
  centred at 30°, 150°, 270°; lower joints ``P[i]`` on ``r_P = 0.98 m`` in pairs ``(P1, P2),
  (P3, P4), (P5, P6)`` of chord ``|P1P2| = 0.256 m``, centred at 90°, 210°, 330°. Then
  ``B1B2`` is parallel to B's x axis, so ``y_B ⊥ B1B2`` as the text defines the frame.
- Inertias ``L I_U``, ``L I_D`` (and ``C I_CB`` in the cabin) are read as **central**
  (about each body's own centre of mass). The text says "about B[i]", but eq. 15 adds
  ``m r × a_rel`` to ``I·A + W × I·W``, which is the Newton–Euler moment equation only
  for central inertias, and Table 1's ``L I_D`` transverse value 115.3 kg·m² is smaller than
  ``m_D·|r_D|² ≈ 129 kg·m²`` about ``B[i]`` at the home pose, impossible for an inertia about
  ``B[i]`` (parallel-axis theorem).
- Eq. 28: the last term is ``-Σ (R P[i]) × c[i]`` (the printed ``+`` contradicts eq. 21
  with eq. 16 substituted). Eq. 53: the Coriolis term is ``2 ω_B × (R_B ṫ_P)``; the printed
  ``2 ω_B × (R_B t_P)`` is dimensionally wrong. Eqs. 17, 44, 46 print the dot product as ×.
- The axial moment ``M_UD[i] s[i]`` that keeps leg ``i`` from spinning (eq. 15) is supplied
  by the upper joint (a universal joint; the lower joint is spherical, eq. 21 has no moment),
  so its reaction ``-M_UD[i] s[i]`` acts on the upper platform. It is returned in
  :class:`StewartForces` and used by the cabin's moment balance.
- Legs rotate with the angular velocity ``W[i]`` of eq. 45 (no spin about their axis), as
  eqs. 47–50 assume.
"""

from __future__ import annotations

from typing import NamedTuple

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float


def _f64(x):
    return jnp.asarray(x, jnp.float64)


def joint_circle(
    radius: float, short_edge: float, pair_centres_deg: tuple[float, float, float], first_low: bool
) -> np.ndarray:
    """Six joints on a circle in three pairs of chord ``short_edge``, ``z = 0``.

    With half-angle ``α = arcsin(short_edge / (2 radius))`` and pair centres ``θ_k``, the
    joints are at ``θ_k ∓ α``. ``first_low=True`` numbers each pair ``(θ_k − α, θ_k + α)``
    starting with pair 0 (lower platform: ``(P1, P2)``, …); ``False`` starts the numbering at
    the upper angle of pair 0 (upper platform: ``B1 = θ_0 + α``, ``B2 = θ_1 − α``, …,
    ``B6 = θ_0 − α``).
    """
    alpha = np.arcsin(short_edge / (2.0 * radius))
    c = np.deg2rad(np.asarray(pair_centres_deg))
    if first_low:
        ang = np.array([c[0] - alpha, c[0] + alpha, c[1] - alpha, c[1] + alpha, c[2] - alpha,
                        c[2] + alpha])
    else:
        ang = np.array([c[0] + alpha, c[1] - alpha, c[1] + alpha, c[2] - alpha, c[2] + alpha,
                        c[0] - alpha])
    return np.stack([radius * np.cos(ang), radius * np.sin(ang), np.zeros(6)], axis=-1)


class StewartParams(eqx.Module):
    """Stewart platform of the FAST cabin (Yin et al., Table 1); SI units.

    - ``B``: ``Float[Array, "6 3"]``, upper joints ``B[i]`` in frame B.
    - ``P``: ``Float[Array, "6 3"]``, lower joints ``P[i]`` in frame P.
    - ``m_U``, ``m_D``: masses of the upper and lower leg parts (kg).
    - ``r_U0``: ``Float[Array, "3"]``, upper part's centre of mass from ``B[i]``, frame L.
    - ``r_D0``: ``Float[Array, "3"]``, lower part's centre of mass from ``P[i]``, frame L.
    - ``I_U``, ``I_D``: ``Float[Array, "3 3"]``, central inertias of the leg parts, frame L.
    - ``m_P``: lower platform mass (kg); ``I_P``: ``Float[Array, "3 3"]``, its inertia about
      the origin of P, frame P; ``r_P0``: ``Float[Array, "3"]``, its centre of mass in P
      (Table 1's ``a_P = 0``: at the origin).
    - ``gravity``: ``Float[Array, "3"]``, gravity vector in G, ``(0, 0, -9.8)``.
    """

    B: Float[Array, "6 3"] = eqx.field(converter=_f64)
    P: Float[Array, "6 3"] = eqx.field(converter=_f64)
    m_U: Float[Array, ""] = eqx.field(converter=_f64)
    m_D: Float[Array, ""] = eqx.field(converter=_f64)
    r_U0: Float[Array, "3"] = eqx.field(converter=_f64)
    r_D0: Float[Array, "3"] = eqx.field(converter=_f64)
    I_U: Float[Array, "3 3"] = eqx.field(converter=_f64)
    I_D: Float[Array, "3 3"] = eqx.field(converter=_f64)
    m_P: Float[Array, ""] = eqx.field(converter=_f64)
    I_P: Float[Array, "3 3"] = eqx.field(converter=_f64)
    r_P0: Float[Array, "3"] = eqx.field(converter=_f64)
    gravity: Float[Array, "3"] = eqx.field(converter=_f64)


def paper_stewart_params(gravity: ArrayLike = (0.0, 0.0, -9.8)) -> StewartParams:
    """The Stewart platform of Yin et al., Table 1, with the joint layout described in the
    module docstring."""
    return StewartParams(
        B=joint_circle(2.0, 0.349, (30.0, 150.0, 270.0), first_low=False),
        P=joint_circle(0.98, 0.256, (90.0, 210.0, 330.0), first_low=True),
        m_U=165.34,
        m_D=60.12,
        # Table 1 gives L r_U0 and L r_D0 in units of 1e-5 m.
        r_U0=np.array([88892.252, -2.923, 1017.727]) * 1e-5,
        r_D0=np.array([-81444.366, 80.387, 278.948]) * 1e-5,
        I_U=np.diag([0.9425, 287.26, 286.81]),
        I_D=np.diag([0.1041, 115.27, 115.26]),
        m_P=2371.0,
        I_P=np.array(
            [[2185.2, -21.443, -48.346], [-21.443, 2401.3, -17.991], [-48.346, -17.991, 2350.1]]
        ),
        r_P0=np.zeros(3),
        gravity=np.asarray(gravity, dtype=np.float64),
    )


class UpperMotion(NamedTuple):
    """Motion of the upper platform (frame B) in G.

    - ``R``: ``Float[Array, "3 3"]``, ``G R_B``.
    - ``omega``: ``Float[Array, "3"]``, ``G ω_B``; ``eps``: ``G ε_B`` (angular acceleration).
    - ``acc``: ``Float[Array, "3"]``, ``G ẗ_B``, acceleration of B's origin.
    """

    R: Float[Array, "3 3"]
    omega: Float[Array, "3"]
    eps: Float[Array, "3"]
    acc: Float[Array, "3"]


class LowerMotion(NamedTuple):
    """Motion of the lower platform (frame P) relative to B, expressed in B.

    - ``R``: ``Float[Array, "3 3"]``, ``B R_P``; ``omega``, ``eps``: ``B ω_P``, ``B ε_P``.
    - ``pos``, ``vel``, ``acc``: ``Float[Array, "3"]``, ``B t_P`` and its first two time
      derivatives.
    """

    R: Float[Array, "3 3"]
    omega: Float[Array, "3"]
    eps: Float[Array, "3"]
    pos: Float[Array, "3"]
    vel: Float[Array, "3"]
    acc: Float[Array, "3"]


class LegKinematics(NamedTuple):
    """Leg quantities of eqs. 3–5 and 30–50, all in G; leading axis: the six legs.

    ``S`` (eq. 3), ``L`` (4), ``s`` (5), ``S_dot`` (33), ``S_ddot`` (34), ``R_L`` (38),
    ``r_U`` (39), ``r_D`` (40), ``L_dot`` (44), ``W`` (45), ``L_ddot`` (46), ``A`` (47),
    ``a_B`` (48), ``a_U`` (49), ``a_D`` (50), ``G_B`` (``G R_B B[i]``), ``G_P``
    (``G R_B B R_P P[i]``).
    """

    S: Float[Array, "6 3"]
    L: Float[Array, "6"]
    s: Float[Array, "6 3"]
    S_dot: Float[Array, "6 3"]
    S_ddot: Float[Array, "6 3"]
    R_L: Float[Array, "6 3 3"]
    r_U: Float[Array, "6 3"]
    r_D: Float[Array, "6 3"]
    L_dot: Float[Array, "6"]
    W: Float[Array, "6 3"]
    L_ddot: Float[Array, "6"]
    A: Float[Array, "6 3"]
    a_B: Float[Array, "6 3"]
    a_U: Float[Array, "6 3"]
    a_D: Float[Array, "6 3"]
    G_B: Float[Array, "6 3"]
    G_P: Float[Array, "6 3"]


class StewartForces(NamedTuple):
    """Result of :func:`stewart_inverse_dynamics`, forces in G (N, N·m).

    - ``F_S``: ``Float[Array, "6"]``, axial component of ``F_D`` (eqs. 17, 22).
    - ``F_D``: ``Float[Array, "6 3"]``, force of the lower platform on leg ``i`` at ``P[i]``
      (eq. 16).
    - ``F_U``: ``Float[Array, "6 3"]``, force of the upper platform on leg ``i`` at ``B[i]``
      (eq. 29); the leg pushes the upper platform with ``-F_U``.
    - ``M_UD``: ``Float[Array, "6"]``, axial moment on leg ``i`` (``s · eq. 15``).
    - ``legs``: :class:`LegKinematics`.
    """

    F_S: Float[Array, "6"]
    F_D: Float[Array, "6 3"]
    F_U: Float[Array, "6 3"]
    M_UD: Float[Array, "6"]
    legs: LegKinematics


def _cross(a, b):
    return jnp.cross(a, b)


def _dot(a, b):
    return jnp.sum(a * b, axis=-1)


# NOTE: the small products below are written as broadcast-multiply-and-sum instead of
# ``@``/``einsum``. On CPU, XLA emits every tiny ``dot`` as its own kernel call, whereas
# the broadcast form fuses with its neighbours; in the time-stepping loop this roughly
# halves the cost of one evaluation of the inverse dynamics.
def mv(A: Float[Array, "... i j"], x: Float[Array, "... j"]) -> Float[Array, "... i"]:
    """``A x`` over leading batch axes."""
    return jnp.sum(A * x[..., None, :], axis=-1)


def rows_times_T(X: Float[Array, "n j"], R: Float[Array, "i j"]) -> Float[Array, "n i"]:
    """``X Rᵀ`` (rotate each row of ``X`` by ``R``)."""
    return jnp.sum(R[None, :, :] * X[:, None, :], axis=-1)


def mm(A: Float[Array, "... i k"], B: Float[Array, "... k j"]) -> Float[Array, "... i j"]:
    """``A B`` over leading batch axes."""
    return jnp.sum(A[..., :, :, None] * B[..., None, :, :], axis=-2)


def leg_kinematics(params: StewartParams, upper: UpperMotion, lower: LowerMotion) -> LegKinematics:
    """Leg positions, velocities and accelerations, eqs. 3–5 and 30–50 (eq. 48 for ``a_B``)."""
    R_B = upper.R
    B_P = rows_times_T(params.P, lower.R)  # B R_P P[i]
    B_S = B_P + lower.pos - params.B  # eq. 30
    B_S_dot = _cross(lower.omega, B_P) + lower.vel  # eq. 31
    B_S_ddot = (
        _cross(lower.eps, B_P) + _cross(lower.omega, _cross(lower.omega, B_P)) + lower.acc
    )  # eq. 32
    S = rows_times_T(B_S, R_B)  # eq. 3
    L = jnp.linalg.norm(S, axis=-1)  # eq. 4
    s = S / L[:, None]  # eq. 5
    RB_S_dot = rows_times_T(B_S_dot, R_B)
    S_dot = _cross(upper.omega, S) + RB_S_dot  # eq. 33
    S_ddot = (
        _cross(upper.eps, S)
        + _cross(upper.omega, S_dot)
        + _cross(upper.omega, RB_S_dot)
        + rows_times_T(B_S_ddot, R_B)
    )  # eq. 34
    y = _cross(B_S, params.B)
    y = rows_times_T(y / jnp.linalg.norm(y, axis=-1, keepdims=True), R_B)  # eq. 36
    z = _cross(s, y)  # eq. 37
    R_L = jnp.stack([s, y, z], axis=-1)  # eq. 38
    r_U = mv(R_L, params.r_U0)  # eq. 39
    r_D = mv(R_L, params.r_D0) + S  # eq. 40
    L_dot = _dot(s, S_dot)  # eq. 44
    W = _cross(s, S_dot) / L[:, None]  # eq. 45
    L_ddot = _dot(s, S_ddot) + L * _dot(W, W)  # eq. 46
    A = (_cross(s, S_ddot) - 2.0 * L_dot[:, None] * W) / L[:, None]  # eq. 47
    G_B = rows_times_T(params.B, R_B)
    a_B = (
        _cross(upper.eps, G_B) + upper.acc + _cross(upper.omega, _cross(upper.omega, G_B))
    )  # eq. 48
    a_U = _cross(A, r_U) + _cross(W, _cross(W, r_U))  # eq. 49
    a_D = (
        _cross(A, r_D)
        + _cross(W, _cross(W, r_D))
        + L_ddot[:, None] * s
        + 2.0 * L_dot[:, None] * _cross(W, s)
    )  # eq. 50
    return LegKinematics(S, L, s, S_dot, S_ddot, R_L, r_U, r_D, L_dot, W, L_ddot, A, a_B, a_U,
                         a_D, G_B, rows_times_T(B_P, R_B))


class _PlatformMotion(NamedTuple):
    G_tP: Float[Array, "3"]
    r_P0: Float[Array, "3"]
    omega: Float[Array, "3"]
    eps: Float[Array, "3"]
    acc: Float[Array, "3"]
    inertia: Float[Array, "3 3"]


def _lower_platform_motion(params: StewartParams, upper: UpperMotion, lower: LowerMotion):
    # Lower platform in G: origin from B's, centre of mass from P's origin, angular velocity
    # and acceleration, centre-of-mass acceleration and central inertia (eqs. 43, 51–53).
    R_P = mm(upper.R, lower.R)  # G R_B B R_P
    RB_omega = mv(upper.R, lower.omega)
    omega_P = upper.omega + RB_omega  # eq. 51
    eps_P = upper.eps + _cross(upper.omega, RB_omega) + mv(upper.R, lower.eps)  # eq. 52
    G_tP = mv(upper.R, lower.pos)
    a_P = (
        _cross(upper.eps, G_tP)
        + _cross(upper.omega, _cross(upper.omega, G_tP))
        + 2.0 * _cross(upper.omega, mv(upper.R, lower.vel))
        + mv(upper.R, lower.acc)
        + upper.acc
    )  # eq. 53 (Coriolis term with the relative velocity)
    r_P0 = mv(R_P, params.r_P0)
    a_P0 = _cross(eps_P, r_P0) + _cross(omega_P, _cross(omega_P, r_P0))
    I_P = mm(mm(R_P, params.I_P), R_P.T)  # eq. 43
    return _PlatformMotion(G_tP, r_P0, omega_P, eps_P, a_P + a_P0, I_P)


def _leg_loads(params: StewartParams, legs: LegKinematics):
    # Per leg, the d'Alembert loads of its two parts: the force m_U (a_U − g) + m_D (a_D − g)
    # (the bracket of eq. 29) and the moment about B[i], D of eq. 19.
    g = params.gravity
    RLt = jnp.swapaxes(legs.R_L, -1, -2)
    I_leg = mm(mm(legs.R_L, params.I_U + params.I_D), RLt)  # eqs. 41–42
    f_U = params.m_U * (legs.a_B + legs.a_U - g)
    f_D = params.m_D * (legs.a_B + legs.a_D - g)
    D = (
        _cross(legs.r_U, f_U)
        + _cross(legs.r_D, f_D)
        + mv(I_leg, legs.A)
        + _cross(legs.W, mv(I_leg, legs.W))
    )  # eq. 19
    return f_U + f_D, D


def _platform_loads(params: StewartParams, plat: _PlatformMotion):
    # The lower platform's d'Alembert force m_P (a_P − g) and moment about P's origin
    # (eqs. 27–28 without the leg terms).
    f_P = params.m_P * (plat.acc - params.gravity)
    moment = (
        _cross(plat.r_P0, f_P)
        + mv(plat.inertia, plat.eps)
        + _cross(plat.omega, mv(plat.inertia, plat.omega))
    )
    return f_P, moment


def stewart_inverse_dynamics(
    params: StewartParams, upper: UpperMotion, lower: LowerMotion
) -> StewartForces:
    """Newton–Euler inverse dynamics of legs and lower platform in the moving frame B,
    eqs. 14–29 with the kinematics of eqs. 30–53.

    Given the motion of the upper platform in G and of the lower platform relative to B,
    returns the axial forces ``F_S`` (6×6 solve of eq. 22) and the joint forces ``F_U`` that
    the upper platform must apply to the legs (eq. 29). The result is affine in the upper
    platform's accelerations ``(upper.acc, upper.eps)`` for fixed positions and velocities.
    """
    legs = leg_kinematics(params, upper, lower)
    s, L = legs.s, legs.L
    f_leg, D = _leg_loads(params, legs)
    c = -_cross(s, D) / L[:, None]  # eq. 18
    f_P, M_P = _platform_loads(params, _lower_platform_motion(params, upper, lower))
    G_P = legs.G_P

    j = _cross(G_P, s)  # eq. 24
    N = jnp.concatenate([s.T, j.T], axis=0)  # eq. 23
    n1 = -jnp.sum(c, axis=0) - f_P  # eq. 27
    n2 = -M_P - jnp.sum(_cross(G_P, c), axis=0)  # eq. 28 (last sign corrected, see above)
    F_S = jnp.linalg.solve(N, jnp.concatenate([n1, n2]))  # eq. 22
    F_D = F_S[:, None] * s + c  # eq. 16
    F_U = f_leg - F_D  # eq. 29
    M_UD = _dot(s, D)
    return StewartForces(F_S, F_D, F_U, M_UD, legs)


def reaction_wrench(
    params: StewartParams, upper: UpperMotion, lower: LowerMotion
) -> tuple[Float[Array, "3"], Float[Array, "3"]]:
    """Force and moment (about the origin of B, in G) that the six legs exert on the upper
    platform, from the momentum balance of legs + lower platform: minus the sum over the 13
    bodies of ``m (a − g)`` and of ``r × m (a − g) + I α + Ω × I Ω`` (each body's centre of
    mass ``r`` from B's origin, central inertia ``I``), with the body motions of eqs. 30–53.

    The joint forces are internal to that subsystem, so this equals
    ``upper_platform_wrench(stewart_inverse_dynamics(params, upper, lower))`` (tested to
    rounding) without solving eq. 22 for the leg forces: the cheaper form that the coupled
    simulation evaluates at every step.
    """
    legs = leg_kinematics(params, upper, lower)
    f_leg, D = _leg_loads(params, legs)
    plat = _lower_platform_motion(params, upper, lower)
    f_P, M_P = _platform_loads(params, plat)
    force = -(jnp.sum(f_leg, axis=0) + f_P)
    moment = -(jnp.sum(_cross(legs.G_B, f_leg) + D, axis=0) + _cross(plat.G_tP, f_P) + M_P)
    return force, moment


def upper_platform_wrench(forces: StewartForces) -> tuple[Float[Array, "3"], Float[Array, "3"]]:
    """Force and moment (about the origin of B) that the six legs exert on the upper
    platform: ``-Σ F_U[i]`` and ``-Σ (G_B[i] × F_U[i] + M_UD[i] s[i])``."""
    legs = forces.legs
    force = -jnp.sum(forces.F_U, axis=0)
    moment = -jnp.sum(_cross(legs.G_B, forces.F_U) + forces.M_UD[:, None] * legs.s, axis=0)
    return force, moment
