"""Elastic catenary (Yin et al., *Dynamic modeling of a cable-driven parallel robot with a Stewart
platform for use in FAST*, eqs. 6–13) against a numerical integration of the cable's
differential equations, finite differences, and round trips."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import stewart_jax  # noqa: F401  (enables float64)
from stewart_jax.cable_robot import CableParams, solve_catenary

# The catenary's private building blocks (eqs. 6–13 forward, their Jacobian, the two starts),
# each tested against an independent integration, finite differences or a round trip.
from stewart_jax.cable_robot._catenary import (
    catenary_jacobian,
    catenary_upper_end,
    peyrot_goulois_start,
    straight_bar_start,
)

CABLE = CableParams()  # Table 1: EA = 1.243e8 N, ρ = 13.898 kg/m, g = -9.8 m/s²
EA, RHO, G = 1.243e8, 13.898, -9.8


def _grid():
    # Lower-end forces (N) and unstretched lengths (m) spanning the FAST workspace: taut and
    # slack cables, lowest point outside and inside the span, all horizontal directions.
    rng = np.random.default_rng(0)
    n = 40
    h = 10 ** rng.uniform(3.0, 5.7, n)
    phi = rng.uniform(0, 2 * np.pi, n)
    fz = rng.uniform(-4e5, 5e4, n)
    s0 = rng.uniform(50.0, 450.0, n)
    force = np.stack([h * np.cos(phi), h * np.sin(phi), fz], -1)
    return force, s0


def _integrate(force, s0):
    """Upper end by integrating eqs. 6–10 in the unstretched coordinate s:
    dr/ds = dr/dp · dp/ds = -(F + ρ g s e_z)/K · (1 + K/EA), K from eq. 9."""

    def rhs(s, r):
        t = force + np.array([0.0, 0.0, RHO * G * s])
        k = np.linalg.norm(t)
        return -t / k * (1.0 + k / EA)

    sol = solve_ivp(rhs, (0.0, s0), np.zeros(3), method="DOP853", rtol=1e-12, atol=1e-12)
    return sol.y[:, -1]


_end = jax.jit(lambda F, s0: catenary_upper_end(CABLE, F, s0))
_solve = jax.jit(lambda d, s0, F0: solve_catenary(CABLE, d, s0, F0))


def test_closed_form_matches_ode_integration():
    force, s0 = _grid()
    closed = np.asarray(_end(jnp.asarray(force), jnp.asarray(s0)))
    for F, s, c in zip(force, s0, closed, strict=True):
        np.testing.assert_allclose(c, _integrate(F, s), rtol=0, atol=1e-6)


def test_jacobian_matches_finite_differences():
    force, s0 = _grid()
    end, J = jax.jit(lambda F, s: catenary_jacobian(CABLE, F, s))(force, s0)
    J = np.asarray(J)
    # The Newton solver's closed-form end point (log form of arcsinh) against eqs. 11–13 with
    # the library arcsinh.
    np.testing.assert_allclose(np.asarray(end), np.asarray(_end(force, s0)), rtol=0, atol=1e-9)
    for k in range(3):
        h = 1e-6 * np.linalg.norm(force, axis=-1)
        e = np.zeros(3)
        e[k] = 1.0
        fd = (np.asarray(_end(force + h[:, None] * e, s0)) - np.asarray(_end(force - h[:, None] * e, s0))) / (
            2 * h[:, None]
        )
        np.testing.assert_allclose(J[:, :, k], fd, rtol=1e-6, atol=1e-12)


def test_force_position_force_round_trip_from_peyrot_goulois_start():
    force, s0 = _grid()
    delta = _end(force, s0)
    start = peyrot_goulois_start(CABLE, delta, s0)
    sol = _solve(delta, s0, start)
    assert bool(np.all(sol.converged))
    np.testing.assert_allclose(np.asarray(sol.force), force, rtol=1e-8, atol=1e-6)
    # position → force → position closes to the solver's tolerance.
    np.testing.assert_allclose(np.asarray(_end(sol.force, s0)), np.asarray(delta), atol=1e-9)


def test_straight_bar_start_fails_where_peyrot_goulois_works():
    # Slack cables (s0 well above the chord) with a short horizontal span: the bar start
    # puts the force along the chord, far from the catenary.
    force = np.array([[-2e3, 0.0, -1e3], [-5e2, 3e2, -4e3], [-1e3, -1e3, 2e2]])
    s0 = np.array([300.0, 250.0, 400.0])
    delta = _end(force, s0)
    good = _solve(delta, s0, peyrot_goulois_start(CABLE, delta, s0))
    bad = _solve(delta, s0, straight_bar_start(CABLE, delta, s0))
    assert bool(np.all(good.converged))
    np.testing.assert_allclose(np.asarray(good.force), force, rtol=1e-8)
    assert not bool(np.all(bad.converged))


def test_warm_start_needs_few_steps():
    force, s0 = _grid()
    delta = _end(force, s0)
    sol = _solve(delta + 1e-4, s0, force)  # neighbouring pose, previous force as start
    assert bool(np.all(sol.converged)) and int(sol.steps) <= 3


def test_implicit_derivative_matches_finite_differences():
    force, s0 = _grid()
    force, s0 = force[:6], s0[:6]
    delta = np.asarray(_end(force, s0))

    def f(d, s):
        return solve_catenary(CABLE, d, s, force).force

    Jd, Js = jax.jit(jax.jacfwd(f, argnums=(0, 1)))(delta, s0)
    h = 1e-4
    for k in range(3):
        dd = np.zeros_like(delta)
        dd[:, k] = h
        plus = np.asarray(_solve(delta + dd, s0, force).force)
        minus = np.asarray(_solve(delta - dd, s0, force).force)
        fd = (plus - minus) / (2 * h)
        got = np.asarray(Jd)[:, :, :, k].sum(axis=2)  # block diagonal: perturb every cable
        np.testing.assert_allclose(got, fd, rtol=1e-5, atol=1e-3)
    fd_s = (np.asarray(_solve(delta, s0 + h, force).force) - np.asarray(_solve(delta, s0 - h, force).force)) / (2 * h)
    np.testing.assert_allclose(np.asarray(Js).sum(axis=2), fd_s, rtol=1e-5, atol=1e-3)


def test_vertical_cable_limit_is_finite():
    # H = 0 exactly: no arcsinh(·/0); the horizontal end coordinate is 0, derivatives finite.
    F = jnp.array([0.0, 0.0, -5e4])
    end = catenary_upper_end(CABLE, F, 100.0)
    assert np.all(np.isfinite(np.asarray(end))) and float(end[0]) == 0.0
    # z agrees with the integral of eq. 8 for a vertical cable.
    np.testing.assert_allclose(np.asarray(end), _integrate(np.asarray(F), 100.0), atol=1e-9)
    g = jax.grad(lambda F: catenary_upper_end(CABLE, F, 100.0)[2])(F)
    assert np.all(np.isfinite(np.asarray(g)))
    near = catenary_upper_end(CABLE, jnp.array([1e-9, 0.0, -5e4]), 100.0)
    np.testing.assert_allclose(np.asarray(near), np.asarray(end), atol=1e-9)


def test_bad_input_raises():
    with pytest.raises(ValueError, match="last axis of 3"):
        solve_catenary(CABLE, np.zeros((6, 2)), np.ones(6))
    with pytest.raises(ValueError, match="finite"):
        solve_catenary(CABLE, np.array([[1.0, np.nan, 3.0]]), np.ones(1))
    with pytest.raises(ValueError, match="positive"):
        solve_catenary(CABLE, np.ones((1, 3)), -np.ones(1))


def test_jacobian_of_a_vertical_cable_is_the_limit():
    """At H = 0 the closed form uses the limits of d and q; the Jacobian there is finite and
    equals the one at a horizontal force of H = 1e-3 N: the entries even in H to rtol 1e-9
    (they move by O(H²/F²) ≈ 1e-15), the ones proportional to Fx (∂x/∂Fz = ∂z/∂Fx) by
    O(H/F)·|J| ≈ 5e-8·|J|, hence the absolute tolerance 1e-6·|J|."""
    s0 = np.array([100.0, 250.0])
    vertical = np.array([[0.0, 0.0, -2e4], [0.0, 0.0, -5e5]])
    near = vertical + np.array([1e-3, 0.0, 0.0])
    jac = jax.jit(lambda F, s: catenary_jacobian(CABLE, F, s))
    (e0, J0), (e1, J1) = jac(vertical, s0), jac(near, s0)
    assert np.all(np.isfinite(np.asarray(J0)))
    scale = np.max(np.abs(np.asarray(J1)), axis=(1, 2), keepdims=True)
    np.testing.assert_allclose(np.asarray(J0) / scale, np.asarray(J1) / scale, rtol=1e-9,
                               atol=1e-6)
    # End points: first-order Taylor step from the vertical cable (error O(H²) ≈ 1e-12 m).
    taylor = np.asarray(e0) + np.einsum("nij,nj->ni", np.asarray(J0), near - vertical)
    np.testing.assert_allclose(taylor, np.asarray(e1), rtol=0, atol=1e-9)
