import jax
import jax.numpy as jnp
import numpy as np
from conftest import ARCSEC, UM

import stewart_jax as sj

# The simulated laser tracker's building blocks (private), tested on their own: the Kabsch fit
# against an exact transform, one measurement against the linearised fit's noise.
from stewart_jax.calibration._simulation import rigid_fit, tracker_measure


def test_plan120_structure():
    plan = np.asarray(sj.plan_poses("plan120", jax.random.key(0)))
    assert plan.shape == (120, 6)
    assert len({tuple(p) for p in plan}) == 120
    disp = {tuple(p) for p in plan[:, :3]}
    assert len(disp) == 15
    expected = {(x, y, z) for x in (0.5, -0.5) for y in (0.5, -0.5) for z in (0.5, -0.5)}
    expected |= {(0.0, 0.0, 0.0)} | {tuple(s * np.eye(3)[i]) for i in range(3) for s in (1.0, -1.0)}
    assert disp == {tuple(map(float, d)) for d in expected}
    half = np.deg2rad(0.5)
    np.testing.assert_allclose(np.abs(plan[:, 3:]), half, rtol=1e-15)
    for d in disp:  # each displacement point with all 8 sign combinations of the angles
        rows = plan[np.all(plan[:, :3] == d, axis=1)]
        assert len({tuple(np.sign(r[3:])) for r in rows}) == 8


def test_validation_poses_in_travel_and_off_plan():
    val = np.asarray(sj.calibration.validation_poses(jax.random.key(3)))
    assert val.shape == (42, 6)
    assert np.all(np.abs(val[:, :3]) <= 1.0) and np.all(np.abs(val[:, 3:]) <= np.deg2rad(1.0))
    plan = np.asarray(sj.plan_poses("plan120", jax.random.key(0)))
    assert np.min(np.abs(val[:, None] - plan[None]).max(-1)) > 1e-6
    # Excluding a pose forces a redraw even for an exact hit.
    val2 = np.asarray(sj.calibration.validation_poses(jax.random.key(3), exclude=jnp.asarray(val[:1])))
    assert not np.any(np.all(val2 == val[0], axis=1))


def test_simulated_data_follow_the_protocol(nominal, actual):
    k1, k2 = jax.random.split(jax.random.key(11))
    targets = sj.calibration.random_poses(k1, 400)
    sim = sj.simulate_measurements(k2, nominal, actual, targets, sigma_um=0.5, sigma_arcsec=2.0)
    assert bool(np.all(sim.converged))
    np.testing.assert_allclose(sim.data.readings, sj.inverse_kinematics(nominal, targets), atol=0)
    np.testing.assert_allclose(sj.inverse_kinematics(actual, sim.true_poses), sim.data.readings, atol=1e-10)
    noise = np.asarray(sim.data.poses - sim.true_poses)
    std = np.concatenate([noise[:, :3].std(0) / UM, noise[:, 3:].std(0) / ARCSEC])
    # 400 samples: the sample std is within ±15 % of σ with probability > 0.999 per component.
    np.testing.assert_allclose(std, [0.5] * 3 + [2.0] * 3, rtol=0.15)


def test_rigid_fit_recovers_exact_transform():
    rng = np.random.default_rng(0)
    body = rng.normal(size=(5, 3)) * 50
    angles = rng.uniform(-0.3, 0.3, 3)
    R = np.asarray(sj.rotation_matrix(jnp.asarray(angles)))
    t = rng.normal(size=3)
    rot, trans = rigid_fit(jnp.asarray(body), jnp.asarray(body @ R.T + t))
    np.testing.assert_allclose(rot, R, atol=1e-13)
    np.testing.assert_allclose(trans, t, atol=1e-12)


def test_tracker_measurement_noise_level(actual):
    tracker = sj.calibration.tracker_for(actual)
    pose = jnp.array([0.3, -0.2, 0.1, 0.005, -0.01, 0.008])
    keys = jax.random.split(jax.random.key(5), 2000)
    measure = jax.vmap(tracker_measure, in_axes=(0, None, None, None))
    meas = np.asarray(measure(keys, tracker, pose, actual.v0))
    exact = tracker_measure(keys[0], sj.calibration.LaserTracker(tracker.balls, 0.0), pose, actual.v0)
    np.testing.assert_allclose(exact, pose, atol=1e-12)
    err = meas - np.asarray(pose)
    # The centroid of 3 points averages the noise: translation σ ≈ 3 µm/√3 for a fit about the
    # ball centroid, here offset 90 mm from A's origin, which adds rotation noise × 90 mm.
    # Independent check: the linearised least-squares covariance of the same fit.
    assert np.all(np.abs(err.mean(0)) < 4 * err.std(0) / np.sqrt(len(err)))
    assert 1.0 < err[:, 0].std() / UM < 6.0
    assert np.all(err[:, 3:].std(0) / ARCSEC > 1.0)
