import jax
import jax.numpy as jnp
import numpy as np
import pytest

import stewart_jax as sj
from stewart_jax.calibration import (
    calibration_uncertainty,
    identifiability_report,
    plan_poses_optimal,
    predicted_control_error_std,
)
from stewart_jax.mechanism import PSSMechanism


@pytest.fixture(scope="module")
def geoms():
    return sj.nominal_geometry(), sj.actual_geometry()


def test_parameter_jacobian_matches_finite_differences(geoms):
    nom, _ = geoms
    poses = sj.calibration.random_poses(jax.random.key(0), 3)
    J = np.asarray(nom.parameter_jacobian(poses))
    u, h = np.asarray(nom.params), 1e-5
    fd = np.stack([
        (np.asarray(PSSMechanism.from_params(u + h * e).solve_inverse_kinematics(poses).readings)
         - np.asarray(PSSMechanism.from_params(u - h * e).solve_inverse_kinematics(poses).readings)).reshape(-1)
        / (2 * h)
        for e in np.eye(36)
    ], axis=1)
    np.testing.assert_allclose(J, fd, atol=1e-8)


def test_kinematic_snapshot_and_control_error_sensitivity_match_finite_differences(geoms):
    """One program serves the reachability check, the noise covariance, both Jacobians and the
    control-error sensitivity: each against central differences of the inverse kinematics."""
    from stewart_jax.calibration._identifiability import control_error_sensitivity, kinematic_snapshot

    _, act = geoms
    poses = np.asarray(sj.calibration.random_poses(jax.random.key(3), 4))
    snap = kinematic_snapshot(act, poses, sigma_um=2.0, sigma_arcsec=3.0)
    ik = lambda mech, p: np.asarray(mech.solve_inverse_kinematics(jnp.asarray(p)).readings)  # noqa: E731
    # two compiled programs fuse the same arithmetic differently: 1e-14 mm apart, not bitwise
    np.testing.assert_allclose(snap.readings, ik(act, poses), rtol=0, atol=1e-12)
    assert snap.reachable.shape == (4,) and snap.reachable.all()
    h = 1e-6  # mm and rad: the IK is smooth, central differences are good to ~1e-9 here
    jp_fd = np.stack([(ik(act, poses + h * e) - ik(act, poses - h * e)) / (2 * h) for e in np.eye(6)], axis=-1)
    np.testing.assert_allclose(snap.pose_jacobian, jp_fd, atol=1e-7)
    sigma = np.diag([(2.0e-3) ** 2] * 3 + [(3.0 * np.pi / 180 / 3600) ** 2] * 3)
    np.testing.assert_allclose(snap.noise, jp_fd @ sigma @ np.swapaxes(jp_fd, 1, 2), rtol=1e-6, atol=1e-20)
    u = np.asarray(act.params)
    gu_fd = np.stack([(ik(act.with_params(u + h * e), poses) - ik(act.with_params(u - h * e), poses)) / (2 * h)
                      for e in np.eye(36)], axis=-1)
    np.testing.assert_allclose(snap.jacobian, gu_fd.reshape(-1, 36), atol=1e-7)
    m = control_error_sensitivity(act, poses)
    np.testing.assert_allclose(np.einsum("kij,kjn->kin", jp_fd, m), gu_fd, atol=1e-6)
    unreachable = poses.copy()
    unreachable[1, 0] = 400.0  # mm sideways: longer than the rods
    assert kinematic_snapshot(act, unreachable).reachable.tolist() == [True, False, True, True]


def test_parameter_covariance_is_the_least_squares_sandwich(geoms):
    nom, _ = geoms
    poses = sj.plan_poses("plan120", jax.random.key(0))
    rep = identifiability_report(nom, poses, sigma_um=0.1, sigma_arcsec=0.0)
    assert rep.rank == 36 and np.isfinite(rep.condition_number)
    assert rep.singular_values[0] >= rep.singular_values[-1] > 0
    J = np.asarray(nom.parameter_jacobian(poses))
    # Independent dense computation of (JᵀJ)⁻¹JᵀCJ(JᵀJ)⁻¹, with C built pose by pose from the
    # kinematic Jacobian and the pose covariance (σ = 0.1 µm in translation only).
    jp = np.asarray(jax.vmap(lambda p: nom.ik_and_jacobian(p)[2])(poses))
    Sp = np.diag([1e-8] * 3 + [0.0] * 3)
    C = np.zeros((720, 720))
    for j in range(120):
        C[6 * j:6 * j + 6, 6 * j:6 * j + 6] = jp[j] @ Sp @ jp[j].T
    A = np.linalg.inv(J.T @ J)
    np.testing.assert_allclose(rep.param_cov, A @ J.T @ C @ J @ A, rtol=1e-6, atol=1e-16)


def test_predicted_control_error_matches_monte_carlo(geoms):
    # 200 independent LM calibrations on the same 8 poses (SPEC §3 noise); the spread of the
    # control error at 42 validation poses vs the linearised prediction. Sample standard
    # deviations of 200 draws scatter by ~5 %; the median over 42 poses scatters less.
    nom, act = geoms
    targets = sj.calibration.random_poses(jax.random.key(1), 8)
    keys = jax.random.split(jax.random.key(2), 200)
    sims = jax.vmap(lambda k: sj.simulate_measurements(k, nom, act, targets))(keys)
    problems = jax.vmap(lambda d: sj.calibration_problem(d, nom))(sims.data)
    res = sj.calibration.calibrate_batch(problems, "lm-batched", keys)
    assert np.all(np.asarray(res.status == sj.optimise.RESULTS.successful))
    val = sj.calibration.random_poses(jax.random.key(3), 42)
    errs = jax.jit(jax.vmap(lambda p: sj.control_error(PSSMechanism.from_params(p), act, val).errors))(res.params)
    mc = sj.calibration.error_in_report_units(errs).std(axis=0)  # (42, 6)
    pred = calibration_uncertainty(act, targets, 0.1, 0.1, val)["control_error_std"]
    ratio = np.median(mc / pred, axis=0)
    assert np.all((ratio > 0.8) & (ratio < 1.2)), ratio


def test_o1_plan_beats_random_plan_of_same_size(geoms):
    nom, _ = geoms
    cand = sj.calibration.random_poses(jax.random.key(4), 200)
    plan = plan_poses_optimal(nom, cand, 8, "O1", exchange_sweeps=1)
    assert plan.poses.shape == (8, 6) and len(set(plan.index.tolist())) == 8
    assert plan.history[-1] >= plan.history[0]
    val = sj.calibration.random_poses(jax.random.key(5), 42)
    paper_like = sj.calibration.random_poses(jax.random.key(6), 8)
    err_opt = predicted_control_error_std(nom, val, identifiability_report(nom, jnp.asarray(plan.poses)).param_cov)
    err_rnd = predicted_control_error_std(nom, val, identifiability_report(nom, paper_like).param_cov)
    assert np.all(err_opt.max(axis=0) < err_rnd.max(axis=0))
    with pytest.raises(ValueError, match="m must satisfy"):
        plan_poses_optimal(nom, cand, 5)


def test_covariance_about_the_truth_with_held_directions():
    """``total_covariance`` against a Monte Carlo of the estimator it describes: a linear model
    whose truth is spread by the threshold's prior scales in every direction, fitted by the
    truncated (held-at-nominal) least squares; the covariance of estimate minus truth over 20 000
    draws matches it to sampling error, held directions and the control-error prediction included."""
    from stewart_jax.calibration._determined import determine, restricted_covariance, total_covariance

    rng = np.random.default_rng(3)
    n, rows, t = 6, 40, 0.5
    scale = np.array([1.0, 1.0, 1e-3, 1.0, 1e-3, 1.0])
    q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    u, _ = np.linalg.qr(rng.normal(size=(rows, n)))
    jac = u @ np.diag([50.0, 20.0, 6.0, 2.5, 1.2, 0.3]) @ q.T / scale  # whitened, parameters' units
    det = determine(jac, scale, t)
    assert det.n_determined == 4
    basis = det.step_basis
    draws = 20_000
    truth = t * scale * rng.normal(size=(draws, n))
    data = truth @ jac.T + rng.normal(size=(draws, rows))
    a = np.linalg.lstsq(jac @ basis, data.T, rcond=None)[0]  # the fit over the determined directions
    err = (basis @ a).T - truth
    cov = total_covariance(det, restricted_covariance(det, jac[:, None, :]))
    sample = err.T @ err / draws
    std = np.sqrt(np.diag(cov))
    # NOTE: a sample covariance of 20 000 Gaussian draws is within ~4·sqrt(2/20 000) = 4 % of each
    # entry's scale (σ_i·σ_j); 6 % leaves room for the largest of 36 entries.
    np.testing.assert_allclose(sample / np.outer(std, std), cov / np.outer(std, std), atol=0.06)
    sens = rng.normal(size=(3, n)) / scale  # a control error's sensitivity to the parameters
    np.testing.assert_allclose(np.diag(sens @ sample @ sens.T), np.diag(sens @ cov @ sens.T), rtol=0.06)
    data_only = np.diag(sens @ restricted_covariance(det, jac[:, None, :]) @ sens.T)
    assert np.all(data_only < 0.8 * np.diag(sens @ sample @ sens.T))  # what the data's covariance alone misses
