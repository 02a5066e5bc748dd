import jax
import jax.numpy as jnp
import numpy as np
import pytest
from conftest import ARCSEC, travel_grid

import stewart_jax as sj


@pytest.fixture(scope="module")
def noise_free(nominal, actual):
    """The paper's protocol without noise: measured poses are the true poses exactly."""
    targets = jnp.asarray(travel_grid(seed=21, n_random=8)[-8:])
    return sj.simulate_measurements(jax.random.key(0), nominal, actual, targets, 0.0, 0.0)


def test_residual_vanishes_at_true_parameters(noise_free, actual, nominal):
    data = noise_free.data
    r_true = sj.calibration_problem(data, actual).residuals(actual.params)
    r_nom = sj.calibration_problem(data, nominal).residuals(nominal.params)
    assert r_true.shape == (48,)
    # The true poses come from FK, converged to max|IK(P) − q| ≤ 1e-12 mm.
    assert np.abs(np.asarray(r_true)).max() <= 1e-12
    assert np.abs(np.asarray(r_nom)).max() > 1e-3
    # S is the sum of squared residuals (eq. 9), computed here from eq. 7 by hand.
    by_hand = np.sum((np.asarray(data.readings) - np.asarray(sj.inverse_kinematics(nominal, data.poses))) ** 2)
    np.testing.assert_allclose(sj.calibration_problem(data, nominal).cost(nominal.params), by_hand, rtol=1e-14)


def test_cost_is_inf_where_a_pose_becomes_unreachable(noise_free, nominal):
    bad = np.asarray(nominal.params).copy()
    # Ac_1 level with Bc_1: the rod is horizontal at the zero pose (L from the zero pose), so
    # any pose moving the joint outward by a few µm is beyond the rod's reach.
    bad[2] = bad[20] + 1e-3
    problem = sj.calibration_problem(noise_free.data, nominal)
    assert np.isinf(float(problem.cost(jnp.asarray(bad))))
    assert np.all(np.isfinite(np.asarray(problem.residuals(jnp.asarray(bad)))))


def test_cost_vmaps_over_population(noise_free, nominal, actual):
    pop = jnp.stack([nominal.params, actual.params, 0.5 * (nominal.params + actual.params)])
    problem = sj.calibration_problem(noise_free.data, nominal)
    batched = jax.vmap(problem.cost)(pop)
    one_by_one = [problem.cost(p) for p in pop]
    np.testing.assert_allclose(batched, one_by_one, rtol=1e-15)


def test_lm_recovers_control_accuracy_without_noise(noise_free, nominal, actual):
    problem = sj.calibration_problem(noise_free.data, nominal)
    res = sj.calibrate(problem, "lm-batched")
    assert bool(res.status == sj.optimise.RESULTS.successful)
    assert float(res.cost) < 1e-20  # mm², i.e. residuals ~1e-11 mm: exact data, exact fit
    cal = nominal.with_params(res.params)
    # 36 parameters are not all identifiable from 8 poses, but the control error is: it must
    # vanish at the calibration poses and stay far below the 0.1 µm noise level elsewhere.
    err_cal = sj.summarize_control_error(sj.control_error(cal, actual, noise_free.targets))
    err_val = sj.summarize_control_error(
        sj.control_error(cal, actual, jnp.asarray(travel_grid(seed=22, n_random=42)[-42:]))
    )
    assert max(err_cal["max_abs"]) < 1e-6
    assert max(err_val["max_abs"]) < 1e-2


def test_lm_reaches_noise_floor_on_paper_protocol(nominal, actual):
    # σ = 0.1 µm, 0.1″ (SPEC §3). At the optimum E[S] ≈ σ_q²·(6m − 36) where σ_q is the stroke
    # noise that the pose noise induces; the before-calibration S is ~1e5× larger.
    k1, k2 = jax.random.split(jax.random.key(7))
    targets = sj.plan_poses("paper8", k1)
    sim = sj.simulate_measurements(k2, nominal, actual, targets)
    problem = sj.calibration_problem(sim.data, nominal)
    res = sj.calibrate(problem, "lm-batched")
    s0 = float(problem.cost(problem.initial))
    J = actual.ik_and_jacobian(sim.true_poses)[2]
    scale = np.array([1e-4] * 3 + [0.1 * ARCSEC] * 3)
    sigma_q2 = np.mean(np.sum((np.asarray(J) * scale) ** 2, axis=-1))
    expected = sigma_q2 * (48 - 36)
    assert bool(res.status == sj.optimise.RESULTS.successful)
    assert float(res.cost) < 5 * expected  # chi-square with 12 dof: P(> 5·mean) < 1e-4
    assert float(res.cost) < 1e-5 * s0


def test_control_error_is_zero_for_exact_model(actual):
    err = sj.control_error(actual, actual, jnp.asarray(travel_grid(seed=3, n_random=20)))
    assert bool(np.all(err.converged))
    assert np.abs(np.asarray(err.errors)).max() < 1e-12


def test_problem_needs_enough_poses(noise_free, nominal):
    with pytest.raises(ValueError, match="at least 6 poses"):
        sj.calibration_problem(noise_free.data.take(np.arange(5)), nominal)
    with pytest.raises(ValueError, match="positive"):
        sj.calibration_problem(noise_free.data, nominal, half_width=0.0)
