"""What the data determine: the truncated-SVD update against an independent solution of a linear
problem, and on every preset and plan that the calibrated parameters stay within a few standard
deviations of the truth, each std at most its prior scale, or the assessment says why not."""

import jax
import numpy as np
import pytest

from stewart_jax.calibration import (
    assess_calibration,
    calibrate,
    calibration_problem,
    hold_undetermined,
    perturbed,
    plan_poses,
    reachable_travel,
    simulate_measurements,
)
from stewart_jax.calibration._determined import determine, prior_scale, refine_in_subspace, total_std
from stewart_jax.mechanism import preset, presets

# The slow tier (make test-all runs it, make test does not): determined directions over several plans and
# families, through the command line.
pytestmark = pytest.mark.slow


def test_refine_from_a_drifted_start_is_the_truncated_svd_solution():
    """A linear model with two directions the data barely see: from a start drifted 100 scales
    along them, the update is the truncated-SVD solution written out in NumPy, and no parameter's
    std about the truth exceeds its prior scale."""
    rng = np.random.default_rng(0)
    n, rows = 8, 60
    scale = np.array([1.0, 1.0, 1.0, 1.0, 1e-3, 1e-3, 1.0, 1.0])
    q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    sv = np.array([300.0, 200.0, 90.0, 40.0, 12.0, 3.0, 0.2, 0.01])  # in prior-scale units
    u, _ = np.linalg.qr(rng.normal(size=(rows, n)))
    js = u @ np.diag(sv) @ q.T  # the Jacobian in scaled coordinates
    jac = js / scale
    y0 = rng.normal(size=n) * scale
    b = rng.normal(size=rows)
    det = determine(jac, scale)
    assert det.n_determined == 6
    # independent: the truncated least-squares update in scaled coordinates
    uu, ss, vt = np.linalg.svd(js, full_matrices=False)
    z = vt[:6].T @ ((uu[:, :6].T @ b) / ss[:6])
    expected = y0 + scale * z
    start = expected + 100 * scale * (vt[6] + vt[7])
    got = refine_in_subspace(lambda y: jac @ (y - y0) - b, lambda y: jac, y0, start, det)
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-9 * np.max(np.abs(expected)))
    cov = (scale[:, None] * vt[:6].T) @ np.diag(ss[:6] ** -2) @ (vt[:6] * scale)
    assert np.all(total_std(det, cov) <= scale * (1 + 1e-12))


PLANS = ("paper8", "plan120")


@pytest.mark.parametrize("plan", PLANS)
@pytest.mark.parametrize("name", presets())
def test_calibrated_parameters_stay_near_the_truth(name, plan):
    """The pose route on every preset and plan (parameters perturbed by σ = 0.5 mm / 0.5 mrad,
    pose noise 1 µm, 1″, the default lm-batched): each calibrated parameter within 4 std of the
    truth, each std at most its prior scale; or, with fewer readings than parameters, a refusal."""
    nominal = preset(name)
    key = jax.random.key(11)
    true = perturbed(nominal, jax.random.fold_in(key, 1), 0.5)
    poses = plan_poses(plan, jax.random.fold_in(key, 2), reachable_travel(nominal))
    data = simulate_measurements(jax.random.fold_in(key, 3), nominal, true, poses, 1.0, 1.0).data
    if 6 * len(poses) < nominal.n_params:  # refused before any work, in words
        with pytest.raises(ValueError, match="poses are needed"):
            calibration_problem(data, nominal)
        return
    res = calibrate(calibration_problem(data, nominal), "lm-batched")
    params = hold_undetermined(nominal, data, np.asarray(res.params), 1.0, 1.0)
    a = assess_calibration(nominal.with_params(params), data, 1.0, 1.0, nominal=nominal)
    assert a.status in ("ok", "partly_determined"), a.warnings
    assert (a.status == "partly_determined") == (a.n_determined < nominal.n_params)
    if a.status == "partly_determined":
        assert any("held at nominal" in w for w in a.warnings)
    scale = prior_scale(nominal.param_units)
    std = a.param_std
    # at most the prior scale where the determination was made (nominal); 5 % for the calibrated point
    assert np.all(np.isfinite(std)) and np.all(std <= 1.05 * scale)
    err = np.abs(params - np.asarray(true.params))
    assert np.all(err <= 4 * std), (name, plan, np.max(err / std))
