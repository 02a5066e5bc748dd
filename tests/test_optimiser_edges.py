"""The optimiser contract's valid edges, for every registered box method (registry-driven):
float32 inputs, fixed coordinates (``lower == upper``), a target met at the start or never,
CMA-ES's IPOP and BIPOP restarts at the same edges; and the invalid edges refused before
tracing."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import stewart_jax.optimise as o
from stewart_jax.calibration._methods import METHOD_REGISTRY
from stewart_jax.optimise import minimise

BOX = [n for n, m in METHOD_REGISTRY.items() if isinstance(m.factory(), o.AbstractSolver)]
CENTRE = np.array([0.3, -0.2, 0.1])


def sphere(y, _):
    return jnp.sum((y - CENTRE) ** 2)


def solvers():
    """Every registered box method, and CMA-ES with each restart strategy (the slow tier: a
    restarted CMA-ES compiles its restart schedule, 15-70 s a test on 2 cores)."""
    out = [pytest.param(n, METHOD_REGISTRY[n].factory, id=n) for n in BOX]
    out += [pytest.param(f"cma-es/{r}", lambda r=r, **kw: o.CMAES(restarts=r, **kw), id=f"cma-es/{r}",
                         marks=pytest.mark.slow) for r in ("ipop", "bipop")]
    return out


@pytest.mark.parametrize("name,factory", solvers())
def test_float32_objective_and_bounds_are_widened_at_the_boundary(name, factory):
    # A float32 objective over float32 bounds: the search runs in float64 (no dtype clash inside
    # a cond), the value is reported as a float64, and the minimum of the float32 sphere is found.
    def f32(y, _):
        return jnp.sum((y.astype(jnp.float32) - CENTRE.astype(np.float32)) ** 2)

    lo, hi = -jnp.ones(3, jnp.float32), jnp.ones(3, jnp.float32)
    r = minimise(f32, factory(), lo, hi, jax.random.key(0), max_evaluations=3_000)
    assert r.cost.dtype == jnp.float64 and r.params.dtype == jnp.float64
    assert float(r.cost) < 1e-2


@pytest.mark.parametrize("name,factory", solvers())
def test_fixed_coordinates_are_held_and_the_rest_searched(name, factory):
    # lower == upper fixes coordinate 1 at 0.5 (not the sphere's centre): the result holds it
    # exactly, the free coordinates reach the centre, and the cost is the fixed offset's square.
    lo = jnp.array([-1.0, 0.5, -1.0])
    hi = jnp.array([1.0, 0.5, 1.0])
    seen = []

    def fn(y, _):
        jax.debug.callback(lambda v: seen.append(float(v)), y[1])
        return sphere(y, None)

    r = minimise(fn, factory(), lo, hi, jax.random.key(1), max_evaluations=3_000)
    assert float(r.params[1]) == 0.5
    assert set(seen) == {0.5}  # the objective never saw another value of the fixed coordinate
    np.testing.assert_allclose(np.asarray(r.params)[[0, 2]], CENTRE[[0, 2]], atol=0.05)
    assert float(r.cost) == pytest.approx((0.5 + 0.2) ** 2, abs=5e-3)


def test_every_coordinate_fixed_is_one_evaluation():
    x = jnp.array([0.1, 0.2, 0.3])
    for name, factory in (p.values for p in solvers()):
        r = minimise(sphere, factory(), x, x, jax.random.key(0), max_evaluations=100)
        np.testing.assert_array_equal(np.asarray(r.params), np.asarray(x))
        assert float(r.cost) == pytest.approx(float(np.sum((np.asarray(x) - CENTRE) ** 2)))
        assert int(r.n_evaluations) == 1 and o.status_name(r.status) == "success", name


@pytest.mark.parametrize("name,factory", solvers())
def test_targets_at_the_edges(name, factory):
    # target = +inf holds for the first evaluated point: no generation runs, the status says the
    # target was reached, and only the initialisation's calls are spent.
    solver = factory(target=float("inf"))
    r = minimise(sphere, solver, -jnp.ones(3), jnp.ones(3), jax.random.key(0), max_evaluations=5_000)
    assert o.status_name(r.status) == "target"
    plan = solver.restart_schedule(3, 5_000)
    first = solver if plan is None else plan.first
    assert int(r.n_evaluations) == first.init_evaluations(3) + first.final_evaluations(3)
    # target = −inf: never reached, the run ends on its budget or its own test.
    r = minimise(sphere, factory(target=float("-inf")), -jnp.ones(3), jnp.ones(3), jax.random.key(0),
                 max_evaluations=2_000)
    assert o.status_name(r.status) != "target" and float(r.cost) >= 0.0
    # A negative objective, minimum −5 inside the box: a target of −5 + 1e-3 is reached and ends
    # the run early (a negative target is a target like any other).
    fn = lambda y, _: sphere(y, None) - 5.0  # noqa: E731
    r = minimise(fn, factory(target=-5.0 + 1e-3), -jnp.ones(3), jnp.ones(3), jax.random.key(0),
                 max_evaluations=6_000)
    assert o.status_name(r.status) == "target", o.status_name(r.status)
    assert -5.0 <= float(r.cost) <= -5.0 + 1e-3
    assert int(r.n_evaluations) < 6_000


@pytest.mark.parametrize("name,factory", solvers())
def test_target_nan_is_refused_at_construction(name, factory):
    with pytest.raises(ValueError, match="target"):
        factory(target=float("nan"))


@pytest.mark.parametrize("lo,hi,match", [
    ([0.0, 1.0], [1.0, 0.5], r"lower\[1\] = 1.0 is above upper\[1\] = 0.5"),
    ([0.0, -np.inf], [1.0, 1.0], r"finite: lower\[1\]"),
    ([0.0, 0.0], [1.0, np.nan], r"finite: upper\[1\]"),
])
def test_an_invalid_box_is_refused_before_tracing(lo, hi, match):
    traced = []

    def fn(y, _):
        traced.append(1)
        return jnp.sum(y**2)

    with pytest.raises(ValueError, match=match):
        minimise(fn, o.CMAES(), jnp.asarray(lo), jnp.asarray(hi), jax.random.key(0), max_evaluations=100)
    assert not traced
