"""Optimiser speed, side by side in one run, on the same objective (Wang et al. 2018, eq. 9, 8 poses).

    python benchmarks/optimisers.py [--quick]

1. Objective evaluations per second of cuckoo search with 37 nests:
   - ours: the jitted, vmapped population step inside ``lax.scan`` (``calibrate`` with
     method ``cs``; and ``vsa-smcs``), one trial, and 100 trials batched with vmap;
   - mealpy's ``OriginalCSA`` (pop 37), objective = the NumPy S of one vector;
   - a NumPy-vectorised CS (the same algorithm as ``stewart_jax.optimise.CuckooSearch``: the population
     evaluated in one vectorised call per phase).
2. Time per LM calibration: our optimistix LM vmapped over 1000 trials, against SciPy's
   ``least_squares(method="lm")`` run sequentially (default 2-point finite-difference Jacobian,
   and with the exact Jacobian computed by a jitted JAX function).

Compile time is reported separately; every JAX timing blocks on the result. mealpy pins
numpy ≤ 1.26, which jax cannot use; it runs unchanged on numpy 2, so ``make bench-deps``
installs it with ``--no-deps`` beside its own light dependencies.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from _common import write_results  # noqa: E402

import stewart_jax as sj  # noqa: E402

# ahead-of-time compilation (``.lower().compile()``) needs the jitted runners themselves
from stewart_jax.calibration._methods import _run_batch, _run_one, make_solver  # noqa: E402
from stewart_jax.optimise._levy import mantegna_sigma  # noqa: E402
from stewart_jax.study import simulate_trials, trial_keys  # noqa: E402


def numpy_readings(U, upper_idx, poses, v0):
    """IK (eq. 4) for a population ``U`` (n, 36) at poses (m, 6) → readings (n, m, 6)."""
    upper = U[:, :18].reshape(-1, 1, 6, 3)
    lower = U[:, 18:].reshape(-1, 1, 6, 3)
    phi, th, ps = poses[:, 3], poses[:, 4], poses[:, 5]
    cf, sf, ct, st, cp, sp = np.cos(phi), np.sin(phi), np.cos(th), np.sin(th), np.cos(ps), np.sin(ps)
    R = np.stack([
        np.stack([cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf], -1),
        np.stack([sp * ct, sp * st * sf + cp * cf, sp * st * cf - cp * sf], -1),
        np.stack([-st, ct * sf, ct * cf], -1),
    ], -2)  # (m, 3, 3)
    a = np.einsum("mjk,nmik->nmij", R, np.broadcast_to(upper, (U.shape[0], 1, 6, 3))) + poses[None, :, None, :3] + v0
    e = upper + v0 - lower
    L2 = np.sum(e**2, -1)
    dx = lower[..., 0] - a[..., 0]
    dy = lower[..., 1] - a[..., 1]
    margin = L2 - dx**2 - dy**2
    q = a[..., 2] - lower[..., 2] - np.sqrt(np.maximum(margin, 0.0))
    return np.where(np.all(margin >= 0, -1, keepdims=True), q, np.nan)


def numpy_cost(U, q, poses, v0):
    s = np.sum((q[None] - numpy_readings(U, None, poses, v0)) ** 2, axis=(1, 2))
    return np.where(np.isfinite(s), s, np.inf)


def mantegna(rng, shape, beta=1.5):
    sigma = float(mantegna_sigma(beta))
    return rng.normal(0, sigma, shape) / np.abs(rng.normal(0, 1, shape)) ** (1 / beta)


def numpy_cuckoo(cost, lo, hi, n_nests, generations, rng, alpha=0.01, pa=0.25):
    """Vectorised CS, the algorithm of ``stewart_jax.optimise.CuckooSearch`` in NumPy."""
    x = rng.uniform(lo, hi, (n_nests, lo.size))
    f = cost(x)
    n_evals = n_nests
    for _ in range(generations):
        best = x[np.argmin(f)]
        new = np.clip(x + alpha * mantegna(rng, x.shape) * (x - best) * rng.normal(size=x.shape), lo, hi)
        fn = cost(new)
        better = fn < f
        x[better], f[better] = new[better], fn[better]
        mask = rng.uniform(size=x.shape) < pa
        new = np.clip(x + rng.uniform() * (x[rng.permutation(n_nests)] - x[rng.permutation(n_nests)]) * mask, lo, hi)
        fn = cost(new)
        better = fn < f
        x[better], f[better] = new[better], fn[better]
        n_evals += 2 * n_nests
    return f.min(), n_evals


def timed(fn, repeats=3):
    best = np.inf
    out = None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = jax.block_until_ready(fn())
        best = min(best, time.perf_counter() - t0)
    return best, out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args(argv)
    budget = 20_000 if args.quick else 200_000
    n_lm = 100 if args.quick else 1000
    n_scipy = 10 if args.quick else 50
    n_batch = 10 if args.quick else 100
    nominal, actual = sj.nominal_geometry(), sj.actual_geometry()
    keys = trial_keys(0, max(n_lm, n_batch))
    problems, *_ = simulate_trials(keys, nominal, actual, "paper8")
    one = jax.tree.map(lambda x: x[0], problems)
    q, poses, v0 = (np.asarray(x) for x in (one.data.readings, one.data.poses, one.mechanism.v0))
    lo, hi = np.asarray(one.lower), np.asarray(one.upper)
    rows = []

    # 1. evaluations per second
    def add(name, evals, seconds, compile_s=None, note=""):
        rows.append({"section": "evaluations", "method": name, "evaluations": int(evals), "seconds": seconds,
                     "evaluations_per_second": evals / seconds, "compile_seconds": compile_s, "note": note})
        print(f"{name:48s} {evals / seconds:12.4g} evals/s  ({evals} in {seconds:.3f} s)", flush=True)

    for method in ("cs", "vsa-smcs"):
        # compile ahead of time (``lower().compile()``), then time the compiled call alone
        solver = make_solver(method, None, population_size=37)  # mealpy and the NumPy CS use 37 nests too
        call = (solver, one, jax.random.key(1), budget)
        t0 = time.perf_counter()
        compiled = _run_one.lower(*call).compile()
        compile_s = time.perf_counter() - t0
        sec, res = timed(lambda c=compiled, a=call: c(*a))
        add(f"stewart_jax {method} (1 trial, pop {solver.population_size})", int(res.n_evaluations), sec, compile_s)
        batch = jax.tree.map(lambda x: x[:n_batch], problems)
        call = (solver, batch, jax.random.split(jax.random.key(2), n_batch), budget)
        t0 = time.perf_counter()
        compiled = _run_batch.lower(*call).compile()
        compile_s = time.perf_counter() - t0
        sec, res = timed(lambda c=compiled, a=call: c(*a), repeats=2)
        add(f"stewart_jax {method} ({n_batch} trials vmapped)", int(np.sum(res.n_evaluations)), sec, compile_s)
    pop = jnp.asarray(np.random.default_rng(0).uniform(lo, hi, (37, 36)))
    for label, ev in (("population layout, what the optimisers call", jax.jit(type(one).population_cost)),
                      ("per-nest cost vmapped", jax.jit(lambda p, x: jax.vmap(p.cost)(x)))):
        jax.block_until_ready(ev(one, pop))
        sec, _ = timed(lambda ev=ev: [ev(one, pop) for _ in range(200)][-1])
        add(f"stewart_jax S of 37 nests, {label} (one call each)", 200 * 37, sec, note="dispatch-bound: no scan")

    # Every implementation: best of 3 runs (the same rule as for ours), so that the ratios do
    # not depend on which run a background job on the machine happened to slow down.
    cost = lambda U: numpy_cost(U, q, poses, v0)  # noqa: E731
    gens = max(budget // 74 // (10 if args.quick else 20), 5)
    sec, n = timed(lambda: numpy_cuckoo(cost, lo, hi, 37, gens, np.random.default_rng(0))[1])
    add("NumPy-vectorised CS (pop 37)", n, sec)
    try:
        from mealpy import CSA, FloatVar
    except ImportError:
        print("mealpy not installed (make bench-deps): skipped", flush=True)
        rows.append({"section": "evaluations", "method": "mealpy OriginalCSA (pop 37)", "skipped": "not installed"})
    else:
        single = lambda u: float(cost(np.asarray(u)[None])[0])  # noqa: E731
        problem = {"obj_func": single, "bounds": FloatVar(lb=lo.tolist(), ub=hi.tolist()), "minmax": "min",
                   "log_to": None}

        def run_mealpy():
            # enough epochs for a stable rate (~2 evaluations per nest and epoch)
            model = CSA.OriginalCSA(epoch=40 if args.quick else 200, pop_size=37, p_a=0.25)
            model.solve(problem, seed=0)
            return model.nfe_counter

        sec, n = timed(run_mealpy)
        add("mealpy OriginalCSA (pop 37)", n, sec)

    # 2. LM per calibration
    lm_rows = []
    batch = jax.tree.map(lambda x: x[:n_lm], problems)
    t0 = time.perf_counter()
    lm = sj.optimise.LevenbergMarquardt()
    f = jax.jit(jax.vmap(lambda p: lm.run(lambda u, pp: pp.residuals(u), p.initial, p, lambda u, pp: pp.cost(u))))
    f = f.lower(batch).compile()
    compile_s = time.perf_counter() - t0
    sec, res = timed(lambda: f(batch))
    lm_rows.append({"method": f"stewart_jax LM, vmap over {n_lm} trials", "trials": n_lm, "seconds": sec,
                    "seconds_per_calibration": sec / n_lm, "compile_seconds": compile_s,
                    "median_cost": float(np.median(res.cost))})
    from scipy.optimize import least_squares

    def resid(u, k):
        d = jax.tree.map(lambda x: np.asarray(x[k]), problems.data)
        return (d.readings - numpy_readings(u[None], None, d.poses, v0)[0]).reshape(-1)

    jres = jax.jit(lambda p, u: p.residuals(u))
    jjac = jax.jit(lambda p, u: jax.jacfwd(p.residuals)(u))
    for label, use_jac in (("SciPy least_squares lm, 2-point FD Jacobian, sequential", False),
                           ("SciPy least_squares lm, exact JAX Jacobian, sequential", True)):
        costs = []
        t0 = time.perf_counter()
        for k in range(n_scipy):
            pk = jax.tree.map(lambda x, k=k: x[k], problems)
            if use_jac:
                r = least_squares(lambda u, pk=pk: np.asarray(jres(pk, u)), np.asarray(pk.initial),
                                  jac=lambda u, pk=pk: np.asarray(jjac(pk, u)), method="lm", xtol=1e-15, ftol=1e-15,
                                  gtol=1e-15)
            else:
                r = least_squares(resid, np.asarray(pk.initial), args=(k,), method="lm", xtol=1e-15, ftol=1e-15,
                                  gtol=1e-15)
            costs.append(2 * r.cost)
        sec = time.perf_counter() - t0
        lm_rows.append({"method": label, "trials": n_scipy, "seconds": sec, "seconds_per_calibration": sec / n_scipy,
                        "median_cost": float(np.median(costs))})
    for r in lm_rows:
        print(f"{r['method']:60s} {r['seconds_per_calibration'] * 1e3:9.3f} ms/calibration, "
              f"median S {r['median_cost']:.3g}")

    ours = {r["method"]: r for r in rows if "evaluations_per_second" in r}
    mealpy_rate = ours.get("mealpy OriginalCSA (pop 37)", {}).get("evaluations_per_second")
    numpy_rate = ours["NumPy-vectorised CS (pop 37)"]["evaluations_per_second"]
    lines = ["## Objective evaluations per second (S of eq. 9, 8 poses, 36 parameters)", "",
             "| implementation | evaluations | run s | compile s | evaluations/s | × mealpy | × NumPy CS |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        if "skipped" in r:
            lines.append(f"| {r['method']} | skipped: {r['skipped']} | | | | | |")
            continue
        rate = r["evaluations_per_second"]
        cs = "" if r["compile_seconds"] is None else f"{r['compile_seconds']:.1f}"
        xm = f"{rate / mealpy_rate:.0f}×" if mealpy_rate else "–"
        lines.append(f"| {r['method']} | {r['evaluations']} | {r['seconds']:.3f} | {cs} | {rate:.3g} | {xm} | "
                     f"{rate / numpy_rate:.1f}× |")
    scipy_fd = lm_rows[1]["seconds_per_calibration"]
    lines += ["", ("## Levenberg–Marquardt, time per calibration (8-pose problem, from nominal) — weak peers only: "
              "SciPy calling a JAX function or finite differences; the strong peer (NumPy residual + analytic "
              "Jacobian) is in batched_lm.md"), "",
              "| implementation | trials | run s | compile s | ms per calibration | speed-up vs SciPy (FD) "
              "| median S (mm²) |",
              "|---|---|---|---|---|---|---|"]
    for r in lm_rows:
        cs = f"{r['compile_seconds']:.1f}" if "compile_seconds" in r else ""
        lines.append(f"| {r['method']} | {r['trials']} | {r['seconds']:.3f} | {cs} | "
                     f"{r['seconds_per_calibration'] * 1e3:.3f} | {scipy_fd / r['seconds_per_calibration']:.1f}× | "
                     f"{r['median_cost']:.3g} |")
    text = "\n".join(lines)
    print("\n" + text)
    write_results("optimisers_quick" if args.quick else "optimisers", {"evaluations": rows, "lm": lm_rows}, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
