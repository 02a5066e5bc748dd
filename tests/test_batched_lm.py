"""The batched Levenberg–Marquardt (Levenberg 1944; Marquardt 1963; Moré 1978; Nielsen 1999):
closed-form problems, statuses, the batch loop (a finished problem is never changed, jit and the
working set do not change results), separable blocks, and the calibration method ``lm-batched``
against optimistix's LM and SciPy's MINPACK LM on 6-PSS and 6-UPS problems (Wang et al. 2018,
"Improved cuckoo calibration method of space telescope secondary mirror adjusting mechanism").

Sizes are small: a few problems per batch, so that compilation dominates and stays under ~30 s.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.optimize import least_squares as scipy_least_squares

import stewart_jax as sj
from stewart_jax.calibration import CalibrationData, calibrate, calibrate_batch, perturbed
from stewart_jax.mechanism import AbstractMechanism, preset, presets
from stewart_jax.optimise import RESULTS, BatchedLevenbergMarquardt, Blocks, least_squares_batch, status_name


def linear(y, args):
    a, b = args
    return a @ y - b


def rosenbrock(y, args):
    return jnp.stack([10.0 * (y[1] - y[0] ** 2), 1.0 - y[0]]) * args


# ---- closed-form problems ------------------------------------------------------------------


def test_linear_least_squares_one_step_to_the_exact_solution():
    # Undamped (μ at a negligible floor), the first step of LM on a linear problem is the
    # Gauss–Newton step, i.e. the least-squares solution itself.
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(5, 10, 4)), rng.normal(size=(5, 10))
    solver = BatchedLevenbergMarquardt(max_steps=1, initial_damping=1e-14, min_damping=1e-14)
    r = least_squares_batch(linear, solver, jnp.zeros((5, 4)), args=(jnp.asarray(a), jnp.asarray(b)))
    exact = np.stack([np.linalg.lstsq(a[i], b[i], rcond=None)[0] for i in range(5)])
    np.testing.assert_allclose(r.params, exact, rtol=1e-10, atol=1e-12)
    cost = np.sum((np.einsum("bij,bj->bi", a, exact) - b) ** 2, axis=-1)
    np.testing.assert_allclose(r.cost, cost, rtol=1e-12)
    # the step budget ran out before a stopping test could see that the step was the last
    assert list(status_name(r.status)) == ["max_steps"] * 5
    np.testing.assert_array_equal(r.n_evaluations, 2)


ROSEN_Y0 = jnp.array([[1.0 + 1e-6, 1.0], [-1.2, 1.0], [2.0, -1.0]])
ROSEN_W = jnp.array([1.0, 1.0, 0.5])


@pytest.fixture(scope="module")
def rosen():
    return least_squares_batch(rosenbrock, BatchedLevenbergMarquardt(), ROSEN_Y0, args=ROSEN_W)


def test_rosenbrock_residuals_converge_and_a_tiny_budget_reports_max_steps(rosen):
    np.testing.assert_allclose(rosen.params, 1.0, rtol=0, atol=1e-9)
    assert np.all(np.asarray(rosen.cost) < 1e-20)
    assert list(status_name(rosen.status)) == ["success"] * 3
    short = least_squares_batch(rosenbrock, BatchedLevenbergMarquardt(max_steps=2), ROSEN_Y0, args=ROSEN_W)
    assert list(status_name(short.status)) == ["max_steps"] * 3
    np.testing.assert_array_equal(short.n_evaluations, 3)


def test_nonfinite_residual_is_a_status_never_a_silent_nan():
    def fn(y, bad):
        return jnp.stack([y[0] - 1.0, y[1] + jnp.where(bad, jnp.nan, 0.0)])

    r = least_squares_batch(fn, BatchedLevenbergMarquardt(), jnp.zeros((2, 2)), args=jnp.array([False, True]))
    assert list(status_name(r.status)) == ["success", "nonfinite"]
    np.testing.assert_array_equal(np.asarray(r.params[1]), [0.0, 0.0])  # the start, untouched

    # A residual that is NaN away from the start (sqrt of a negative number beyond y = 1): the
    # steps that land there are rejected, the damping grows, and the fit stays finite.
    def sqrt_fn(y, _):
        return jnp.stack([jnp.sqrt(1.0 - y[0]) - 0.1, 0.01 * y[0]])

    r = least_squares_batch(sqrt_fn, BatchedLevenbergMarquardt(initial_damping=1e-8), jnp.zeros((1, 1)),
                            args=jnp.zeros(1))
    assert status_name(r.status)[0] == "success" and np.isfinite(float(r.cost[0]))
    ref = scipy_least_squares(lambda y: [np.sqrt(1.0 - min(y[0], 1.0)) - 0.1, 0.01 * y[0]], [0.0], method="lm",
                              xtol=1e-15, ftol=1e-15, gtol=1e-15)
    np.testing.assert_allclose(r.params[0], ref.x, rtol=1e-8)


# ---- the batch loop ------------------------------------------------------------------------


def test_a_problem_that_finishes_early_is_not_changed_by_later_iterations(rosen):
    # Problem 0 starts next to the optimum and stops after a few steps; the others run on.
    # Each result must be the one the problem gets alone, bit for bit, whether the batch is
    # iterated whole (working set of 3) or one slot at a time, refilled.
    steps = np.asarray(rosen.n_evaluations)
    assert steps[0] < steps[1:].min()
    one_slot = least_squares_batch(rosenbrock, BatchedLevenbergMarquardt(working_set=1), ROSEN_Y0, args=ROSEN_W)
    for i in range(3):
        alone = least_squares_batch(rosenbrock, BatchedLevenbergMarquardt(), ROSEN_Y0[i:i + 1],
                                    args=ROSEN_W[i:i + 1])
        for r, k in ((rosen, i), (one_slot, i), (alone, 0)):
            np.testing.assert_array_equal(r.params[k], rosen.params[i])
            np.testing.assert_array_equal(r.n_evaluations[k], steps[i])


def test_vmap_of_single_runs_agrees_with_the_batch(rosen):
    solver = BatchedLevenbergMarquardt()
    vmapped = jax.jit(jax.vmap(lambda y, a: solver.run(rosenbrock, y, a)))(ROSEN_Y0, ROSEN_W)
    np.testing.assert_allclose(vmapped.params, rosen.params, rtol=1e-12)
    np.testing.assert_array_equal(vmapped.n_evaluations, rosen.n_evaluations)
    np.testing.assert_array_equal(vmapped.status == RESULTS.successful, rosen.status == RESULTS.successful)


def test_pytree_start_and_explicit_jacobian():
    def fn(y, c):
        return jnp.concatenate([y["a"] - c, 2.0 * (y["b"] - c[:1])])

    def jac(y, c):  # raveled order: a (2), then b (1)
        del y, c
        return jnp.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 2.0]])

    y0 = {"a": jnp.zeros((3, 2)), "b": jnp.zeros((3, 1))}
    c = jnp.arange(6.0).reshape(3, 2)
    for j in (None, jac):
        r = least_squares_batch(fn, BatchedLevenbergMarquardt(), y0, args=c, jac=j)
        np.testing.assert_allclose(r.params["a"], c, atol=1e-12)
        np.testing.assert_allclose(r.params["b"], c[:, :1], atol=1e-12)


def test_separable_blocks_give_the_unblocked_solution():
    # Two Rosenbrock problems side by side in one residual vector: blocks (rows 0,1 | 2,3) and
    # (params 0,1 | 2,3); column-compressed autodiff must give the same fit as the dense one.
    def two(y, w):
        return jnp.concatenate([rosenbrock(y[:2], w), rosenbrock(y[2:], 2.0 * w)])

    y0 = jnp.array([[-1.2, 1.0, 0.5, -0.5]])
    blocks = Blocks(np.array([[0, 1], [2, 3]]), np.array([[0, 1], [2, 3]]))
    blocked = least_squares_batch(two, BatchedLevenbergMarquardt(), y0, args=jnp.ones(1), blocks=blocks)
    dense = least_squares_batch(two, BatchedLevenbergMarquardt(), y0, args=jnp.ones(1))
    np.testing.assert_allclose(blocked.params, 1.0, atol=1e-9)
    np.testing.assert_allclose(dense.params, 1.0, atol=1e-9)

    def block_jac(y, w):  # Rosenbrock's r = (10(y1 − y0²), 1 − y0)·w, per block: (K, m_k, n_k)
        def one(z, s):
            return jnp.array([[-20.0 * z[0], 10.0], [-1.0, 0.0]]) * s
        return jnp.stack([one(y[:2], w), one(y[2:], 2.0 * w)])

    exact = least_squares_batch(two, BatchedLevenbergMarquardt(), y0, args=jnp.ones(1), blocks=blocks, jac=block_jac)
    np.testing.assert_allclose(exact.params, blocked.params, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="block Jacobian must have shape"):
        least_squares_batch(two, BatchedLevenbergMarquardt(), y0, args=jnp.ones(1), blocks=blocks,
                            jac=lambda y, w: block_jac(y, w)[:, :1])
    with pytest.raises(ValueError, match="blocks.cols"):
        least_squares_batch(two, BatchedLevenbergMarquardt(), y0, args=jnp.ones(1),
                            blocks=(np.array([[0, 1], [2, 3]]), np.array([[0, 1], [1, 3]])))


@pytest.mark.parametrize("bad", [
    dict(max_steps=0), dict(ftol=-1.0), dict(initial_damping=0.0), dict(min_damping=1.0),
    dict(scaling="none"), dict(working_set=0),
])
def test_invalid_hyper_parameters_raise_at_construction(bad):
    with pytest.raises(ValueError, match="must be"):
        BatchedLevenbergMarquardt(**bad)


def test_batch_axis_mismatch_raises():
    with pytest.raises(ValueError, match="leading batch axis"):
        least_squares_batch(rosenbrock, BatchedLevenbergMarquardt(), jnp.zeros((3, 2)), args=jnp.ones(2))


# ---- calibration ---------------------------------------------------------------------------


@pytest.mark.parametrize("name", presets())
def test_leg_parameters_match_the_parameter_jacobians_sparsity(name):
    # The blocks lm-batched uses: leg i's readings (rows 6j + i) depend on leg_parameters[i] only.
    m = preset(name)
    legs = m.leg_parameters
    if legs is None:  # truly optional: legs that share parameters get the dense least-squares solve
        pytest.skip(f"{m.family}'s legs share parameters")
    poses = sj.calibration.random_poses(jax.random.key(1), 3, half=sj.calibration.reachable_travel(m))
    jac = np.asarray(jax.jit(jax.jacfwd(lambda u: m.with_params(u).solve_inverse_kinematics(poses).readings))(m.params))
    assert sorted(i for leg in legs for i in leg) == list(range(m.n_params))
    for i, leg in enumerate(legs):
        outside = np.delete(jac[:, i, :], list(leg), axis=-1)
        assert np.all(outside == 0.0)
        assert np.all(np.any(jac[:, i, list(leg)] != 0.0, axis=0))


@pytest.mark.parametrize("name", [*presets(), "nominal/42", "nominal/54"])
def test_leg_parameter_jacobian_is_the_autodiff_jacobians_leg_blocks(name):
    # What lm-batched linearises with: per leg, its readings' derivatives by its own parameters,
    # against the blocks of the forward-mode AD Jacobian (the abstraction's default).
    base, _, pset = name.partition("/")
    m = preset(base) if not pset else preset(base).with_param_set(pset)
    if m.leg_parameters is None:
        pytest.skip(f"{m.family}'s legs share parameters")
    if type(m).leg_parameter_jacobian is AbstractMechanism.leg_parameter_jacobian:
        pytest.skip(f"{m.family} cuts its blocks from the default Jacobian (checked by central differences)")
    poses = sj.calibration.random_poses(jax.random.key(2), 5, half=sj.calibration.reachable_travel(m))
    blocks = np.asarray(jax.jit(type(m).leg_parameter_jacobian)(m, poses))
    ad = np.asarray(jax.jit(AbstractMechanism.parameter_jacobian)(m, poses)).reshape(5, 6, -1)
    assert blocks.shape == (6, 5, len(m.leg_parameters[0]))
    for i, leg in enumerate(m.leg_parameters):
        # entries O(1e-2..1), closed forms cancellation-free: rounding ~1e-16
        np.testing.assert_allclose(blocks[i], ad[:, i, list(leg)], rtol=0, atol=1e-14)


def simulated(nominal, actual, seed: int, n: int):
    """``n`` 8-pose problems: readings of the true mechanism at random poses in the nominal's
    travel, with 0.1 µm noise (poses exact: a cheap stand-in for the paper's protocol, no FK)."""
    half = tuple(float(h) for h in sj.calibration.reachable_travel(nominal))

    @jax.jit
    def one(key):
        k1, k2 = jax.random.split(key)
        poses = sj.calibration.random_poses(k1, 8, half=half)
        readings = actual.solve_inverse_kinematics(poses).readings + 1e-4 * jax.random.normal(k2, (8, 6))
        return sj.calibration_problem(CalibrationData(readings, poses), nominal, 5.0)

    return jax.vmap(one)(jax.random.split(jax.random.key(seed), n))


@pytest.fixture(scope="module")
def pss_batch():
    problems = simulated(sj.nominal_geometry(), sj.actual_geometry(), 3, 3)
    keys = jax.random.split(jax.random.key(0), 3)
    return problems, calibrate_batch(problems, "lm-batched", keys), calibrate_batch(problems, "lm", keys)


@pytest.fixture(scope="module")
def ups_batch():
    nominal = preset("rubin_camera")
    problems = simulated(nominal, perturbed(nominal, jax.random.key(2), 0.5), 4, 3)
    return problems, calibrate_batch(problems, "lm-batched", jax.random.split(jax.random.key(0), 3))


_residuals = jax.jit(lambda p, u: p.residuals(u))
_jacobian = jax.jit(lambda p, u: jax.jacfwd(p.residuals)(u))


def scipy_fit(problem):
    """MINPACK's LM (SciPy) on one problem: the library's residual, autodiff Jacobian."""
    r = scipy_least_squares(lambda u: np.asarray(_residuals(problem, u)), np.asarray(problem.initial),
                            jac=lambda u: np.asarray(_jacobian(problem, u)), method="lm", xtol=1e-15, ftol=1e-15,
                            gtol=1e-15)
    return r.x, 2.0 * r.cost


# NOTE: "the same cost to rounding". The residuals are ~0.1 µm differences of readings computed
# from ~200 mm (6-PSS) or metre-scale (6-UPS) legs; their rounding (~1e-14 mm) makes the cost
# itself uncertain by ~1e-10 relative, so two solvers at the same minimum agree to that, not
# to 1e-16.
COST_RTOL = 1e-9


def same_fit(problem, u1, u2, cost):
    """Two fits determine the same readings. 8 poses identify ~30 of the 36 (6-PSS) or 42
    (6-UPS) parameters: compare what the data determine, the residual vector, not the raw
    parameters along the unidentified directions. The minimum is flat along those, the cost
    changing with the square of a residual change, so fits whose costs agree to COST_RTOL may
    differ by up to sqrt(COST_RTOL·cost) in a residual."""
    r1, r2 = _residuals(problem, u1), _residuals(problem, jnp.asarray(u2))
    np.testing.assert_allclose(r1, r2, rtol=0, atol=np.sqrt(COST_RTOL * cost))


def test_lm_batched_matches_optimistix_and_scipy_on_pss(pss_batch):
    problems, fast, ref = pss_batch
    assert list(status_name(fast.status)) == ["success"] * 3
    np.testing.assert_allclose(fast.cost, ref.cost, rtol=COST_RTOL)
    for k in range(2):
        one = jax.tree.map(lambda x, k=k: x[k], problems)
        x, cost = scipy_fit(one)
        np.testing.assert_allclose(fast.cost[k], cost, rtol=COST_RTOL)
        same_fit(one, fast.params[k], x, cost)
    # LM is unbounded (as optimistix's): both end at the same point, in Ω or not.
    np.testing.assert_allclose(fast.params, ref.params, rtol=0, atol=1e-3)


def test_lm_batched_matches_scipy_on_ups(ups_batch):
    problems, fast = ups_batch
    assert list(status_name(fast.status)) == ["success"] * 3
    for k in range(3):
        one = jax.tree.map(lambda x, k=k: x[k], problems)
        x, cost = scipy_fit(one)
        np.testing.assert_allclose(fast.cost[k], cost, rtol=COST_RTOL)
        same_fit(one, fast.params[k], x, cost)


def test_calibrate_one_problem_equals_its_batch_entry(pss_batch):
    problems, fast, _ = pss_batch
    one = jax.tree.map(lambda x: x[1], problems)
    r = calibrate(one, "lm-batched")
    # compiled for one problem or for a batch, XLA may order sums differently: rounding only
    np.testing.assert_allclose(r.cost, fast.cost[1], rtol=COST_RTOL)
    same_fit(one, r.params, fast.params[1], float(fast.cost[1]))


def test_hybrid_batch_polishes_every_best_nest_to_the_lm_minimum(pss_batch):
    # The hybrid's batched path (vmapped VSA-SMCS, then one batched LM from the best nests)
    # ends where LM from the nominal parameters ends: the 8-pose problem has one minimum.
    problems, fast, _ = pss_batch
    keys = jax.random.split(jax.random.key(4), 3)
    r = calibrate_batch(problems, "vsa-smcs+lm", keys, max_evaluations=500)
    assert list(status_name(r.status)) == ["success"] * 3
    np.testing.assert_allclose(r.cost, fast.cost, rtol=COST_RTOL)
    assert np.all(np.asarray(r.history_cost)[:, -1] == np.asarray(r.cost))
    assert np.all(np.asarray(r.n_evaluations) > 500 - 110)  # VSA-SMCS's evaluations are counted
