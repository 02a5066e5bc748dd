"""The sparse route to the lumped-mass cables' modes below a cut-off (block Hessian, chain
solves, banded eigenvalues, inverse iteration) against the dense route (``jax.hessian`` of the
energy, a dense solve, a dense generalised eigen-solve of every mode), and its refusals."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.linalg

import stewart_jax  # noqa: F401
from stewart_jax.cable_robot import _lumped_blocks as blocks, _lumped_low, paper_fast_params
from stewart_jax.cable_robot._lumped import catenary_nodes, lumped_modes, lumped_potential
from stewart_jax.cable_robot._lumped_low import lumped_low_modes, modal_summary
from stewart_jax.cable_robot._statics import static_equilibrium_jit
from stewart_jax.cable_robot._workspace import assembly_centre_of_mass

# The slow tier (make test-all runs it, make test does not): the low-mode solver against dense modes at two
# positions (60 s on 2 cores).
pytestmark = pytest.mark.slow

PARAMS = paper_fast_params()
R = jnp.eye(3)
N = 8
POSITIONS = {"off_centre": jnp.array([30.0, 0.0, 142.8]), "centre": jnp.array([0.0, 0.0, 140.0])}


@pytest.fixture(scope="module", params=list(POSITIONS))
def pair(request):
    pos = POSITIONS[request.param]
    st = static_equilibrium_jit(PARAMS, pos, R)
    return lumped_modes(PARAMS, pos, N, static=st), lumped_low_modes(PARAMS, pos, N, 1.5, static=st)


def test_blocks_are_the_hessian_and_solve_and_band_agree_with_dense_algebra():
    # a non-equilibrium point (catenary nodes, cabin moved) so that every term counts
    pos = POSITIONS["off_centre"]
    n = 3
    st = static_equilibrium_jit(PARAMS, pos, R)
    X = catenary_nodes(PARAMS, pos, R, st, n) + 0.01
    q = jnp.array([1e-3, -2e-3, 5e-4, 1e-4, -2e-4, 3e-4])
    m, com = assembly_centre_of_mass(PARAMS, pos, R)
    # both jitted: op by op they take 40 s under the suite's -O0
    b = jax.jit(blocks.potential_blocks)(PARAMS, pos, R, st.s0, q, X, m, R.T @ (com - pos))
    y = jnp.concatenate([q, X.reshape(-1)])
    H = jax.jit(jax.hessian(lambda yy: lumped_potential(PARAMS, pos, R, st.s0, yy[:6], yy[6:].reshape(X.shape))))(y)
    H = np.asarray(0.5 * (H + H.T))
    K = np.asarray(blocks.dense(b))
    np.testing.assert_allclose(K, H, rtol=0, atol=1e-12 * np.max(np.abs(H)))
    # the chain-by-chain solve of K − σM against a dense solve
    rng = np.random.default_rng(0)
    Mcc = rng.normal(size=(6, 6))
    Mcc = Mcc @ Mcc.T + 6 * np.eye(6)
    mn = np.array([1.0, 2.0, 3.0, 1.5, 2.5, 0.5])
    M = scipy.linalg.block_diag(Mcc, np.diag(np.repeat(mn, 3 * (n - 1))))
    r = rng.normal(size=K.shape[0])
    sigma = 0.3 * np.max(np.abs(np.diag(K)))
    xc, xn = blocks.solve(blocks.factor(blocks.shifted(b, sigma, Mcc, mn)), jnp.asarray(r[:6]),
                          jnp.asarray(r[6:]).reshape(6, n - 1, 3))
    x = np.linalg.solve(K - sigma * M, r)
    np.testing.assert_allclose(np.r_[xc, np.ravel(xn)], x, rtol=0, atol=1e-9 * np.max(np.abs(x)))
    # the banded standard form: the same eigenvalues as the dense pencil
    ab, _ = blocks.band_standard_form(b, Mcc, mn)
    w = scipy.linalg.eigvals_banded(np.asarray(ab), lower=False)
    np.testing.assert_allclose(w, scipy.linalg.eigh(K, M, eigvals_only=True), rtol=1e-10,
                               atol=1e-12 * np.max(np.abs(w)))


def test_low_modes_equal_the_dense_modes_below_the_cut_off(pair):
    dense, low = pair
    assert low.method == "banded" and bool(low.ok) and bool(low.stable)
    f = np.asarray(low.frequencies_hz)
    k = f.shape[0]
    fd = np.asarray(dense.frequencies_hz)
    assert f[-1] < 1.5 <= fd[k]
    # NOTE: both are at the rounding of an eigen-solve of a matrix whose norm is set by the
    # segments' axial stiffness (ε‖A‖/λ ≈ 1e-11 for the lowest mode at N = 8)
    np.testing.assert_allclose(f, fd[:k], rtol=1e-9)
    assert float(low.residual) < 1e-8
    np.testing.assert_allclose(np.asarray(low.cabin_energy_share), np.asarray(dense.cabin_energy_share[:k]),
                               rtol=0, atol=1e-8)
    np.testing.assert_allclose(np.asarray(low.compliance), np.asarray(dense.compliance), rtol=1e-9)
    # a repeated mode's shares depend on the basis chosen inside its eigenspace: compare the
    # shares summed over each group of equal frequencies
    group = np.concatenate([[0], np.cumsum(np.diff(fd[:k]) > 1e-7 * fd[1:k])])
    for a, b in ((low.compliance_share, dense.compliance_share[:k]), (low.cabin_energy_share,
                                                                       dense.cabin_energy_share[:k])):
        sa = np.stack([np.sum(np.asarray(a)[group == g], axis=0) for g in np.unique(group)])
        sb = np.stack([np.sum(np.asarray(b)[group == g], axis=0) for g in np.unique(group)])
        np.testing.assert_allclose(sa, sb, rtol=0, atol=1e-8)
    np.testing.assert_allclose(np.asarray(low.compliance_resolved),
                               np.sum(np.asarray(dense.compliance_share[:k]), axis=0), atol=1e-8)
    # M-orthonormal eigenvectors of the dense pencil
    K, M, phi = np.asarray(dense.stiffness), np.asarray(dense.mass), np.asarray(low.shapes)
    np.testing.assert_allclose(phi.T @ M @ phi, np.eye(k), atol=1e-9)
    w2 = (2 * np.pi * f) ** 2
    np.testing.assert_allclose(K @ phi, (M @ phi) * w2, rtol=0, atol=1e-8 * np.max(np.abs(K @ phi)))
    sd, sl = modal_summary(dense), modal_summary(low)
    np.testing.assert_allclose(sl.frequencies_hz, sd.frequencies_hz, rtol=1e-9)
    assert sl.kind == sd.kind
    for name, (_, fi, share) in sd.dominant.items():
        _, fj, share_low = sl.dominant[name]
        assert np.isclose(fj, fi, rtol=1e-9) and np.isclose(share_low, share, atol=1e-8), name


def test_dominant_mode_is_named_only_where_the_modes_below_the_cut_off_tell():
    pos = POSITIONS["off_centre"]
    st = static_equilibrium_jit(PARAMS, pos, R)
    dense = modal_summary(lumped_modes(PARAMS, pos, N, static=st))
    # below 0.2 Hz the rotations' compliance mostly lies above: no verdict without more modes
    low = lumped_low_modes(PARAMS, pos, N, 0.2, static=st, resolve_dominant=False)
    s = modal_summary(low, cutoff_hz=0.2)
    missing = [k for k, v in s.dominant.items() if v is None]
    assert missing, s.dominant
    rest = 1.0 - np.asarray(low.compliance_resolved)
    for k, name in enumerate(s.dominant):
        best = float(np.max(np.asarray(low.compliance_share)[:, k]))
        assert (s.dominant[name] is None) == (best <= rest[k])
        if s.dominant[name] is not None:   # a named one is the dense route's
            assert np.isclose(s.dominant[name][1], dense.dominant[name][1], rtol=1e-9)
    # raising the cut-off until every verdict is earned gives the dense route's verdicts
    full = lumped_low_modes(PARAMS, pos, N, 0.2, static=st)
    assert full.cutoff_hz > 0.2
    s = modal_summary(full, cutoff_hz=0.2)
    assert np.all(s.frequencies_hz < 0.2)
    for name, (_, f, share) in dense.dominant.items():
        assert np.isclose(s.dominant[name][1], f, rtol=1e-9) and np.isclose(s.dominant[name][2], share, atol=1e-8)
    with pytest.raises(ValueError, match="above"):
        modal_summary(low, cutoff_hz=0.5)


def test_a_failed_check_falls_back_on_the_dense_route(monkeypatch):
    pos = POSITIONS["off_centre"]
    st = static_equilibrium_jit(PARAMS, pos, R)

    def fail(*args, **kwargs):
        raise np.linalg.LinAlgError("not positive definite")

    monkeypatch.setattr(_lumped_low, "_rayleigh_ritz", fail)
    low = lumped_low_modes(PARAMS, pos, N, 1.5, static=st)
    dense = lumped_modes(PARAMS, pos, N, static=st)
    assert low.method == "dense"
    keep = np.asarray(dense.frequencies_hz) < low.cutoff_hz
    np.testing.assert_array_equal(np.asarray(low.frequencies_hz), np.asarray(dense.frequencies_hz)[keep])
    assert float(low.residual) < 1e-8


def test_a_poor_vector_is_recomputed_with_a_moved_shift(monkeypatch):
    # one inverse-iteration vector left off its eigenvector (as a near-singular chain pivot
    # leaves it): its residual fails the 1e-9 check, it is recomputed with the shift moved by
    # 1e-6 λ, and the banded route still gives the dense route's modes
    pos = POSITIONS["off_centre"]
    st = static_equilibrium_jit(PARAMS, pos, R)
    dense = lumped_modes(PARAMS, pos, N, static=st)
    K, M = np.asarray(dense.stiffness), np.asarray(dense.mass)
    real, calls = _lumped_low._inverse_iteration_jit, []

    def spoiled(prep, lam, tau, chunk, label):
        V, MV, KV = (np.array(a) for a in real(prep, lam, tau, chunk, label))
        calls.append(int(chunk))
        if int(chunk) == 0:
            e = 1e-9 * np.linalg.norm(V[:, 5]) * np.random.default_rng(1).normal(size=V.shape[0])
            V[:, 5] += e
            MV[:, 5] += M @ e
            KV[:, 5] += K @ e
        return V, MV, KV

    monkeypatch.setattr(_lumped_low, "_inverse_iteration_jit", spoiled)
    low = lumped_low_modes(PARAMS, pos, N, 1.5, static=st)
    assert 1000 in calls and low.method == "banded"
    k = low.frequencies_hz.shape[0]
    np.testing.assert_allclose(np.asarray(low.frequencies_hz), np.asarray(dense.frequencies_hz)[:k], rtol=1e-9)
    assert float(low.residual) < 1e-8


def test_bad_input():
    pos = POSITIONS["off_centre"]
    for cut in (0.0, -1.0, float("nan"), "1"):
        with pytest.raises(ValueError, match="cutoff_hz"):
            lumped_low_modes(PARAMS, pos, N, cut)
    with pytest.raises(ValueError, match="no mode below"):
        lumped_low_modes(PARAMS, pos, N, 0.01)
    with pytest.raises(ValueError, match="segments"):
        lumped_low_modes(PARAMS, pos, 1)
    with pytest.raises(ValueError, match="no static equilibrium of the elastic catenaries"):
        lumped_low_modes(PARAMS, np.array([150.0, 0.0, 200.0]), N)
