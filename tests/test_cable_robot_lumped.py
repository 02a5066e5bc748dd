"""Lumped-mass cables for the FAST cabin (the MoorDyn discretisation: Hall & Goupee 2015):
statics against the elastic catenary of Yin et al. (eqs. 6–13) with the order of convergence,
the cabin's static stiffness with free nodes against the quasi-static cables' implicit
stiffness, light cables against the quasi-static modes, the Hessian against finite differences
of the gradient, the modal bookkeeping against closed forms, and the bad inputs."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import stewart_jax  # noqa: F401
from stewart_jax.cable_robot import CableParams, cabin_modes, paper_fast_params, static_equilibrium
from stewart_jax.cable_robot._lumped import (
    _raise_if_failed,
    catenary_nodes,
    lumped_modes,
    lumped_potential,
    lumped_statics,
    lumped_stiffness_schur,
)
from stewart_jax.cable_robot._lumped_low import modal_summary

# The slow tier (make test-all runs it, make test does not): lumped-mass statics at two refinements, shared by
# every test here (63 s on 2 cores).
pytestmark = pytest.mark.slow

static_equilibrium_jit, cabin_modes_jit = jax.jit(static_equilibrium), jax.jit(cabin_modes)

PARAMS = paper_fast_params()
POS = jnp.array([30.0, 0.0, 142.8])  # Table 2's second position: no symmetry to hide behind
R = jnp.eye(3)


@pytest.fixture(scope="module")
def static():
    return static_equilibrium_jit(PARAMS, POS, R)


@pytest.fixture(scope="module")
def coarse(static):
    return lumped_modes(PARAMS, POS, 8, static=static)


@pytest.fixture(scope="module")
def fine(static):
    return lumped_modes(PARAMS, POS, 16, static=static)


def _errors(m, static):
    st = m.statics
    F = np.asarray(static.force)
    w = PARAMS.cable.rho * PARAMS.cable.g * np.asarray(static.s0)
    top = np.linalg.norm(F + np.array([0.0, 0.0, 1.0]) * w[:, None], axis=-1)
    n = st.nodes.shape[1] - 1
    nodes = np.asarray(catenary_nodes(PARAMS, POS, R, static, n))
    return {
        "sag_m": np.linalg.norm(np.asarray(st.q[:3])),
        "tilt_rad": np.linalg.norm(np.asarray(st.q[3:])),
        # the cable's force on the cabin is -F of eqs. 6-13
        "anchor_n": np.max(np.abs(np.asarray(st.anchor_force_n) + F)),
        "top_n": np.max(np.abs(np.asarray(st.top_tension_n) - top)),
        "nodes_m": np.max(np.abs(np.asarray(st.nodes[:, 1:-1]) - nodes)),
    }


def test_statics_converge_to_the_catenary_at_second_order(coarse, fine, static):
    e8, e16 = _errors(coarse, static), _errors(fine, static)
    for k in e8:
        order = np.log2(e8[k] / e16[k])
        assert 1.85 < order < 2.15, (k, e8[k], e16[k], order)
    # and small in absolute terms at N = 16: the cabin sags by millimetres, forces within 0.2 %
    assert e16["sag_m"] < 0.02
    assert e16["anchor_n"] < 2e-3 * np.min(np.linalg.norm(np.asarray(static.force), axis=-1))
    for m in (coarse, fine):
        assert bool(m.statics.converged) and not np.any(np.asarray(m.statics.slack))
        assert float(m.statics.residual_n) < 1e-4


def test_cabin_stiffness_with_free_nodes_tends_to_the_quasi_static_cables(coarse, fine, static):
    # K_cc − K_cn K_nn⁻¹ K_nc: the static stiffness the continuous, quasi-static cables give
    # (implicit differentiation of eqs. 11-13, an independent formula)
    Kq = np.asarray(cabin_modes_jit(PARAMS, POS, R, static).stiffness)
    err = [np.max(np.abs(np.asarray(lumped_stiffness_schur(m)) - Kq)) / np.max(np.abs(Kq)) for m in (coarse, fine)]
    assert err[1] < 2e-3
    assert 1.8 < np.log2(err[0] / err[1]) < 2.2, err


def test_hessian_matches_finite_differences_of_the_gradient(fine):
    st = fine.statics
    n = st.nodes.shape[1] - 1
    X = st.nodes[:, 1:-1]

    @jax.jit
    def grad(y):
        return jax.grad(lambda yy: lumped_potential(PARAMS, POS, R, st.s0, yy[:6], yy[6:].reshape(X.shape)))(y)

    y0 = jnp.concatenate([st.q, X.reshape(-1)])
    K = np.asarray(fine.stiffness)
    rng = np.random.default_rng(0)
    for _ in range(3):
        v = rng.normal(size=y0.shape[0]) * np.r_[np.full(3, 1e-3), np.full(3, 1e-5), np.full(18 * (n - 1), 1e-3)]
        fd = (np.asarray(grad(y0 + v)) - np.asarray(grad(y0 - v))) / 2.0
        np.testing.assert_allclose(fd, K @ v, rtol=0, atol=1e-5 * np.max(np.abs(K @ v)))


def test_modes_are_m_orthonormal_and_shares_add_up(fine, static):
    K, M, phi = (np.asarray(a) for a in (fine.stiffness, fine.mass, fine.shapes))
    w2 = (2 * np.pi * np.asarray(fine.frequencies_hz)) ** 2
    np.testing.assert_allclose(phi.T @ M @ phi, np.eye(len(w2)), atol=1e-9)
    np.testing.assert_allclose(phi.T @ K @ phi, np.diag(w2), atol=1e-7 * w2.max())
    assert np.all(np.diff(w2) >= 0) and bool(fine.stable)
    share = np.asarray(fine.compliance_share)
    np.testing.assert_allclose(share.sum(axis=0), 1.0, atol=1e-8)
    # static compliance by a direct solve, not the modal sum
    np.testing.assert_allclose(np.asarray(fine.compliance), np.diag(np.linalg.inv(K))[:6], rtol=1e-7)
    e = np.asarray(fine.cabin_energy_share)
    assert np.all((e > -1e-12) & (e < 1 + 1e-12))
    # the translational mass: assembly + the cables, less the tower-end half segments
    s0 = np.asarray(static.s0)
    m_asm = 25731.0 + 2371.0 + 6 * (165.34 + 60.12)
    total = M[0, 0] + np.trace(M[6:, 6:]) / 3.0
    np.testing.assert_allclose(total, m_asm + PARAMS.cable.rho * np.sum(s0) * (1 - 0.5 / 16), rtol=1e-12)


def test_light_cables_recover_the_quasi_static_modes():
    # cables 1000 times lighter: their string modes move ~30x up, and the six lowest modes are
    # the cabin's on quasi-static cables (Yin et al.'s model) up to O(1e-3) cable inertia
    light = paper_fast_params()
    light = type(light)(**{**{f: getattr(light, f) for f in light.__dataclass_fields__},
                           "cable": CableParams(EA=1.243e8, rho=13.898e-3, g=-9.8)})
    st = static_equilibrium(light, POS, R, rtol=1e-11)  # 1e-13 is below the rounding of weightless cables
    assert bool(st.converged)
    qs = np.asarray(cabin_modes_jit(light, POS, R, st).frequencies_hz)
    lm = lumped_modes(light, POS, 16, static=st)
    np.testing.assert_allclose(np.asarray(lm.frequencies_hz[:6]), qs, rtol=2e-3)
    assert np.all(np.asarray(lm.cabin_energy_share[:6]) > 0.99)
    assert lm.frequencies_hz[6] > 2.0 * qs[-1]


def test_cable_inertia_brings_the_lowest_cabin_mode_into_the_measured_band(fine, static):
    # Li, Sun, Li, Yao (2024) measured the lowest cabin-cable mode of FAST at 0.12-0.2 Hz; the
    # quasi-static cables give 0.25 Hz here, the lumped ones a cabin-carrying mode in the band
    qs = np.asarray(cabin_modes_jit(PARAMS, POS, R, static).frequencies_hz)
    s = modal_summary(fine, cutoff_hz=1.0)
    assert np.all(np.diff(s.frequencies_hz) >= 0) and s.frequencies_hz[-1] < 1.0
    first_cabin = s.frequencies_hz[np.asarray(s.kind) == "cabin"][0]
    assert 0.12 <= first_cabin <= 0.2 < qs[0]
    assert "string" in s.kind
    for _, (index, freq, share) in s.dominant.items():
        assert 0 < share <= 1 and freq == float(fine.frequencies_hz[index])


def test_bad_input(static):
    for n in (1, 0, 2.5, True):
        with pytest.raises(ValueError, match="segments"):
            lumped_statics(PARAMS, POS, n)
    with pytest.raises(ValueError, match="no static equilibrium of the elastic catenaries"):
        lumped_statics(PARAMS, np.array([150.0, 0.0, 200.0]), 8)
    # a third cable three times too long still hangs in tension (a chain under gravity has no
    # slack segment at rest): the solver finds that equilibrium, with cable 3 carrying little
    long = lumped_statics(PARAMS, POS, 8, static=static._replace(s0=static.s0.at[2].multiply(3.0)))
    T = np.asarray(long.anchor_tension_n)
    assert bool(long.converged) and T[2] < 0.6 * np.delete(T, 2).min()
    # an iteration that stalls with slack segments names the cables
    bad = long._replace(converged=jnp.asarray(False), residual_n=jnp.asarray(1e5),
                        slack=jnp.array([False, False, True, False, False, True]))
    with pytest.raises(ValueError, match=r"no equilibrium.*slack segments.*cable 3, cable 6"):
        _raise_if_failed(bad, POS, static)
    with pytest.raises(ValueError, match=r"slack segment in cable 3 at the lumped-mass equilibrium"):
        _raise_if_failed(long._replace(slack=jnp.array([False, False, True, False, False, False])), POS, static)
