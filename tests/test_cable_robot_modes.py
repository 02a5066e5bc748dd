"""Stiffness, mass matrix and vibration modes of the FAST cabin on its six elastic catenaries
(beyond Yin J., Jiang P., Chen M., Yao R., *Dynamic modeling of a cable-driven parallel robot
with a Stewart platform for use in FAST*): the stiffness against finite differences of the
re-solved cable equilibrium, the mass matrix against closed forms, the lowest frequency against
the FFT of a released cabin in the coupled simulation, and the cables' string frequencies
against a discretised string with the actual tension profile."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.linalg import eigh_tridiagonal

import stewart_jax  # noqa: F401
from stewart_jax.cable_robot import (
    cabin_modes,
    cable_string_modes,
    paper_fast_params,
    solve_catenary,
    static_equilibrium,
)

# The model's private building blocks: the equations of motion (for the stiffness by finite
# differences), the assembly's centre of mass, and the coupled integrator with its state (the
# released cabin whose FFT checks the lowest frequency).
from stewart_jax.cable_robot._attitude import rotation_from_vector
from stewart_jax.cable_robot._coupled import CabinState, matrix_to_quat, simulate
from stewart_jax.cable_robot._scenario import rotation_vector
from stewart_jax.cable_robot._system import cabin_residual, cable_deltas, static_lower_motion
from stewart_jax.cable_robot._workspace import assembly_centre_of_mass

static_equilibrium_jit = jax.jit(static_equilibrium)
cabin_modes_jit = jax.jit(cabin_modes)

PARAMS = paper_fast_params()
M_TOTAL = 25731.0 + 2371.0 + 6 * (165.34 + 60.12)  # Table 1: cabin, lower platform, legs
POS = np.array([30.0, 0.0, 142.8])  # Table 2's second position: no symmetry to hide behind


@pytest.fixture(scope="module")
def modes():
    st = static_equilibrium_jit(PARAMS, jnp.asarray(POS), jnp.eye(3))
    return cabin_modes_jit(PARAMS, jnp.asarray(POS), jnp.eye(3), st)


@jax.jit
def _wrench_at(q, s0, force0):
    # Independent of the module's formula: re-solve every cable at fixed s0 (Newton) at the
    # displaced pose and evaluate eqs. 57-58 at rest with the legs' inverse dynamics.
    R = rotation_from_vector(q[3:])
    pos = jnp.asarray(POS) + q[:3]
    cab = solve_catenary(PARAMS.cable, cable_deltas(PARAMS, pos, R), s0, force0)
    r, _ = cabin_residual(PARAMS, R, jnp.zeros(3), cab.force, static_lower_motion(PARAMS.h),
                          jnp.zeros(6))
    return r, jnp.all(cab.converged)


def test_stiffness_matches_finite_differences_of_the_equilibrium(modes):
    K = np.asarray(modes.stiffness)
    assert float(modes.asymmetry) < 1e-10  # a conservative system at equilibrium
    s0, f0 = modes.static.s0, modes.static.force
    h = np.array([1e-3] * 3 + [1e-5] * 3)  # m, rad
    fd = np.zeros((6, 6))
    for k in range(6):
        e = np.zeros(6)
        e[k] = h[k]
        rp, okp = _wrench_at(jnp.asarray(e), s0, f0)
        rm, okm = _wrench_at(jnp.asarray(-e), s0, f0)
        assert bool(okp) and bool(okm)
        fd[:, k] = -(np.asarray(rp) - np.asarray(rm)) / (2 * h[k])
    # central differences: truncation ~ h² K''' and rounding ~ 1e-9·|r|/h, both < 1e-6 of |K|
    np.testing.assert_allclose(K, 0.5 * (fd + fd.T), rtol=0, atol=1e-6 * np.abs(K).max())


def test_mass_matrix_closed_form(modes):
    M = np.asarray(modes.mass)
    _, com = assembly_centre_of_mass(PARAMS, jnp.asarray(POS), jnp.eye(3))
    c = np.asarray(com) - POS
    np.testing.assert_allclose(M[:3, :3], M_TOTAL * np.eye(3), rtol=1e-12, atol=1e-9)
    skew = np.array([[0, -c[2], c[1]], [c[2], 0, -c[0]], [-c[1], c[0], 0]])
    np.testing.assert_allclose(M[3:, :3], M_TOTAL * skew, rtol=1e-10, atol=1e-6)
    assert np.all(np.linalg.eigvalsh(M) > 0)
    # M-orthonormal shapes that diagonalise K
    V = np.asarray(modes.shapes)
    np.testing.assert_allclose(V.T @ M @ V, np.eye(6), atol=1e-10)
    w2 = (2 * np.pi * np.asarray(modes.frequencies_hz)) ** 2
    np.testing.assert_allclose(V.T @ np.asarray(modes.stiffness) @ V, np.diag(w2),
                               atol=1e-9 * w2.max())


@jax.jit
def _free_response(state, s0, force):
    # 60 s (15 periods of the lowest mode) at dt = 20 ms: ω dt ≤ 0.15 for the stiffest mode
    return simulate(PARAMS, s0, state, force, lambda t: static_lower_motion(PARAMS.h), 0.02, 3000)


def test_lowest_frequency_matches_free_response_fft(modes):
    # Release the cabin 5 mm along its first mode (platform held still) in the coupled
    # simulation, project the motion on that mode and take the FFT peak.
    f1 = float(modes.frequencies_hz[0])
    phi = np.asarray(modes.shapes[:, 0])
    q0 = phi * 5e-3 / np.abs(phi[:3]).max()
    R0 = rotation_from_vector(jnp.asarray(q0[3:]))
    state = CabinState(jnp.asarray(POS + q0[:3]), matrix_to_quat(R0), jnp.zeros(3), jnp.zeros(3))
    traj = _free_response(state, modes.static.s0, modes.static.force)
    dt = 0.02
    assert int(traj.n_failed) == 0
    q = np.concatenate([np.asarray(traj.pos) - POS, np.asarray(rotation_vector(traj.R))], axis=1)
    y = q @ np.asarray(modes.mass) @ phi
    y = (y - y.mean()) * np.hanning(len(y))
    spec = np.abs(np.fft.rfft(y, 1 << 18))
    freqs = np.fft.rfftfreq(1 << 18, dt)
    k = np.argmax(spec)
    a, b, c = np.log(spec[k - 1:k + 2])
    f_fft = freqs[k] + 0.5 * (a - c) / (a - 2 * b + c) * (freqs[1] - freqs[0])
    print(f"lowest frequency: modes {f1:.5f} Hz, FFT of the free response {f_fft:.5f} Hz")
    assert abs(f_fft - f1) / f1 < 0.02


def test_cable_string_frequency_against_discretised_string(modes):
    # Independent: the string equation -(T u')' = ω² μ u on the actual tension profile T(s)
    # of cable 1 (finite differences, 2000 cells), fixed ends, transverse motion.
    cs = cable_string_modes(PARAMS, jnp.asarray(POS), modes.static)
    F, s0 = np.asarray(modes.static.force[0]), float(modes.static.s0[0])
    n = 2000
    s = np.linspace(0.0, s0, n + 1)
    T = np.linalg.norm(F[None, :] + np.outer(-13.898 * 9.8 * s, [0, 0, 1]), axis=1)
    stretch = 1.0 + T / 1.243e8
    ds = s0 / n
    Tm = 0.5 * (T[1:] + T[:-1]) / (0.5 * (stretch[1:] + stretch[:-1]))  # per stretched length
    mu = 13.898 * ds  # mass of each interior node
    diag = (Tm[:-1] + Tm[1:]) / ds / mu
    off = -Tm[1:-1] / ds / np.sqrt(mu * mu)
    w2 = eigh_tridiagonal(diag, off, select="i", select_range=(0, 0))[0][0]
    f_fd = np.sqrt(w2) / (2 * np.pi)
    # the closed form uses the mean tension; the tension varies by ~15 % along the cable
    assert abs(float(cs.taut_string_hz[0]) - f_fd) / f_fd < 5e-3
