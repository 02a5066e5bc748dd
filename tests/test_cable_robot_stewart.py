"""Newton–Euler inverse dynamics of the Stewart platform in the moving cabin (Yin et al.,
*Dynamic modeling of a cable-driven parallel robot with a Stewart platform for use in FAST*,
eqs. 14–53) against independent formulations: the power balance and the momentum balance of
legs + lower platform, written here from positions only (velocities and accelerations by
automatic differentiation in time), and the equivalence principle."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import stewart_jax  # noqa: F401

# The platform's Newton–Euler dynamics is a private building block of the coupled model
# (run_scenario), tested here on its own.
from stewart_jax.cable_robot._stewart import (
    LowerMotion,
    UpperMotion,
    paper_stewart_params,
    reaction_wrench,
    stewart_inverse_dynamics,
    upper_platform_wrench,
)

G = jnp.array([0.0, 0.0, -9.8])


def _rot(v):
    # Rodrigues' formula (test-only, independent of the library's rotations).
    a = jnp.sqrt(jnp.sum(v * v))
    k = v / a
    K = jnp.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return jnp.eye(3) + jnp.sin(a) * K + (1 - jnp.cos(a)) * K @ K


def _vee(W):
    return jnp.array([W[2, 1], W[0, 2], W[1, 0]])


# A smooth, rotating, accelerating motion of the cabin (upper platform B) and of the lower
# platform relative to B, as functions of time.
def R_B(t):
    return _rot(jnp.array([0.02 * jnp.sin(1.3 * t) + 0.03, 0.015 * jnp.sin(0.7 * t + 0.3),
                           0.4 * jnp.sin(2.0 * t) + 0.1]))


def t_B(t):
    return jnp.array([0.5 * jnp.sin(1.1 * t), 0.3 * jnp.cos(1.7 * t), 140 + 0.2 * jnp.sin(0.9 * t)])


def R_P(t):
    return _rot(jnp.array([0.03 * jnp.sin(3.0 * t) + 0.01, 0.05 * jnp.sin(2.5 * t), 0.04 * jnp.sin(1.5 * t) + 0.02]))


def p_P(t):
    return jnp.array([0.05 * jnp.sin(2.0 * t), 0.04 * jnp.sin(3.0 * t + 0.5), -1.7 + 0.06 * jnp.sin(t)])


def d(f, n=1):
    for _ in range(n):
        f = jax.jacfwd(f)
    return f


def motions(t):
    R = R_B(t)
    omega = _vee(d(R_B)(t) @ R.T)
    eps = d(lambda s: _vee(d(R_B)(s) @ R_B(s).T))(t)
    upper = UpperMotion(R, omega, eps, d(t_B, 2)(t))
    Rp = R_P(t)
    w_p = _vee(d(R_P)(t) @ Rp.T)
    e_p = d(lambda s: _vee(d(R_P)(s) @ R_P(s).T))(t)
    lower = LowerMotion(Rp, w_p, e_p, p_P(t), d(p_P)(t), d(p_P, 2)(t))
    return upper, lower


def consistent_params(gravity=(0.0, 0.0, -9.8)):
    """Table 1 with the leg centres of mass on the leg axis and axisymmetric leg inertias:
    then the paper's kinematic assumption (legs rotate with W, eq. 45) is exact for any
    choice of leg frame, and the balances below must hold to round-off."""
    p = paper_stewart_params(gravity)
    return p.__class__(
        B=p.B, P=p.P, m_U=p.m_U, m_D=p.m_D,
        r_U0=jnp.array([p.r_U0[0], 0.0, 0.0]), r_D0=jnp.array([p.r_D0[0], 0.0, 0.0]),
        I_U=jnp.diag(jnp.array([0.9425, 287.26, 287.26])),
        I_D=jnp.diag(jnp.array([0.1041, 115.27, 115.27])),
        m_P=p.m_P, I_P=p.I_P, r_P0=jnp.array([0.01, -0.02, 0.03]), gravity=p.gravity,
    )


def bodies(params, t):
    """Centres of mass of the 6 upper leg parts, 6 lower leg parts and the lower platform,
    the leg axes, and the platform attitude, from positions only."""
    Rb, tb, Rp, pp = R_B(t), t_B(t), R_P(t), p_P(t)
    B = tb + params.B @ Rb.T
    P = tb + (params.P @ Rp.T + pp) @ Rb.T
    S = P - B
    s = S / jnp.linalg.norm(S, axis=-1, keepdims=True)
    x_U = B + params.r_U0[0] * s
    x_D = P + params.r_D0[0] * s
    x_P = tb + (pp + Rp @ params.r_P0) @ Rb.T
    return B, P, s, x_U, x_D, x_P, Rb @ Rp


def energy(params, t):
    def pos(tt):
        return bodies(params, tt)

    (B, P, s, x_U, x_D, x_P, R), (_, _, s_dot, v_U, v_D, v_P, R_dot) = jax.jvp(pos, (t,), (1.0,))
    W = jnp.cross(s, s_dot)  # leg angular velocity (no spin)
    w_P = _vee(R_dot @ R.T)
    I_P = R @ params.I_P @ R.T
    kin = (
        0.5 * params.m_U * jnp.sum(v_U**2) + 0.5 * params.m_D * jnp.sum(v_D**2)
        + 0.5 * (params.I_U[1, 1] + params.I_D[1, 1]) * jnp.sum(W**2)
        + 0.5 * params.m_P * jnp.sum(v_P**2) + 0.5 * w_P @ I_P @ w_P
    )
    pot = -(params.m_U * jnp.sum(x_U @ G) + params.m_D * jnp.sum(x_D @ G) + params.m_P * x_P @ G)
    return kin + pot


def momenta(params, t):
    """Linear momentum and angular momentum about G's origin."""
    (B, P, s, x_U, x_D, x_P, R), (_, _, s_dot, v_U, v_D, v_P, R_dot) = jax.jvp(
        lambda tt: bodies(params, tt), (t,), (1.0,))
    W = jnp.cross(s, s_dot)
    w_P = _vee(R_dot @ R.T)
    lin = params.m_U * v_U.sum(0) + params.m_D * v_D.sum(0) + params.m_P * v_P
    ang = (
        params.m_U * jnp.cross(x_U, v_U).sum(0) + params.m_D * jnp.cross(x_D, v_D).sum(0)
        + (params.I_U[1, 1] + params.I_D[1, 1]) * W.sum(0)
        + params.m_P * jnp.cross(x_P, v_P) + R @ params.I_P @ R.T @ w_P
    )
    return jnp.concatenate([lin, ang])


@jax.jit
def _balances(t):
    params = consistent_params()
    upper, lower = motions(t)
    out = stewart_inverse_dynamics(params, upper, lower)
    B, P, s, x_U, x_D, x_P, _ = bodies(params, t)
    v_B = jax.jvp(lambda tt: bodies(params, tt)[0], (t,), (1.0,))[1]
    L_dot = jax.jvp(lambda tt: jnp.linalg.norm(bodies(params, tt)[1] - bodies(params, tt)[0], axis=-1), (t,), (1.0,))[1]
    a_D = d(lambda tt: bodies(params, tt)[4], 2)(t)
    # Actuator force (lower part pushed along +s by the upper part): axial Newton equation
    # of the lower part, m_D (a_D - g)·s = F_D·s + f_act, with F_D·s = F_S.
    f_act = params.m_D * jnp.sum((a_D - G) * s, -1) - out.F_S
    power_in = jnp.sum(out.F_U * v_B) + jnp.sum(f_act * L_dot)
    dE = jax.jvp(lambda tt: energy(params, tt), (t,), (1.0,))[1]
    dH = jax.jvp(lambda tt: momenta(params, tt), (t,), (1.0,))[1]
    m_tot = 6 * (params.m_U + params.m_D) + params.m_P
    ext_force = jnp.sum(out.F_U, 0) + m_tot * G
    ext_moment = (
        jnp.sum(jnp.cross(B, out.F_U) + out.M_UD[:, None] * s, 0)
        + jnp.sum(params.m_U * jnp.cross(x_U, jnp.broadcast_to(G, x_U.shape)), 0)
        + jnp.sum(params.m_D * jnp.cross(x_D, jnp.broadcast_to(G, x_D.shape)), 0)
        + params.m_P * jnp.cross(x_P, G)
    )
    scale_p = jnp.sum(jnp.abs(out.F_U * v_B)) + jnp.sum(jnp.abs(f_act * L_dot))
    return power_in, dE, scale_p, dH, jnp.concatenate([ext_force, ext_moment]), out


@pytest.mark.parametrize("t", [0.3, 1.1, 2.7])
def test_power_balance(t):
    """Σ F_U·v_B + Σ f_act·L̇ = d/dt (kinetic + potential energy) of legs + lower platform."""
    power_in, dE, scale, *_ = _balances(t)
    assert float(scale) > 1e2  # the motion does real work
    assert abs(float(power_in - dE)) <= 1e-9 * float(scale)


@pytest.mark.parametrize("t", [0.3, 1.1, 2.7])
def test_momentum_balance(t):
    """d/dt (momentum, angular momentum about O) = external force, moment (joint forces
    F_U and axial moments M_UD at the upper joints, gravity)."""
    *_, dH, ext, out = _balances(t)
    scale = float(jnp.max(jnp.abs(out.F_U))) * 150.0
    np.testing.assert_allclose(np.asarray(dH), np.asarray(ext), rtol=0, atol=1e-10 * scale)


def test_uniform_cabin_acceleration_equals_changed_gravity():
    """Equivalence principle: a cabin translating with constant acceleration a0 gives the
    same leg forces as a fixed cabin under gravity g - a0."""
    a0 = jnp.array([0.7, -0.4, 1.3])
    _, lower = motions(0.8)
    R = R_B(0.3)
    z = jnp.zeros(3)
    moving = stewart_inverse_dynamics(paper_stewart_params(), UpperMotion(R, z, z, a0), lower)
    fixed = stewart_inverse_dynamics(
        paper_stewart_params(np.array([0.0, 0.0, -9.8]) - np.asarray(a0)), UpperMotion(R, z, z, z), lower)
    np.testing.assert_allclose(np.asarray(moving.F_S), np.asarray(fixed.F_S), rtol=1e-12, atol=1e-8)
    np.testing.assert_allclose(np.asarray(moving.F_U), np.asarray(fixed.F_U), rtol=1e-12, atol=1e-8)


def test_static_platform_carries_its_weight():
    """At rest the legs carry exactly the weight of legs and lower platform (independent
    sum of Table 1 masses)."""
    p = paper_stewart_params()
    z = jnp.zeros(3)
    out = stewart_inverse_dynamics(p, UpperMotion(jnp.eye(3), z, z, z),
                                   LowerMotion(jnp.eye(3), z, z, jnp.array([0, 0, -1.7]), z, z))
    weight = 9.8 * (6 * (165.34 + 60.12) + 2371.0)
    np.testing.assert_allclose(np.asarray(out.F_U.sum(0)), [0, 0, weight], rtol=1e-12, atol=1e-8)
    assert np.all(np.asarray(out.F_S) > 0)  # the platform hangs: legs in tension


@jax.jit
def _two_wrenches(params, t):
    upper, lower = motions(t)
    by_joints = upper_platform_wrench(stewart_inverse_dynamics(params, upper, lower))
    return jnp.concatenate(by_joints), jnp.concatenate(reaction_wrench(params, upper, lower))


@pytest.mark.parametrize("consistent", [False, True])
def test_reaction_wrench_equals_summed_joint_forces(consistent):
    """The coupled simulation's shortcut (momentum balance of legs + lower platform, no solve
    of eq. 22) gives the legs' wrench on the upper platform of eq. 29 summed, for Table 1's
    off-axis leg centres of mass and for a lower platform with an offset centre of mass."""
    params = consistent_params() if consistent else paper_stewart_params()
    for t in (0.3, 1.1, 2.7):
        joints, momentum = (np.asarray(w) for w in _two_wrenches(params, t))
        assert np.max(np.abs(joints)) > 1e4  # N and N·m: a loaded, moving platform
        # 1e-12 of the largest component: the two sums round differently (~1e-15 each over
        # ~50 terms of up to 1e5).
        np.testing.assert_allclose(momentum, joints, rtol=0, atol=1e-12 * np.max(np.abs(joints)))
