"""Every population method of ``stewart_jax.optimise`` on COCO's ``bbob`` suite beside its reference.

Hansen, Auger, Ros, Mersmann, Tušar & Brockhoff (2021), "COCO: a platform for comparing
continuous optimizers in a black-box setting", Optimization Methods and Software 36(1):114–144;
Hansen, Finck, Ros & Auger (2009), "Real-parameter black-box optimization benchmarking 2009:
noiseless functions definitions" (INRIA RR-6829).

Pairs (ours → the implementation a user would otherwise reach for):

- CMA-ES → pycma (Hansen's ``cma``), same initial step (0.3 of the box) and bounds;
- DE/rand/1/bin → ``scipy.optimize.differential_evolution`` (same 37 points, F, CR, budget);
- PSO → pyswarms' ``GlobalBestPSO`` (same swarm size and constriction coefficients);
- cuckoo search → mealpy's ``OriginalCSA`` (same population and discovery rate);
- Nelder–Mead → ``scipy.optimize.minimize(method="Nelder-Mead", adaptive=True)`` (Gao & Han's
  coefficients, the same initial simplex);
- SMCS and VSA-SMCS (Wang et al. 2018) beside them: no reference exists.

Part 1 (COCO's conventions): each method on each problem once, every evaluation through the
``cocoex`` problem with COCO's own observer (``cocoex.Observer("bbob", ...)``), the run ending
at the final target ``f_opt + 1e-8`` or the budget ``budget_factor × D`` evaluations; ``cocopp``
post-processes the logs (ECDFs of runtimes per function group and dimension over the targets
``f_opt + 10^{2..-8}``, ERT tables). Our JAX solvers call the ``cocoex`` problem through
``jax.pure_callback`` (one call per population), so COCO sees every evaluation, in order.

Part 2 (batched): every (function, instance) of a dimension in one compiled program of our solver
on the JAX BBOB functions of ``_bbob_jax`` (checked against ``cocoex``), grouped by function
(:func:`batched`), against the reference implementations' Python loops: problems solved (to
``f_opt + 1e-8``) per second. ``benchmarks/bbob_batched.py`` measures that part alone, beside the
reference loops in the same run, with the targets.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import time
import warnings

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import equinox as eqx  # noqa: E402
import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)

import _bbob_jax as bbob  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from _common import RESULTS, expand, write_results  # noqa: E402

import stewart_jax.optimise as so  # noqa: E402

OUT = os.path.join(RESULTS, "bbob")
LOWER, UPPER = -5.0, 5.0
TARGET_PRECISION = 1e-8  # COCO's final target: f_opt + 1e-8
N_POP = 37  # the population of every population method here (ours and the references)


# ---------------------------------------------------------------------------------------------
# Our solvers, with their defaults, stopping at the target f_opt + 1e-8 (a traced array, so that
# one compilation serves every problem of a dimension).

OURS = {
    "CMA-ES": so.CMAES,
    "DE": so.DifferentialEvolution,
    "PSO": so.ParticleSwarm,
    "CS": lambda **kw: so.CuckooSearch(population_size=N_POP, **kw),
    "NM": so.NelderMead,
    "SMCS": so.SMCS,
    "VSA-SMCS": so.VSASMCS,
}
REFERENCE_OF = {"CMA-ES": "pycma", "DE": "scipy-DE", "PSO": "pyswarms", "CS": "mealpy-CSA", "NM": "scipy-NM"}


def our_solver(name: str, fopt):
    return OURS[name](target=jnp.asarray(fopt + TARGET_PRECISION, jnp.float64))


class _Current:
    problem = None


def _host_objective(x):
    x = np.asarray(x, np.float64)
    p = _Current.problem
    if x.ndim == 1:
        return np.asarray(p(x), np.float64)
    return np.array([p(xi) for xi in x], np.float64)


def _callback_objective(y, args):
    del args
    return jax.pure_callback(_host_objective, jax.ShapeDtypeStruct((), jnp.float64), y, vmap_method="expand_dims")


_COMPILED: dict = {}


def run_ours(name: str, problem, fopt: float, budget: int, seed: int) -> None:
    """One run of our solver on a ``cocoex`` problem (every evaluation logged by COCO)."""
    dim = problem.dimension
    solver = our_solver(name, fopt)
    _Current.problem = problem
    key_ = (name, dim, budget)
    if key_ not in _COMPILED:
        lower = jnp.full(dim, LOWER)
        upper = jnp.full(dim, UPPER)

        def go(solver, key):
            return so.minimise(_callback_objective, solver, lower, upper, key, max_evaluations=budget)

        _COMPILED[key_] = eqx.filter_jit(go)
    result = _COMPILED[key_](solver, jax.random.key(seed))
    jax.block_until_ready(result.cost)


# ---------------------------------------------------------------------------------------------
# The reference implementations, each stopped at the final target or the budget.

class _Done(Exception):
    pass


class _Budgeted:
    """``problem`` that raises :class:`_Done` once the final target is hit or the budget spent."""

    def __init__(self, problem, budget: int):
        self.problem = problem
        self.budget = budget

    def __call__(self, x):
        if self.problem.final_target_hit or self.problem.evaluations >= self.budget:
            raise _Done
        return self.problem(np.asarray(x, np.float64))

    def many(self, xs):
        return np.array([self(x) for x in np.atleast_2d(xs)])


def run_reference(name: str, problem, budget: int, seed: int) -> None:
    dim = problem.dimension
    f = _Budgeted(problem, budget)
    rng = np.random.default_rng(seed)
    lower, upper = np.full(dim, LOWER), np.full(dim, UPPER)
    try:
        if name == "pycma":
            import cma

            x0 = rng.uniform(LOWER, UPPER, dim)
            es = cma.CMAEvolutionStrategy(x0, 0.3 * (UPPER - LOWER), {
                "bounds": [LOWER, UPPER], "maxfevals": budget, "verbose": -9, "seed": seed + 1,
                "verb_log": 0, "verb_disp": 0})
            while not es.stop():
                xs = es.ask()
                es.tell(xs, [f(x) for x in xs])
        elif name == "scipy-DE":
            from scipy.optimize import differential_evolution

            init = rng.uniform(LOWER, UPPER, (N_POP, dim))
            differential_evolution(f, list(zip(lower, upper, strict=True)), strategy="rand1bin",
                                   maxiter=budget // N_POP, init=init, mutation=0.5, recombination=0.9,
                                   tol=0.0, atol=0.0, polish=False, updating="deferred", rng=seed)
        elif name == "pyswarms":
            import logging

            import pyswarms

            logging.getLogger("pyswarms").setLevel(logging.ERROR)
            opt = pyswarms.single.GlobalBestPSO(
                n_particles=N_POP, dimensions=dim, options={"c1": 1.49618, "c2": 1.49618, "w": 0.7298},
                bounds=(lower, upper), init_pos=rng.uniform(LOWER, UPPER, (N_POP, dim)))
            np.random.seed(seed % 2**32)
            opt.optimize(f.many, iters=budget // N_POP, verbose=False)
        elif name == "mealpy-CSA":
            from mealpy import CSA, FloatVar

            model = CSA.OriginalCSA(epoch=budget, pop_size=N_POP, p_a=0.25)
            model.solve({"obj_func": f, "bounds": FloatVar(lb=lower.tolist(), ub=upper.tolist()), "minmax": "min",
                         "log_to": None}, termination={"max_fe": budget}, seed=seed)
        elif name == "scipy-NM":
            from scipy.optimize import minimize

            x0 = 0.5 * (lower + upper)
            step = 0.1 * (upper - lower)
            simplex = np.vstack([x0, x0 + np.diag(step)])
            minimize(f, x0, method="Nelder-Mead", bounds=list(zip(lower, upper, strict=True)),
                     options={"initial_simplex": simplex, "adaptive": True, "maxfev": budget,
                              "xatol": 1e-10, "fatol": 1e-14})
        else:
            raise ValueError(name)
    except _Done:
        pass


# ---------------------------------------------------------------------------------------------
# Part 1: the COCO experiment.

def coco_experiment(alg: str, functions, dims, instances, budget_factor: int, folder: str) -> dict:
    """Runs ``alg`` on the suite with COCO's observer; returns per-problem rows."""
    import cocoex

    suite = cocoex.Suite("bbob", f"instances: {','.join(map(str, instances))}",
                         f"function_indices: {','.join(map(str, functions))} "
                         f"dimensions: {','.join(map(str, dims))}")
    observer = cocoex.Observer("bbob", f"result_folder: {folder} algorithm_name: {alg} "
                               f"algorithm_info: stewart_jax BBOB benchmark")
    rows = []
    fopts = {}
    for problem in suite:
        f, dim, inst = problem.id_function, problem.dimension, problem.id_instance
        key = (f, inst, dim)
        if key not in fopts:
            fopts[key] = float(bbob.make_instance(f, inst, dim).fopt)
        problem.observe_with(observer)
        seed = 1000 * f + 100 * inst + dim
        budget = budget_factor * dim
        if alg in OURS and (alg, dim) not in _WARM:  # compile apart: a throw-away unobserved run first
            _warm(alg, dim, budget, fopts[key])
        t0 = time.perf_counter()
        if alg in OURS:
            run_ours(alg, problem, fopts[key], budget, seed)
        else:
            run_reference(alg, problem, budget, seed)
        seconds = time.perf_counter() - t0
        rows.append({"function": f, "instance": inst, "dim": dim, "evaluations": int(problem.evaluations),
                     "solved": bool(problem.final_target_hit),
                     "best_minus_fopt": float(problem.best_observed_fvalue1 - fopts[key]), "seconds": seconds})
        problem.free()
    del observer, suite
    return {"rows": rows}


_WARM: set = set()


def _warm(alg: str, dim: int, budget: int, fopt: float) -> None:
    import cocoex

    suite = cocoex.Suite("bbob", "instances: 1", f"function_indices: 1 dimensions: {dim}")
    problem = suite.get_problem(0)
    t0 = time.perf_counter()
    run_ours(alg, problem, fopt, budget, 0)
    _WARM.add((alg, dim))
    COMPILE_S[f"{alg} {dim}-D"] = time.perf_counter() - t0
    problem.free()


COMPILE_S: dict = {}


# ---------------------------------------------------------------------------------------------
# Part 2: the whole suite of one dimension in one compiled program of our solver, grouped by
# function.

def batched(alg: str, functions, dim: int, instances, budget_factor: int, seed: int = 0) -> dict:
    """Every (function, instance) of dimension ``dim`` in one program: ``lax.map`` over the
    functions, each ``vmap``-ing our solver over its instances.

    NOTE: the function index is the same for every problem of a ``vmap`` here (it comes from the
    ``lax.map`` over functions, not from the batch), so ``lax.switch`` stays a branch and each point
    evaluates its own function only. Batched over every problem at once, the index would be batched
    too and the switch a select: every point would evaluate all 24 functions (up to 24× the run
    time), and each function's code would sit inside the vmapped loop (compile 22–140 s per method
    and dimension). Here the solver's loop is compiled once and the 24 functions once each, as
    branches."""
    problems = bbob.make_instances(functions, instances, dim)  # function-major
    nf, ni = len(functions), len(instances)
    grouped = jax.tree.map(lambda a: a.reshape(nf, ni, *a.shape[1:]), problems)
    budget = budget_factor * dim
    lower, upper = jnp.full(dim, LOWER), jnp.full(dim, UPPER)
    branches = tuple(bbob.BRANCHES[f - 1] for f in functions)

    def per_function(args):
        probs, keys, index = args

        def one(p, key):
            solver = our_solver(alg, p.fopt)  # the target is a traced leaf: one per problem
            objective = lambda x, a: jax.lax.switch(index, branches, x, a)  # noqa: E731
            return so.minimise(objective, solver, lower, upper, key, max_evaluations=budget, args=p)

        return jax.vmap(one)(probs, keys)

    keys = jax.random.split(jax.random.key(seed), nf * ni).reshape(nf, ni)
    run = jax.jit(lambda probs, ks: jax.lax.map(per_function, (probs, ks, jnp.arange(nf))))
    t0 = time.perf_counter()
    compiled = run.lower(grouped, keys).compile()
    compile_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    result = compiled(grouped, keys)
    jax.block_until_ready(result.cost)
    run_s = time.perf_counter() - t0
    # Success as COCO counts it: the best value found within f_opt + 1e-8.
    gap = np.asarray(result.cost).reshape(-1) - np.asarray(problems.fopt)
    solved = gap <= TARGET_PRECISION
    return {"method": alg, "dim": dim, "problems": nf * ni, "solved": int(solved.sum()), "run_s": run_s,
            "best_minus_fopt": gap.tolist(),
            "evaluations_by_problem": np.asarray(result.n_evaluations).reshape(-1).tolist(),
            "compile_s": compile_s, "solved_per_s": float(solved.sum() / run_s),
            "evaluations": int(np.asarray(result.n_evaluations).sum()),
            "solved_by_function": {int(f): int(solved[i * ni:(i + 1) * ni].sum()) for i, f in enumerate(functions)}}


# ---------------------------------------------------------------------------------------------
# Summary: solved problems and ERT ratios from the per-problem rows (COCO's ERT at 1e-8).

def ert(rows) -> float:
    """Expected running time to f_opt + 1e-8 over the rows of one problem set (inf if none solved)."""
    evals = sum(r["evaluations"] for r in rows)
    solved = sum(r["solved"] for r in rows)
    return evals / solved if solved else float("inf")


def summarise(experiment: dict, functions, dims) -> dict:
    summary = {}
    for alg, data in experiment.items():
        for dim in dims:
            rows = [r for r in data["rows"] if r["dim"] == dim]
            if not rows:
                continue
            summary.setdefault(alg, {})[str(dim)] = {
                "problems": len(rows), "solved": sum(r["solved"] for r in rows),
                "seconds": sum(r["seconds"] for r in rows),
                "ert_evaluations_by_function": {str(f): ert([r for r in rows if r["function"] == f])
                                                for f in functions},
            }
    ratios = {}
    for ours, ref in REFERENCE_OF.items():
        if ours not in summary or ref not in summary:
            continue
        for dim in dims:
            d = str(dim)
            if d not in summary[ours] or d not in summary[ref]:
                continue
            per_f = {}
            for f in functions:
                a = summary[ours][d]["ert_evaluations_by_function"][str(f)]
                b = summary[ref][d]["ert_evaluations_by_function"][str(f)]
                per_f[str(f)] = a / b if np.isfinite(a) and np.isfinite(b) else None
            both = [v for v in per_f.values() if v is not None]
            ratios.setdefault(ours, {})[d] = {
                "reference": ref, "ert_ratio_by_function": per_f,
                "ert_ratio_geometric_mean": float(np.exp(np.mean(np.log(both)))) if both else None,
                "functions_solved_by_both": len(both),
            }
    return {"per_method": summary, "ert_ratio_ours_over_reference": ratios}


def markdown(payload: dict) -> str:
    s = payload["summary"]["per_method"]
    dims = payload["dims"]
    lines = [
        "# BBOB (COCO `bbob` suite): our optimisers beside their reference implementations",
        "",
        f"Functions f{min(payload['functions'])}–f{max(payload['functions'])}, instances "
        f"{payload['instances']}, dimensions {dims}, budget {payload['budget_factor']} × D evaluations "
        "per run (one run per problem, stopping at f_opt + 1e-8). Size run and its wall time: "
        f"{payload['wall_s'] / 60:.1f} min.",
        "",
        "## Problems solved to f_opt + 1e-8",
        "",
        "| method | " + " | ".join(f"{d}-D" for d in dims) + " |",
        "|---|" + "---|" * len(dims),
    ]
    for alg in s:
        cells = [f"{s[alg][str(d)]['solved']}/{s[alg][str(d)]['problems']}" if str(d) in s[alg] else "–"
                 for d in dims]
        lines.append(f"| {alg} | " + " | ".join(cells) + " |")
    lines += ["", "## ERT ratio ours / reference at f_opt + 1e-8 (geometric mean over functions both solve)",
              "", "| ours | reference | " + " | ".join(f"{d}-D" for d in dims) + " |",
              "|---|---|" + "---|" * len(dims)]
    for ours, per_dim in payload["summary"]["ert_ratio_ours_over_reference"].items():
        cells = []
        for d in dims:
            r = per_dim.get(str(d))
            if r is None or r["ert_ratio_geometric_mean"] is None:
                cells.append("–")
            else:
                cells.append(f"{r['ert_ratio_geometric_mean']:.2f} ({r['functions_solved_by_both']} f)")
        ref = next(iter(per_dim.values()))["reference"]
        lines.append(f"| {ours} | {ref} | " + " | ".join(cells) + " |")
    lines += ["", "## Batched: every (function, instance) of a dimension in one program, grouped by function",
              "", "| method | D | problems | solved | run s | compile s | solved/s | reference loop solved/s |",
              "|---|---|---|---|---|---|---|---|"]
    for b in payload.get("batched", []):
        ref = REFERENCE_OF.get(b["method"])
        loop = s.get(ref, {}).get(str(b["dim"])) if ref else None
        loop_rate = f"{loop['solved'] / loop['seconds']:.2f} ({ref})" if loop and loop["seconds"] > 0 else "–"
        lines.append(f"| {b['method']} | {b['dim']} | {b['problems']} | {b['solved']} | {b['run_s']:.2f} | "
                     f"{b['compile_s']:.1f} | {b['solved_per_s']:.2f} | {loop_rate} |")
    return "\n".join(lines) + "\n"


def postprocess(folders: list[str]) -> str | None:
    """``cocopp`` on the COCO logs (ECDFs per group and dimension, ERT tables); its output folder."""
    try:
        import cocopp
    except ImportError:
        print("cocopp not installed: post-processing skipped", flush=True)
        return None
    out = os.path.join(OUT, "ppdata")
    shutil.rmtree(out, ignore_errors=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cocopp.genericsettings.isConv = False
        cocopp.genericsettings.figure_file_formats = ["png"]  # a tenth of the SVGs' size, to commit
        cocopp.main(["-o", out, "--no-interactive", *folders])
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="f1, f2, f8, f10, f15 in 2-D and 5-D, 3 instances")
    ap.add_argument("--dims", default="2,5,10")
    ap.add_argument("--instances", default="1-5,101-110", help="COCO's current default: 1-5,101-110")
    ap.add_argument("--functions", default="1-24")
    ap.add_argument("--budget-factor", type=int, default=1000, help="evaluations per run = factor × D")
    ap.add_argument("--methods", default=",".join([*OURS, *REFERENCE_OF.values()]))
    ap.add_argument("--no-batched", action="store_true")
    ap.add_argument("--no-cocopp", action="store_true")
    ap.add_argument("--resume", action="store_true",
                    help="keep the methods a cut-short run of the same settings finished (results/bbob_runs.partial"
                         ".json and their COCO logs); run the others")
    ap.add_argument("--postprocess-only", action="store_true",
                    help="only cocopp on the logs in results/bbob/exdata (of --methods)")
    args = ap.parse_args(argv)
    if args.postprocess_only:
        folders = [os.path.join(OUT, "exdata", m) for m in args.methods.split(",")]
        pp = postprocess(folders)
        path = os.path.join(RESULTS, "bbob.json")
        with open(path) as fh:
            payload = json.load(fh)
        payload["cocopp_output"] = os.path.relpath(pp, RESULTS) if pp else None
        with open(path, "w") as fh:
            json.dump(payload, fh, indent=1)
            fh.write("\n")
        return 0

    if args.quick:
        functions, dims, instances = [1, 2, 8, 10, 15], [2, 5], [1, 2, 3]
        args.budget_factor = min(args.budget_factor, 500)
    else:
        functions, dims, instances = expand(args.functions), expand(args.dims), expand(args.instances)
    methods = args.methods.split(",")
    t_start = time.perf_counter()
    os.makedirs(OUT, exist_ok=True)
    here = os.getcwd()
    os.chdir(OUT)  # cocoex writes its logs to ./exdata
    experiment, folders = {}, []
    try:
        partial = os.path.join(RESULTS, "bbob_runs.partial.json")
        done = {}
        if args.resume and os.path.exists(partial):
            with open(partial) as fh:
                done = json.load(fh)
        for alg in methods:
            folder = f"{alg}"
            if alg in done and os.path.isdir(os.path.join("exdata", folder)):  # --resume: kept, COCO logs too
                experiment[alg] = {"rows": done[alg]}
                COMPILE_S.update(done.get("_compile_s", {}))
                folders.append(os.path.join(OUT, "exdata", folder))
                print(f"{alg}: kept from {os.path.relpath(partial)}", flush=True)
                continue
            shutil.rmtree(os.path.join("exdata", folder), ignore_errors=True)
            t0 = time.perf_counter()
            experiment[alg] = coco_experiment(alg, functions, dims, instances, args.budget_factor, folder)
            folders.append(os.path.join(OUT, "exdata", folder))
            solved = sum(r["solved"] for r in experiment[alg]["rows"])
            print(f"{alg}: {solved}/{len(experiment[alg]['rows'])} solved, {time.perf_counter() - t0:.0f} s",
                  flush=True)
            with open(partial, "w") as fh:  # so far, for --resume after a cut
                json.dump({**{a: d["rows"] for a, d in experiment.items()}, "_compile_s": COMPILE_S}, fh)
    finally:
        os.chdir(here)
    def payload_now(batched_rows):
        return {
            "functions": functions, "dims": dims, "instances": instances, "budget_factor": args.budget_factor,
            "target_precision": TARGET_PRECISION, "population": N_POP,
            "wall_s": time.perf_counter() - t_start, "compile_s": COMPILE_S,
            "summary": summarise(experiment, functions, dims), "batched": batched_rows,
            "versions": _versions(), "cocopp_output": None,
        }

    with open(os.path.join(OUT, "runs.json"), "w") as fh:
        json.dump({alg: d["rows"] for alg, d in experiment.items()}, fh)
    write_results("bbob", payload_now([]), markdown(payload_now([])))  # kept if a later part fails
    batched_rows = []
    if not args.no_batched:
        for alg in [m for m in methods if m in OURS]:
            for dim in dims:
                b = batched(alg, functions, dim, instances, args.budget_factor)
                print(f"batched {alg} {dim}-D: {b['solved']}/{b['problems']} solved, {b['run_s']:.1f} s "
                      f"(compile {b['compile_s']:.1f} s)", flush=True)
                batched_rows.append(b)
    payload = payload_now(batched_rows)
    write_results("bbob", payload, markdown(payload))
    pp = None if args.no_cocopp else postprocess(folders)
    payload["cocopp_output"] = os.path.relpath(pp, RESULTS) if pp else None
    payload["wall_s"] = time.perf_counter() - t_start
    write_results("bbob", payload, markdown(payload))
    print(markdown(payload))
    return 0


def _versions() -> dict:
    out = {}
    for name in ("cocoex", "cocopp", "cma", "scipy", "pyswarms", "mealpy"):
        try:
            module = __import__(name)
            out[name] = getattr(module, "__version__", "?")
        except ImportError:
            out[name] = None
    return out


if __name__ == "__main__":
    raise SystemExit(main())
