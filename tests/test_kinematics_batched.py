"""The batched fast paths agree with the reference kinematics (the mechanism's `solve_inverse_kinematics`)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import stewart_jax as sj
from stewart_jax.mechanism import (
    forward_kinematics_newton,
    inverse_kinematics_sharded,
    inverse_kinematics_soa,
)

POLY_RANGE = 0.5  # rad: the documented range of the fast path's polynomial sin/cos


def travel_poses(seed: int, n: int) -> np.ndarray:
    """Uniform in the ±1 mm, ±1° travel, (n, 6)."""
    rng = np.random.default_rng(seed)
    return np.concatenate(
        [rng.uniform(-1.0, 1.0, (n, 3)), np.deg2rad(rng.uniform(-1.0, 1.0, (n, 3)))], axis=1
    )


ik_ref = jax.jit(lambda mechanism, poses: mechanism.solve_inverse_kinematics(poses))
ik_soa = jax.jit(inverse_kinematics_soa)

GEOMETRIES = {
    "nominal": sj.nominal_geometry(),
    "actual": sj.actual_geometry(),
    "actual_v0": sj.actual_geometry(v0=(0.3, -0.2, 1.5)),
}


@pytest.mark.parametrize("name", sorted(GEOMETRIES))
def test_ik_soa_matches_reference(name):
    g = GEOMETRIES[name]
    poses = travel_poses(0, 257)
    ref = ik_ref(g, poses)
    got = ik_soa(g, poses.T)
    assert got.readings.shape == (6, 257) and got.reachable.shape == (257,)
    np.testing.assert_allclose(np.asarray(got.readings).T, ref.readings, rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.asarray(got.margin).T, ref.margin, rtol=1e-12, atol=0)
    np.testing.assert_array_equal(got.reachable, ref.reachable)
    assert bool(np.all(got.reachable))


def test_ik_soa_exact_branch_beyond_polynomial_range():
    g = sj.actual_geometry()
    poses = travel_poses(1, 32)
    poses[5, 4] = POLY_RANGE + 0.1  # outside the polynomial's range → jnp.sin/cos path
    ref = ik_ref(g, poses)
    got = ik_soa(g, poses.T)
    np.testing.assert_allclose(np.asarray(got.readings).T, ref.readings, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(got.reachable, ref.reachable)


def test_ik_soa_trailing_batch_shape_and_unreachable():
    g = sj.nominal_geometry()
    poses = travel_poses(2, 20)
    poses[3, 0] = 400.0  # no rod spans that: unreachable, reported
    ref = ik_ref(g, poses)
    got = ik_soa(g, poses.T.reshape(6, 4, 5))
    assert got.readings.shape == (6, 4, 5) and got.reachable.shape == (4, 5)
    np.testing.assert_array_equal(np.asarray(got.reachable).reshape(20), ref.reachable)
    assert not bool(got.reachable.reshape(20)[3])
    assert bool(np.all(np.isfinite(got.readings)))
    np.testing.assert_allclose(
        np.asarray(got.readings).reshape(6, 20).T, ref.readings, rtol=0, atol=1e-12
    )


def test_ik_soa_vmaps_over_geometries():
    poses = travel_poses(3, 16)
    params = jnp.stack([GEOMETRIES["nominal"].params, GEOMETRIES["actual"].params])
    got = jax.jit(
        jax.vmap(lambda p: inverse_kinematics_soa(sj.mechanism.PSSMechanism.from_params(p), poses.T).readings)
    )(params)
    for k, name in enumerate(("nominal", "actual")):
        ref = ik_ref(GEOMETRIES[name], poses).readings
        np.testing.assert_allclose(np.asarray(got[k]).T, ref, rtol=0, atol=1e-12)


def test_ik_soa_rejects_wrong_layout():
    with pytest.raises(ValueError, match="first axis of 6"):
        inverse_kinematics_soa(sj.nominal_geometry(), np.zeros((10, 6)))


def test_polynomial_branch_matches_the_libm_branch():
    # The same poses through the polynomial sin/cos (every angle within ±0.5 rad) and through
    # jnp.sin/cos (one extra pose beyond the range switches the whole batch). A 1-ulp error in
    # sin/cos moves a ~200 mm leg by ~4e-14 mm, so 1e-13 mm bounds a polynomial that is within
    # an ulp or two over the whole range, ends included.
    g = sj.actual_geometry()
    x = np.linspace(-POLY_RANGE, POLY_RANGE, 2001)
    poses = np.zeros((3 * len(x), 6))
    for k in range(3):
        poses[k * len(x):(k + 1) * len(x), 3 + k] = x
    poly = inverse_kinematics_soa(g, poses.T).readings
    beyond = np.concatenate([poses, [[0, 0, 0, 0, 0, POLY_RANGE + 0.1]]])
    exact = inverse_kinematics_soa(g, beyond.T).readings[:, :-1]
    np.testing.assert_allclose(poly, exact, rtol=0, atol=1e-13)


def test_analytic_jacobian_matches_autodiff():
    g = sj.actual_geometry(v0=(0.3, -0.2, 1.5))
    poses = jnp.asarray(travel_poses(4, 8))
    jac = jax.jit(lambda g, p: g.ik_and_jacobian(p)[2])(g, poses)
    autodiff = jax.jacfwd(lambda p: g.solve_inverse_kinematics(p).readings)
    ref = jax.jit(jax.vmap(autodiff))(poses)
    np.testing.assert_allclose(jac, ref, rtol=0, atol=1e-11)


@pytest.mark.parametrize("chunk_size", [4096, 7])
def test_fk_newton_matches_reference(chunk_size):
    g = sj.actual_geometry()
    poses = travel_poses(5, 30)  # 30 = 4 chunks of 7 + 2, exercises the padding
    readings = np.asarray(ik_ref(g, poses).readings)
    got = forward_kinematics_newton(g, readings, chunk_size=chunk_size)
    assert bool(np.all(got.converged))
    assert float(np.max(got.residual)) <= 1e-11
    np.testing.assert_allclose(got.poses, poses, rtol=0, atol=1e-10)
    np.testing.assert_array_equal(got.steps, 4)


def test_fk_newton_batch_shape_and_failure_is_reported():
    g = sj.nominal_geometry()
    poses = travel_poses(6, 6)
    readings = np.array(ik_ref(g, poses).readings)
    readings[2] = [500.0, -500.0, 500.0, -500.0, 500.0, -500.0]  # no pose gives these
    got = forward_kinematics_newton(g, readings.reshape(2, 3, 6))
    assert got.poses.shape == (2, 3, 6) and got.converged.shape == (2, 3)
    conv = np.asarray(got.converged).reshape(6)
    assert not conv[2] and conv[[0, 1, 3, 4, 5]].all()


def test_ik_sharded_single_device_is_soa():
    g = sj.actual_geometry()
    poses = travel_poses(7, 33)
    got = jax.jit(inverse_kinematics_sharded)(g, poses.T)
    ref = ik_ref(g, poses)
    np.testing.assert_allclose(np.asarray(got.readings).T, ref.readings, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match=r"shape \(6, N\)"):
        inverse_kinematics_sharded(g, poses.T.reshape(6, 3, 11))


_SHARDED_SCRIPT = """
import jax
jax.config.update("jax_num_cpu_devices", 2)
import numpy as np
import stewart_jax as sj
from stewart_jax.mechanism import inverse_kinematics_sharded
g = sj.actual_geometry()
rng = np.random.default_rng(8)
for n in (33, 34):  # odd: padded to the device count
    p = np.concatenate([rng.uniform(-1, 1, (n, 3)), np.deg2rad(rng.uniform(-1, 1, (n, 3)))], 1)
    p[3, 0] = 400.0
    ref = jax.jit(lambda m, q: m.solve_inverse_kinematics(q))(g, p)
    got = jax.jit(inverse_kinematics_sharded)(g, p.T)
    assert got.readings.shape == (6, n) and got.reachable.shape == (n,)
    assert float(np.max(np.abs(np.asarray(got.readings).T - ref.readings))) <= 1e-12
    assert np.array_equal(np.asarray(got.reachable), np.asarray(ref.reachable))
    assert not bool(got.reachable[3])
print("ok")
"""


def test_ik_sharded_over_two_host_devices():
    # The device count is fixed when JAX initialises, so this runs in a fresh interpreter.
    import subprocess
    import sys

    out = subprocess.run(
        [sys.executable, "-c", _SHARDED_SCRIPT], capture_output=True, text=True, timeout=300
    )
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip().endswith("ok")
