"""``stewart-jax calibrate``: calibrate a mechanism's parameters from a measured CSV with any registered method."""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

from ..calibration._methods import METHOD_REGISTRY
from ._common import file_backend, load_nominal, noise_args, param_set_arg


def run(args: argparse.Namespace) -> int:
    import jax

    from ..calibration._csv import read_csv
    from ..calibration._problem import calibration_problem
    from ..mechanism._registry import save_mechanism
    from ..optimise._result import status_name

    data = read_csv(args.file)
    nominal = load_nominal(args)
    problem = calibration_problem(data, nominal, args.half_width)
    options = {}
    if args.max_evaluations is not None:
        if METHOD_REGISTRY[args.method].kind == "least_squares":
            raise SystemExit("--max-evaluations applies to the metaheuristics; LM takes --max-steps")
        options["max_evaluations"] = args.max_evaluations
    if args.max_steps is not None:
        options["max_steps"] = args.max_steps
    t0 = time.perf_counter()
    from ..calibration._methods import calibrate

    result = calibrate(problem, args.method, jax.random.key(args.seed), **options)
    result = jax.block_until_ready(result)
    seconds = time.perf_counter() - t0
    params = np.asarray(result.params)
    m = data.n_poses
    from ..calibration._identifiability import calibration_uncertainty

    unc = calibration_uncertainty(nominal.with_params(params), data.poses, args.sigma_um,
                                  args.sigma_arcsec)
    out = {
        "method": args.method,
        "params": params.tolist(),
        "cost": float(result.cost),
        "n_evaluations": int(result.n_evaluations),
        "seconds": seconds,
        "status": status_name(result.status),
        "n_poses": m,
        "rms_residual_um": float(np.sqrt(float(result.cost) / (6 * m)) * 1e3),
        "in_box": bool(np.all((params >= np.asarray(problem.lower)) & (params <= np.asarray(problem.upper)))),
        "half_width_mm": args.half_width,
        "seed": args.seed,
        "param_std": np.asarray(unc["param_std"]).tolist(),
        "identification_rank": int(unc["rank"]),
        "identification_condition_number": float(unc["condition_number"]),
        "predicted_control_error_std_max": dict(
            zip(("dx_um", "dy_um", "dz_um", "phi_arcsec", "theta_arcsec", "psi_arcsec"),
                np.max(unc["control_error_std"], axis=0).tolist(), strict=True)
        ),
    }
    print(
        f"{args.method}: S = {out['cost']:.6g} mm² (rms stroke residual {out['rms_residual_um']:.4g} µm) "
        f"after {out['n_evaluations']} evaluations in {seconds:.2f} s, status {out['status']}",
        file=sys.stderr,
    )
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=2)
    if args.out_geometry:
        save_mechanism(nominal.with_params(params), args.out_geometry)
    if args.plot:
        file_backend()
        from .. import plotting
        from ..calibration._problem import stroke_residuals

        before = np.asarray(stroke_residuals(nominal.params, data, nominal)).reshape(-1, 6) * 1e3
        after = np.asarray(stroke_residuals(result.params, data, nominal)).reshape(-1, 6) * 1e3
        plotting.show(plotting.plot_stroke_residuals({"nominal": before, f"calibrated ({args.method})": after},
                                                     sigma_um=args.sigma_um), args.plot)
    if not args.json:
        print(json.dumps(out))
    return 0 if out["status"] != "nonfinite" else 1


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("calibrate", help="calibrate the 36 parameters from a measured CSV")
    p.add_argument("file", help="measured data CSV (q1..q6, x, y, z, rx, ry, rz)")
    p.add_argument("--method", choices=tuple(METHOD_REGISTRY), default="lm")
    p.add_argument("--seed", type=int, default=0, help="PRNG seed of the stochastic methods")
    noise_args(p)
    p.add_argument("--json", help="write the result as JSON")
    p.add_argument("--geometry", default="nominal", help="starting/nominal geometry: preset or file")
    param_set_arg(p)
    p.add_argument("--half-width", type=float, default=10.0, help="Ω = nominal ± this (mm; mrad for tilts)")
    p.add_argument("--max-evaluations", type=int, help="objective-evaluation budget (metaheuristics)")
    p.add_argument("--max-steps", type=int, help="iteration budget (LM)")
    p.add_argument("--out-geometry", help="write the calibrated geometry as JSON")
    p.add_argument("--plot", metavar="OUT.png", help="stroke residuals before/after calibration")
    p.set_defaults(func=run)
    return p
