"""Our CMA-ES beside Hansen's pycma on BBOB f1–f14: evaluations to f_opt + 1e-8, both with IPOP restarts.

    python benchmarks/cma_vs_pycma.py --dims 2,5          # runs, then writes the summary
    python benchmarks/cma_vs_pycma.py --summary-only      # the summary of the runs recorded so far

The target of the rewrite (Hansen's tutorial, 2016/2023, with the active update and pycma's
boundary transform): evaluations to f_opt + 1e-8 within 1.25× of pycma in geometric mean over
f1–f14, never worse than 2× on one function, solving at least as many. Both sides start from a
uniform point in [−4, 4]^D with σ₀ = 2 (0.2 of the box width), restart with the population doubled
(IPOP; pycma: ``cma.fmin(..., restarts=9, incpopsize=2)``) and stop at the target or at
``--budget-factor`` × D evaluations. Ours runs on the JAX BBOB functions of ``_bbob_jax.py``
(checked against ``cocoex`` in the tests), pycma on ``cocoex``'s. ERT per (function, dimension) =
evaluations of all runs / successful runs (Hansen et al., COCO); the ratio is ours / pycma's where
both solve at least once. Three instances per cell: the ratio of one cell carries the scatter of
three runs (a run that needs a restart doubles its count), the geometric mean over a dimension much
less.

Runs are appended to ``benchmarks/results/cma_vs_pycma_runs.json`` (one record per run, so that
dimensions can be run in separate processes); the summary is ``cma_vs_pycma.{json,md}``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from collections import defaultdict

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from _common import RESULTS, write_results  # noqa: E402

import stewart_jax  # noqa: E402, F401  (float64)
from stewart_jax.optimise import CMAES, minimise  # noqa: E402

RUNS = os.path.join(RESULTS, "cma_vs_pycma_runs.json")
INSTANCES = (1, 2, 3)


def run_dimension(d: int, functions, budget_factor: int) -> list[dict]:
    import _bbob_jax as bj
    import cma
    import cocoex

    suite = cocoex.Suite("bbob", "instances:1-3", f"dimensions:{d}")
    lo, hi = -5.0 * jnp.ones(d), 5.0 * jnp.ones(d)
    budget = budget_factor * d
    out = []
    for f in functions:
        def fn(x, p, f=f):
            return bj.evaluate_one(f, x, p)

        run = jax.jit(lambda k, p, t, fn=fn: minimise(
            fn, CMAES(target=t, restarts="ipop", start="y0", sigma0=0.2), lo, hi, k, max_evaluations=budget,
            y0=jax.random.uniform(jax.random.fold_in(k, 7), (d,), minval=-4.0, maxval=4.0), args=p))
        for i in INSTANCES:
            p = bj.make_instance(f, i, d)
            target = float(p.fopt) + 1e-8
            r = run(jax.random.key(i), jax.tree.map(jnp.asarray, p), target)
            problem = suite.get_problem_by_function_dimension_instance(f, d, i)
            x0 = np.random.default_rng(i).uniform(-4.0, 4.0, d)
            res = cma.fmin(problem, x0, 2.0, {"bounds": [-5, 5], "ftarget": target, "maxfevals": budget,
                                              "verbose": -9, "seed": i}, restarts=9, incpopsize=2,
                           eval_initial_x=False)
            rec = {"function": f, "dimension": d, "instance": i, "budget": budget,
                   "ours": [bool(float(r.cost) <= target), int(r.n_evaluations)],
                   "pycma": [bool(res[1] <= target), int(res[2])]}
            print(rec, flush=True)
            out.append(rec)
    return out


def summarise(records: list[dict]) -> tuple[dict, str]:
    cells = defaultdict(list)
    for r in records:
        cells[(r["function"], r["dimension"])].append(r)

    def ert(runs, who):
        solved = sum(r[who][0] for r in runs)
        return sum(r[who][1] for r in runs) / solved if solved else math.inf, solved

    rows, logs = [], defaultdict(list)
    for (f, d), runs in sorted(cells.items()):
        e_ours, s_ours = ert(runs, "ours")
        e_ref, s_ref = ert(runs, "pycma")
        ratio = e_ours / e_ref if s_ours and s_ref else None
        if ratio is not None:
            logs[d].append(math.log(ratio))
        rows.append({"function": f, "dimension": d, "runs": len(runs), "solved_ours": s_ours, "solved_pycma": s_ref,
                     "ert_ours": None if math.isinf(e_ours) else e_ours,
                     "ert_pycma": None if math.isinf(e_ref) else e_ref, "ert_ratio": ratio})
    dims = sorted({d for _, d in cells})
    per_dim = {d: {"geometric_mean_ert_ratio": math.exp(sum(logs[d]) / len(logs[d])) if logs[d] else None,
                   "functions_compared": len(logs[d]),
                   "solved_ours": sum(r["solved_ours"] for r in rows if r["dimension"] == d),
                   "solved_pycma": sum(r["solved_pycma"] for r in rows if r["dimension"] == d),
                   "worst_ratio": max((r["ert_ratio"] for r in rows if r["dimension"] == d and r["ert_ratio"]),
                                      default=None)} for d in dims}
    md = ["# Our CMA-ES beside pycma on BBOB f1–f14 (IPOP both, evaluations to f_opt + 1e-8)", "",
          f"Instances {list(INSTANCES)}, one run each; budget {records[0]['budget'] // records[0]['dimension']} × D.",
          "", "| D | geometric mean ERT ratio ours/pycma | functions compared | worst ratio | solved ours | "
          "solved pycma |", "|---|---|---|---|---|---|"]
    for d, s in per_dim.items():
        g = "–" if s["geometric_mean_ert_ratio"] is None else f"{s['geometric_mean_ert_ratio']:.2f}"
        w = "–" if s["worst_ratio"] is None else f"{s['worst_ratio']:.2f}"
        md.append(f"| {d} | {g} | {s['functions_compared']} | {w} | {s['solved_ours']} | {s['solved_pycma']} |")
    md += ["", "| f | D | solved ours | solved pycma | ERT ours | ERT pycma | ratio |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        def num(x):
            return "–" if x is None else f"{x:.0f}"

        ratio = "–" if r["ert_ratio"] is None else f"{r['ert_ratio']:.2f}"
        md.append(f"| {r['function']} | {r['dimension']} | {r['solved_ours']}/{r['runs']} | "
                  f"{r['solved_pycma']}/{r['runs']} | {num(r['ert_ours'])} | {num(r['ert_pycma'])} | {ratio} |")
    return {"per_dimension": {str(d): v for d, v in per_dim.items()}, "cells": rows}, "\n".join(md)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dims", default="2,5,10")
    ap.add_argument("--functions", default=",".join(map(str, range(1, 15))))
    ap.add_argument("--budget-factor", type=int, default=10_000)
    ap.add_argument("--summary-only", action="store_true")
    args = ap.parse_args()
    records = json.load(open(RUNS)) if os.path.exists(RUNS) else []
    if not args.summary_only:
        for d in map(int, args.dims.split(",")):
            new = run_dimension(d, [int(f) for f in args.functions.split(",")], args.budget_factor)
            keys = {(r["function"], r["dimension"], r["instance"]) for r in new}
            records = [r for r in records if (r["function"], r["dimension"], r["instance"]) not in keys] + new
            tmp = RUNS + ".partial"
            with open(tmp, "w") as fh:
                json.dump(records, fh, indent=1)
            os.replace(tmp, RUNS)
    payload, md = summarise(records)
    write_results("cma_vs_pycma", payload, md)
    print(md)


if __name__ == "__main__":
    main()
