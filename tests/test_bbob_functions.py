"""The JAX BBOB functions of the benchmark against COCO's own C implementation (``cocoex``)."""

import os
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest

cocoex = pytest.importorskip("cocoex")
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "benchmarks"))
import _bbob_jax as bbob  # noqa: E402

FUNCTIONS = tuple(range(1, 25))
INSTANCES = (1, 2, 3, 101)  # the first instances of every COCO year and the current year's first
POINTS_PER_INSTANCE = 250  # 1000 random points per (function, dimension)
# NOTE: the error is measured against |f - f_opt| + |f_opt|, the size of the two terms COCO adds:
# where they cancel (f close to 0 with f_opt < 0) the last digits of COCO's own sum are rounding.
# f16, f17, f18, f19 and f23 compose cos/sin/pow of arguments up to ~1e7 (f19's cos of the Rosenbrock
# term, f23's 32 dyadic scales and its product raised to 10/D^1.2); XLA's vectorised
# transcendentals differ from glibc's by an ulp there, which those arguments amplify to ~3e-11
# (measured at most 3.1e-11 in 20-D). Everything else agrees to 1e-12 at almost every point; the
# same ulp differences in T_osz (exp, log, sin, pow) and f24's cos reach 1.1e-12 at one point of
# 1000 (f11 10-D, f24 20-D), hence 2e-12.
LOOSE = {16: 1e-10, 17: 1e-10, 18: 1e-10, 19: 1e-10, 23: 1e-10}
TOLERANCE = 2e-12


@pytest.fixture(scope="module")
def suite():
    return cocoex.Suite("bbob", "instances: 1-3,101", "dimensions: 2,5,10,20")


@pytest.mark.parametrize("dim", [2, 5, 10, pytest.param(20, marks=pytest.mark.slow)])  # 20-D: 20 s
def test_every_function_matches_cocoex(suite, dim):
    rng = np.random.default_rng(dim)
    problems = bbob.make_instances(FUNCTIONS, INSTANCES, dim)
    n = len(FUNCTIONS) * len(INSTANCES)
    x = rng.uniform(-5.0, 5.0, (n, POINTS_PER_INSTANCE, dim))
    x[:, :10] = rng.uniform(-6.0, 6.0, (n, 10, dim))  # a few outside the box: the penalties
    ours = np.asarray(jax.jit(jax.vmap(jax.vmap(bbob.evaluate, in_axes=(0, None))))(jnp.asarray(x), problems))
    k = 0
    for f in FUNCTIONS:
        for instance in INSTANCES:
            problem = suite.get_problem_by_function_dimension_instance(f, dim, instance)
            reference = np.array([problem(xi) for xi in x[k]])
            fopt = float(problems.fopt[k])
            problem.free()
            scale = np.abs(reference - fopt) + abs(fopt)
            error = np.max(np.abs(ours[k] - reference) / scale)
            assert error <= LOOSE.get(f, TOLERANCE), f"f{f} instance {instance} {dim}-D: relative error {error:.2e}"
            k += 1


def test_instance_generator_places_the_optimum_where_cocoex_has_it(suite):
    """COCO's own function at our x_opt is our f_opt (f5, f9, f19, f20, f24 place it elsewhere)."""
    for f in (1, 2, 3, 4, 6, 7, 10, 11, 12, 13, 14, 15, 16, 17, 18, 21, 22, 23):
        for instance in (2, 101):
            p = bbob.make_instance(f, instance, 5)
            problem = suite.get_problem_by_function_dimension_instance(f, 5, instance)
            assert problem(p.xopt) == pytest.approx(float(p.fopt), abs=1e-9), (f, instance)
            problem.free()


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match="function must be 1..24"):
        bbob.make_instance(25, 1, 5)
    with pytest.raises(ValueError, match="dimension must be at least 2"):
        bbob.make_instance(1, 1, 1)


@pytest.mark.slow  # three Nelder-Mead programs and the grouped one: 25 s
def test_the_grouped_batch_gives_each_problem_its_own_run(tmp_path):
    """The batched suite grouped by function (one program, ``lax.switch`` on an index the batch
    shares) against each problem run alone on its own function (no switch, no batch): the same
    best values and evaluation counts. Nelder-Mead starts from the centre, so both runs are
    deterministic. Then the benchmark's smoke run writes its results with the targets."""
    import bbob
    import bbob_batched

    import stewart_jax.optimise as so

    functions, instances, dim, factor = [1, 8, 15], [1, 2], 2, 200
    grouped = bbob.batched("NM", functions, dim, instances, factor)
    lower, upper = jnp.full(dim, bbob.LOWER), jnp.full(dim, bbob.UPPER)
    gaps, evaluations = [], []
    for f in functions:  # function-major, as the grouped batch
        alone = jax.jit(lambda p, f=f: so.minimise(lambda x, a: bbob.bbob.evaluate_one(f, x, a),
                                                   bbob.our_solver("NM", p.fopt), lower, upper, jax.random.key(0),
                                                   max_evaluations=factor * dim, args=p))
        for inst in instances:
            p = jax.tree.map(jnp.asarray, bbob.bbob.make_instance(f, inst, dim))
            res = alone(p)
            gaps.append(float(res.cost) - float(p.fopt))
            evaluations.append(int(res.n_evaluations))
    assert grouped["evaluations_by_problem"] == evaluations
    # the same arithmetic in two compiled programs: equal to rounding of f (|f| up to ~1e3 here)
    np.testing.assert_allclose(grouped["best_minus_fopt"], gaps, rtol=1e-9, atol=1e-9)
    assert bbob_batched.main(["--quick", "--out", str(tmp_path)]) == 0
    text = (tmp_path / "bbob_batched_quick.md").read_text()
    assert "compile at most 10 s per method and dimension" in text and "| NM | 2 |" in text
