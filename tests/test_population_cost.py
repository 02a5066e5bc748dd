"""The population objective: a family's population layout against the per-member cost, vmapped.

Every preset (and the 6-PSS's 42- and 54-parameter sets, and a 6-PSS with tilted slider axes) is
checked, so that a new family or preset is tested without editing this file.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import stewart_jax as sj
from stewart_jax.calibration import calibration_problem, make_calibration_data

# The private objective the population solvers call (its batching rule is what is tested here),
# and the solvers' own population evaluation.
from stewart_jax.calibration._problem import population_objective
from stewart_jax.mechanism import preset, presets
from stewart_jax.optimise._driver import evaluate


def _mechanisms():
    cases = {name: preset(name) for name in presets()}
    nominal = sj.nominal_geometry()
    cases["nominal/42"] = nominal.with_param_set("42")
    cases["nominal/54"] = nominal.with_param_set("54")
    axes = np.tile([0.0, 0.0, 1.0], (6, 1)) + np.random.default_rng(1).normal(0.0, 0.05, (6, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    cases["nominal/tilted-axes"] = sj.mechanism.PSSMechanism(nominal.upper, nominal.lower, nominal.v0, axes=axes)
    # a strut hexapod whose joint-angle limits bind inside the population (no preset has them)
    d = preset("rubin_m2").to_dict()
    d["joint_angle_limits"] = 1.5  # degrees: binds for a few rows of the population
    cases["rubin_m2/joint-limits"] = sj.mechanism.UPSMechanism.from_dict(d)
    return cases


MECHANISMS = _mechanisms()


def _problem_and_population(mechanism, seed, n=40, m=9):
    """Data from the mechanism itself at poses inside its travel, and a population around its
    parameters: most rows within ±2 mm, a few pushed ±60 mm (unreachable for the 6-PSS, whose
    rods cannot stretch), and the nominal parameters themselves (S = the noise only)."""
    rng = np.random.default_rng(seed)
    half = mechanism.travel_half_widths
    half = np.array([1.0, 1.0, 1.0, 0.01, 0.01, 0.01]) if half is None else np.asarray(half)
    poses = rng.uniform(-0.8, 0.8, (m, 6)) * half
    readings = np.asarray(mechanism.solve_inverse_kinematics(jnp.asarray(poses)).readings)
    data = make_calibration_data(readings + rng.normal(0.0, 1e-3, readings.shape), poses)
    problem = calibration_problem(data, mechanism, half_width=100.0)
    p = np.asarray(mechanism.params)
    pop = p + rng.uniform(-2.0, 2.0, (n, p.size))
    pop[1:4] = p + rng.uniform(-60.0, 60.0, (3, p.size))
    pop[0] = p
    if isinstance(mechanism, sj.mechanism.PSSMechanism):
        pop[4, 20] = pop[4, 2] + float(mechanism.v0[2])  # leg 1's rod horizontal: eq. 4's root fails
    return problem, jnp.asarray(pop)


def _assert_same_cost(actual, expected):
    actual, expected = np.asarray(actual), np.asarray(expected)
    np.testing.assert_array_equal(np.isinf(actual), np.isinf(expected))
    finite = np.isfinite(expected)
    # Rounding only: the two layouts sum the same terms in a different order (~1e-14 relative);
    # S near the noise floor (~5e-5 mm²) keeps relative rounding of the ~100 mm terms below 1e-9.
    np.testing.assert_allclose(actual[finite], expected[finite], rtol=1e-9, atol=0.0)


@pytest.mark.parametrize("name", sorted(MECHANISMS))
def test_population_cost_equals_the_vmapped_cost(name):
    problem, pop = _problem_and_population(MECHANISMS[name], seed=len(name))
    expected = jax.jit(lambda p, x: jax.vmap(p.cost)(x))(problem, pop)
    _assert_same_cost(jax.jit(type(problem).population_cost)(problem, pop), expected)
    # what the optimisers evaluate: their ``evaluate`` vmaps the objective over the population
    _assert_same_cost(jax.jit(lambda p, x: evaluate(lambda u: population_objective(u, p), x))(problem, pop), expected)
    # the per-member call is the cost itself
    assert float(population_objective(pop[5], problem)) == float(problem.cost(pop[5]))


def test_the_6pss_population_has_unreachable_rows_and_reads_them_as_inf():
    problem, pop = _problem_and_population(MECHANISMS["nominal"], seed=3)
    cost = np.asarray(problem.population_cost(pop))
    assert np.isinf(cost[4]) and np.isfinite(cost[5:]).all()
    # the nominal row's S is the noise: 54 readings with σ = 1 µm
    assert 0.2 * 54e-6 < cost[0] < 3.0 * 54e-6


def test_the_joint_angle_limit_case_has_rows_on_both_sides_of_it():
    # so that the comparison above exercises the strut family's joint-angle margin both ways
    name = "rubin_m2/joint-limits"
    problem, pop = _problem_and_population(MECHANISMS[name], seed=len(name))
    cost = np.asarray(problem.population_cost(pop))
    assert np.isinf(cost).any() and np.isfinite(cost[0])  # the nominal row is inside the limits


def test_population_objective_batching_rule_falls_back_when_the_problem_is_batched_too():
    problems, pops = [], []
    for seed in range(3):
        problem, pop = _problem_and_population(MECHANISMS["nominal"], seed=10 + seed, n=6)
        problems.append(problem)
        pops.append(pop)
    batch = jax.tree.map(lambda *x: jnp.stack(x), *problems)
    pops = jnp.stack(pops)  # (3 problems, 6 members, 36)
    expected = np.stack([jax.vmap(p.cost)(x) for p, x in zip(problems, pops, strict=True)])
    # one member per problem on the same axis: the fallback
    _assert_same_cost(jax.vmap(population_objective)(pops[:, 2], batch), expected[:, 2])
    # a population per problem (trials outside, nests inside): the population layout, batched over trials
    nested = jax.jit(jax.vmap(lambda x, p: jax.vmap(population_objective, in_axes=(0, None))(x, p)))
    _assert_same_cost(nested(pops, batch), expected)


def test_population_objective_derivatives_match_finite_differences():
    problem, pop = _problem_and_population(MECHANISMS["nominal"], seed=5)
    v = jnp.asarray(np.random.default_rng(0).normal(size=pop.shape[1]))
    h = 1e-3  # S is a smooth sum of squares in u: central differences err by O(h²) ≈ 1e-6 relative

    @jax.jit  # one compilation for every derivative below (op by op they cost seconds each)
    def derivatives(problem, pop):
        u = pop[6]
        tangent = jax.jvp(lambda x: population_objective(x, problem), (u,), (v,))[1]
        fd = (problem.cost(u + h * v) - problem.cost(u - h * v)) / (2 * h)
        # under vmap (the batching rule's jvp), against the per-member cost's jvp
        tangents = jax.vmap(lambda x: jax.jvp(lambda y: population_objective(y, problem), (x,), (v,))[1])(pop[4:8])
        expected = jax.vmap(lambda x: jax.jvp(problem.cost, (x,), (v,))[1])(pop[4:8])
        grad = jax.grad(lambda x: population_objective(x, problem))(u)  # reverse mode too
        return tangent, fd, tangents, expected, grad @ v

    tangent, fd, tangents, expected, grad_v = (np.asarray(x) for x in derivatives(problem, pop))
    np.testing.assert_allclose(tangent, fd, rtol=1e-5)
    np.testing.assert_allclose(tangents, expected, rtol=1e-9)
    np.testing.assert_allclose(grad_v, fd, rtol=1e-5)
