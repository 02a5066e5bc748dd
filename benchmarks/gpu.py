"""Batched Levenberg–Marquardt calibrations per second on whatever device JAX has, GPU or CPU.

    python benchmarks/gpu.py                 # GPU: batches of 10^3, 10^4, 10^5; CPU: 10, 100, 1000
    python benchmarks/gpu.py --quick         # batches of 4 and 16 on one plan: a seconds-long smoke run
    python benchmarks/gpu.py --batches 1000,100000 --plans paper8

The problems are the simulation study's of Wang et al. (2018), "Improved cuckoo calibration method
of space telescope secondary mirror adjusting mechanism": the 6-PSS's 36 joint coordinates from
the nominal geometry, σ = 0.1 µm and 0.1″ on the measured poses, the paper's 8 poses (48
residuals) or the 120-pose plan (720 residuals), one independent trial per batch member
(``stewart_jax.study.simulate_trials``). Each batch is one call of
``stewart_jax.calibration.calibrate_batch(..., "lm-batched")``: one compiled program per batch
size, timed apart (the first call, compilation included, and the best of the warm calls).

The published reference for small batched LM on a GPU is Gpufit (Przybylski, Thiel, Keller-Findeisen,
Stock, Bates 2017, "Gpufit: An open-source toolkit for GPU-accelerated curve fitting", Scientific
Reports 7, 15722): about 3 × 10⁶ fits per second of a 5-parameter model to 25 points in float32
on a 2016 GPU. The problems here are larger (36 parameters, 48 or 720 residuals, float64), so the
comparison is of orders of magnitude, not a race.

On a machine without a GPU the script runs on the CPU and says so: its rows are CPU figures,
and no GPU figure exists until it is run where JAX sees one.

Results: ``benchmarks/results/gpu_<backend>{_quick}.{json,md}`` (``--out`` another folder).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import jax  # noqa: E402
import numpy as np  # noqa: E402
from _common import RESULTS, write_results  # noqa: E402

import stewart_jax as sj  # noqa: E402
from stewart_jax.calibration import calibrate_batch  # noqa: E402
from stewart_jax.optimise import status_name  # noqa: E402
from stewart_jax.study import simulate_trials, trial_keys  # noqa: E402

GPUFIT_FITS_PER_S = 3.0e6
DEFAULT_BATCHES = {"gpu": (1_000, 10_000, 100_000), "cpu": (10, 100, 1_000)}


def batch_row(problems, n: int, repeats: int) -> dict:
    """Calibrations per second of the first ``n`` problems: first call and best warm call."""
    batch = jax.tree.map(lambda x: x[:n], problems)
    keys = jax.random.split(jax.random.key(0), n)
    t0 = time.perf_counter()
    jax.block_until_ready(calibrate_batch(batch, "lm-batched", keys))
    first = time.perf_counter() - t0
    best, res = float("inf"), None
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = jax.block_until_ready(calibrate_batch(batch, "lm-batched", keys))
        best = min(best, time.perf_counter() - t0)
    status = np.asarray(status_name(res.status))
    return {"batch": n, "first_call_s": first, "warm_s": best, "calibrations_per_s": n / best,
            "success_share": float(np.mean(status == "success")),
            "median_cost_mm2": float(np.median(np.asarray(res.cost)))}


def markdown(rows: dict, backend: str, devices: list[str]) -> str:
    lines = [f"Batched LM calibrations of the 6-PSS (36 parameters, float64) on **{backend}** "
             f"({', '.join(devices)}).", ""]
    if backend != "gpu":
        lines += ["**No GPU figure exists yet**: these rows are CPU figures; run the script where JAX sees a GPU.",
                  ""]
    lines += ["| plan | batch | first call (s) | warm (s) | calibrations/s | success | median cost (mm²) |",
              "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for plan, plan_rows in rows.items():
        for r in plan_rows:
            lines.append(f"| {plan} | {r['batch']} | {r['first_call_s']:.2f} | {r['warm_s']:.4f} | "
                         f"{r['calibrations_per_s']:.3g} | {r['success_share']:.0%} | {r['median_cost_mm2']:.3g} |")
    lines += ["", f"Gpufit (Przybylski et al. 2017): about {GPUFIT_FITS_PER_S:.0e} fits/s of a 5-parameter, "
              "25-point float32 model on a 2016 GPU; these problems have 36 parameters and 48 or 720 float64 "
              "residuals."]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="batches of 4 and 16 on the 8-pose plan")
    ap.add_argument("--batches", help="comma-separated batch sizes (default: by device)")
    ap.add_argument("--plans", default=None, help="comma-separated: paper8, plan120 (default both)")
    ap.add_argument("--repeats", type=int, default=3, help="warm calls per row (the best is kept)")
    ap.add_argument("--out", default=RESULTS, help="folder of the result files")
    args = ap.parse_args(argv)
    backend = jax.default_backend()
    if args.batches:
        batches = tuple(int(b) for b in args.batches.split(","))
    else:
        batches = (4, 16) if args.quick else DEFAULT_BATCHES["gpu" if backend == "gpu" else "cpu"]
    plans = args.plans.split(",") if args.plans else (["paper8"] if args.quick else ["paper8", "plan120"])
    if min(batches) < 1 or args.repeats < 1:
        ap.error("--batches and --repeats must be positive")
    nominal, actual = sj.nominal_geometry(), sj.actual_geometry()
    rows: dict[str, list[dict]] = {}
    for plan in plans:
        problems = simulate_trials(trial_keys(0, max(batches)), nominal, actual, plan)[0]
        rows[plan] = []
        for n in batches:
            row = batch_row(problems, n, args.repeats)
            rows[plan].append(row)
            print(f"{plan} batch {n}: first call {row['first_call_s']:.2f} s, warm {row['warm_s']:.4f} s, "
                  f"{row['calibrations_per_s']:.3g} calibrations/s, success {row['success_share']:.0%}", flush=True)
    devices = [str(d) for d in jax.devices()]
    name = f"gpu_{backend}{'_quick' if args.quick else ''}"
    payload = {"backend": backend, "gpu_figures": backend == "gpu", "method": "lm-batched",
               "repeats": args.repeats, "rows": rows,
               "reference": {"gpufit_fits_per_s": GPUFIT_FITS_PER_S,
                             "gpufit_problem": "5 parameters, 25 points, float32, 2016 GPU"}}
    write_results(name, payload, markdown(rows, backend, devices), out=args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
