import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import jit_ik, perturbed_geometry, travel_grid

import stewart_jax as sj


def _rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def numpy_ik(upper, lower, v0, pose):
    """Eq. 4 written directly (independent of the library's rationalised form)."""
    T = _rz(pose[5]) @ _ry(pose[4]) @ _rx(pose[3])
    L = np.linalg.norm(upper + v0 - lower, axis=1)
    a = upper @ T.T + pose[:3] + v0
    return a[:, 2] - lower[:, 2] - np.sqrt(L**2 - (lower[:, 0] - a[:, 0]) ** 2 - (lower[:, 1] - a[:, 1]) ** 2)


def test_rotation_is_product_of_elementary_rotations():
    rng = np.random.default_rng(1)
    angles = rng.uniform(-np.pi, np.pi, (50, 3))
    got = np.asarray(sj.rotation_matrix(jnp.asarray(angles)))
    for a, r in zip(angles, got, strict=True):
        np.testing.assert_allclose(r, _rz(a[2]) @ _ry(a[1]) @ _rx(a[0]), atol=1e-15)


def test_euler_angles_invert_rotation():
    rng = np.random.default_rng(2)
    angles = rng.uniform([-3, -1.5, -3], [3, 1.5, 3], (50, 3))
    back = sj.euler_angles(sj.rotation_matrix(jnp.asarray(angles)))
    np.testing.assert_allclose(back, angles, atol=1e-12)


def test_nominal_rod_lengths_match_table1():
    # Table 1 gives no rod length; the paper's text and SPEC §2 say ≈221.4 mm with v0 = 0.
    # Computed independently from the table values (one decimal) in plain NumPy.
    up = np.array([[103.6, 34.6, 84.7], [-21.5, 107.1, 84.7], [-81.8, 72.4, 84.7]])
    lo = np.array([[67.9, 61.8, -132.1], [19.6, 89.7, -132.1], [-87.5, 27.9, -132.1]])
    L = np.asarray(sj.nominal_geometry().rod_lengths)
    np.testing.assert_allclose(L[:3], np.linalg.norm(up - lo, axis=1), atol=1e-12)
    np.testing.assert_allclose(L, 221.4, atol=0.06)


@pytest.mark.parametrize("seed", range(5))
def test_ik_exactly_zero_at_zero_pose(seed):
    g = perturbed_geometry(seed)
    assert np.array_equal(np.asarray(sj.inverse_kinematics(g, np.zeros(6))), np.zeros(6))


def test_ik_matches_direct_numpy_formula(preset, grid):
    q = np.asarray(jit_ik(preset, jnp.asarray(grid)).readings)
    up, lo, v0 = (np.asarray(x) for x in (preset.upper, preset.lower, preset.v0))
    ref = np.array([numpy_ik(up, lo, v0, p) for p in grid])
    # The direct formula loses ~1e-13 mm to cancellation; 1e-10 mm leaves margin.
    np.testing.assert_allclose(q, ref, atol=1e-10, rtol=0)


def test_fk_of_ik_round_trip(preset, grid):
    q = sj.inverse_kinematics(preset, grid)
    sol = sj.forward_kinematics(preset, q)
    assert bool(np.all(sol.converged))
    err = np.abs(np.asarray(sol.poses) - grid)
    assert err[:, :3].max() <= 1e-9  # mm
    assert err[:, 3:].max() <= 1e-12  # rad


def test_ik_of_fk_round_trip(preset):
    # Readings not produced by IK: IK of the grid perturbed by ±0.1 mm per leg.
    grid = travel_grid(seed=5, n_random=100)
    rng = np.random.default_rng(3)
    q = np.asarray(sj.inverse_kinematics(preset, grid)) + rng.uniform(-0.1, 0.1, (len(grid), 6))
    sol = sj.forward_kinematics(preset, q)
    assert bool(np.all(sol.converged))
    np.testing.assert_allclose(sj.inverse_kinematics(preset, sol.poses), q, atol=1e-9, rtol=0)


def test_round_trip_with_v0_and_perturbed_geometry():
    g = perturbed_geometry(11)
    grid = travel_grid(seed=7, n_random=50)
    sol = sj.forward_kinematics(g, sj.inverse_kinematics(g, grid))
    assert bool(np.all(sol.converged))
    np.testing.assert_allclose(sol.poses, grid, atol=1e-12, rtol=0)


def test_jacobian_matches_finite_differences(actual):
    h = 1e-6
    for pose in travel_grid(seed=9, n_random=5)[-5:]:
        J = np.asarray(actual.ik_and_jacobian(jnp.asarray(pose))[2])
        fd = np.empty((6, 6))
        for k in range(6):
            dp = np.zeros(6)
            dp[k] = h
            hi, lo = jit_ik(actual, pose + dp).readings, jit_ik(actual, pose - dp).readings
            fd[:, k] = (np.asarray(hi) - np.asarray(lo)) / (2 * h)
        # Central differences: truncation O(h²)·|q'''| ~ 1e-12, rounding ~1e-13/h ~ 1e-7.
        np.testing.assert_allclose(J, fd, atol=1e-6, rtol=1e-7)


def test_unreachable_pose_raises_and_reports(actual):
    far = np.array([300.0, 0, 0, 0, 0, 0])
    sol = actual.solve_inverse_kinematics(jnp.asarray(far))
    assert not bool(sol.reachable) and np.all(np.isfinite(np.asarray(sol.readings)))
    with pytest.raises(ValueError, match="unreachable"):
        sj.inverse_kinematics(actual, far)
    batch = np.stack([np.zeros(6), far])
    with pytest.raises(ValueError, match=r"first at index \(1,\)"):
        sj.inverse_kinematics(actual, batch)
    with pytest.raises(Exception, match="unreachable"):
        jax.block_until_ready(jax.jit(sj.inverse_kinematics)(actual, jnp.asarray(far)))


def test_bad_inputs_raise_clear_errors(actual):
    with pytest.raises(ValueError, match="NaN"):
        sj.inverse_kinematics(actual, np.array([0, np.nan, 0, 0, 0, 0]))
    with pytest.raises(ValueError, match="degrees"):
        sj.inverse_kinematics(actual, np.array([0, 0, 0, 1.0, 0, 0]))
    with pytest.raises(ValueError, match="last axis of 6"):
        sj.inverse_kinematics(actual, np.zeros(5))
    with pytest.raises(ValueError, match="NaN"):
        sj.forward_kinematics(actual, np.array([0, 0, np.inf, 0, 0, 0]))
    with pytest.raises(ValueError, match="shape"):
        sj.mechanism.PSSMechanism(np.zeros((5, 3)), np.zeros((6, 3)))


def test_unattainable_readings_report_status_not_nan(actual):
    sol = sj.forward_kinematics(actual, np.array([[0, 0, 500.0, 0, 0, 0], [0.1] * 6]))
    assert list(np.asarray(sol.converged)) == [False, True]
    assert np.all(np.isfinite(np.asarray(sol.poses)))
    with pytest.raises(Exception, match="did not converge"):
        jax.block_until_ready(sj.forward_kinematics(actual, np.array([0, 0, 500.0, 0, 0, 0]), throw=True).poses)


def test_jit_vmap_and_broadcasting_agree(actual, grid):
    g = jnp.asarray(grid)
    plain = actual.solve_inverse_kinematics(g).readings
    vm = jax.vmap(actual.solve_inverse_kinematics)(g).readings
    jv = jax.jit(jax.vmap(actual.solve_inverse_kinematics))(g).readings
    j = jit_ik(actual, g).readings
    # Within one compilation mode the results are bit-identical...
    np.testing.assert_array_equal(vm, plain)
    np.testing.assert_array_equal(jv, j)
    # ...across modes XLA fuses eager and jitted code differently (FMA contraction), which
    # moves a ~4 mm stroke by a few ulps (ulp = 8.9e-16 mm): allow 8 ulps.
    np.testing.assert_allclose(j, plain, atol=8 * np.spacing(4.0), rtol=0)


def test_vmap_over_parameter_sets(grid):
    geoms = [perturbed_geometry(s) for s in range(4)]
    params = jnp.stack([g.params for g in geoms])
    v0s = jnp.stack([g.v0 for g in geoms])

    def ik(p, v):
        return sj.mechanism.PSSMechanism.from_params(p, v).solve_inverse_kinematics(jnp.asarray(grid)).readings

    batched = jax.jit(jax.vmap(ik))(params, v0s)
    for g, q in zip(geoms, batched, strict=True):
        np.testing.assert_array_equal(q, jax.jit(ik)(g.params, g.v0))


def test_geometry_params_round_trip_and_json(tmp_path, actual):
    g = sj.mechanism.PSSMechanism.from_params(actual.params, [1.0, -2.0, 3.0])
    np.testing.assert_array_equal(g.upper, actual.upper)
    np.testing.assert_array_equal(g.lower, actual.lower)
    path = tmp_path / "g.json"
    sj.save_mechanism(g, path)
    back = sj.load_mechanism(path)
    for a, b in ((g.upper, back.upper), (g.lower, back.lower), (g.v0, back.v0)):
        np.testing.assert_array_equal(a, b)
    toml = tmp_path / "g.toml"
    toml.write_text("params = [" + ", ".join(repr(float(x)) for x in np.asarray(actual.params)) + "]\n")
    np.testing.assert_array_equal(sj.load_mechanism(toml).params, actual.params)
    with pytest.raises(ValueError, match="preset"):
        sj.mechanism.preset("true")
