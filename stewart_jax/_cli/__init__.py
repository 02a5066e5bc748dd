"""The ``stewart-jax`` command line (``docs/conventions.md`` lists its files and JSON keys)."""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence

import numpy as np

from ..calibration._methods import METHOD_REGISTRY



def _cmd_simulate(args: argparse.Namespace) -> int:
    import jax

    from ..calibration._csv import write_csv
    from ..calibration._simulation import default_tracker, plan_poses, simulate_measurements
    from ..mechanism._registry import load_mechanism

    nominal, true = load_mechanism(args.nominal), load_mechanism(args.true)
    if type(nominal) is not type(true):
        raise SystemExit(f"simulate: --nominal is a {nominal.family}, --true a {true.family}; give one family")
    k_plan, k_noise = jax.random.split(jax.random.key(args.seed))
    targets = plan_poses(args.plan, k_plan)
    tracker = default_tracker(sigma_um=args.tracker_sigma_um) if args.tracker else None
    sim = simulate_measurements(k_noise, nominal, true, targets, args.sigma_um, args.sigma_arcsec, tracker)
    if not bool(np.all(sim.converged)):
        raise SystemExit("simulate: forward kinematics of the true mechanism failed at a target pose")
    extra = {}
    for prefix, poses in (("target", sim.targets), ("true", sim.true_poses)):
        p = np.array(poses)
        p[:, 3:] = np.degrees(p[:, 3:])
        extra[",".join(f"{prefix}_{c}" for c in ("x", "y", "z", "rx", "ry", "rz"))] = p
    write_csv(args.out, sim.data, extra)
    print(f"wrote {len(targets)} poses ({args.plan}, seed {args.seed}) to {args.out}", file=sys.stderr)
    return 0


def _cmd_calibrate(args: argparse.Namespace) -> int:
    import jax

    from ..calibration._csv import read_csv
    from ..calibration._problem import calibration_problem
    from ..mechanism._registry import load_mechanism, save_mechanism
    from ..optimise._result import status_name

    data = read_csv(args.file)
    nominal = load_mechanism(args.geometry)
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
        _file_backend()
        from .. import plotting
        from ..calibration._problem import stroke_residuals

        before = np.asarray(stroke_residuals(nominal.params, data, nominal)).reshape(-1, 6) * 1e3
        after = np.asarray(stroke_residuals(result.params, data, nominal)).reshape(-1, 6) * 1e3
        plotting.show(plotting.plot_stroke_residuals({"nominal": before, f"calibrated ({args.method})": after},
                                                     sigma_um=args.sigma_um), args.plot)
    if not args.json:
        print(json.dumps(out))
    return 0 if out["status"] != "nonfinite" else 1


def _cmd_study(args: argparse.Namespace) -> int:
    from ..study._study import format_study_table, run_study

    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    unknown = sorted(set(methods) - set(METHOD_REGISTRY))
    if unknown:
        raise SystemExit(f"unknown method(s) {unknown}; choose from {tuple(METHOD_REGISTRY)}")
    options = {}
    if args.max_evaluations is not None:
        options = {m: {"max_evaluations": args.max_evaluations} for m in methods
                   if METHOD_REGISTRY[m].kind != "least_squares"}
    print(
        f"Table 2 simulation study (Wang et al. 2018): plan {args.plan}, {args.trials} trials, σ = {args.sigma_um} µm / "
        f"{args.sigma_arcsec}″, Ω = nominal ± {args.half_width} mm",
        file=sys.stderr,
    )
    result = run_study(
        methods, args.trials, args.seed, args.plan, args.sigma_um, args.sigma_arcsec, args.tracker,
        args.half_width, options, chunk_size=args.chunk, checkpoint=args.checkpoint,
        n_devices=args.devices, first_trial=args.first_trial,
    )
    print("\nMax control error at the calibration poses — median [90th percentile] over trials:\n")
    print(format_study_table(result, "calibration"))
    print("\nMax control error at 42 validation poses — median [90th percentile] over trials:\n")
    print(format_study_table(result, "validation"))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=2)
    if args.plot:
        _file_backend()
        from .. import plotting
        from ..study._study import PAPER_TABLE2

        rows = {k: r["calibration"] for k, r in result["rows"].items()}
        paper = PAPER_TABLE2 if args.plan == "paper8" else None
        plotting.show(plotting.plot_table_comparison(rows, paper=paper, title=f"{args.plan}, {args.trials} trials"),
                      args.plot)
    return 0


def _file_backend() -> None:
    # --plot only writes a file: the non-interactive backend, chosen before pyplot is imported.
    import matplotlib

    matplotlib.use("Agg")


def _noise_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--sigma-um", type=float, default=0.1, help="pose noise σ, translation (µm)")
    p.add_argument("--sigma-arcsec", type=float, default=0.1, help="pose noise σ, angles (″)")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="stewart-jax", description="Stewart-platform kinematics, calibration and dynamics (JAX)."
    )
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("simulate", help="write simulated measured data (the Table 2 study of Wang et al. 2018) as CSV")
    p.add_argument("--out", required=True, help="output CSV (q1..q6, x..rz; plus target_* and true_*)")
    p.add_argument("--plan", choices=("paper8", "plan120", "validation42"), default="paper8")
    p.add_argument("--seed", type=int, default=0)
    _noise_args(p)
    p.add_argument("--tracker", action="store_true", help="measure poses with the 3-ball laser tracker")
    p.add_argument("--tracker-sigma-um", type=float, default=3.0, help="tracker σ per coordinate (µm)")
    p.add_argument("--nominal", default="nominal", help="model geometry: preset or JSON/TOML file")
    p.add_argument("--true", default="actual", help="true geometry: preset or JSON/TOML file")
    p.set_defaults(func=_cmd_simulate)

    p = sub.add_parser("calibrate", help="calibrate the 36 parameters from a measured CSV")
    p.add_argument("file", help="measured data CSV (q1..q6, x, y, z, rx, ry, rz)")
    p.add_argument("--method", choices=tuple(METHOD_REGISTRY), default="lm")
    p.add_argument("--seed", type=int, default=0, help="PRNG seed of the stochastic methods")
    _noise_args(p)
    p.add_argument("--json", help="write the result as JSON")
    p.add_argument("--geometry", default="nominal", help="starting/nominal geometry: preset or file")
    p.add_argument("--half-width", type=float, default=10.0, help="Ω = nominal ± this (mm)")
    p.add_argument("--max-evaluations", type=int, help="objective-evaluation budget (metaheuristics)")
    p.add_argument("--max-steps", type=int, help="iteration budget (LM)")
    p.add_argument("--out-geometry", help="write the calibrated geometry as JSON")
    p.add_argument("--plot", metavar="OUT.png", help="stroke residuals before/after calibration")
    p.set_defaults(func=_cmd_calibrate)

    p = sub.add_parser("study", help="the Table 2 simulation study of Wang et al. (2018) over many seeds")
    p.add_argument("--methods", default="lm", help=f"comma-separated, from {tuple(METHOD_REGISTRY)}")
    p.add_argument("--trials", type=int, default=10)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--plan", choices=("paper8", "plan120"), default="paper8")
    _noise_args(p)
    p.add_argument("--tracker", action="store_true")
    p.add_argument("--half-width", type=float, default=10.0)
    p.add_argument("--max-evaluations", type=int, help="evaluation budget of the metaheuristics")
    p.add_argument("--chunk", type=int, help="trials per chunk (progress; checkpoint granularity)")
    p.add_argument("--checkpoint", help="save finished chunks here; rerun with it to resume")
    p.add_argument("--devices", type=int, default=1, help="split each chunk's trials over this many local JAX devices")
    p.add_argument("--first-trial", type=int, default=0,
                   help="run trials first..first+trials-1 of the seed's sequence (one range per host)")
    p.add_argument("--json", help="write the full result as JSON")
    p.add_argument("--plot", metavar="OUT.png", help="max control error per method beside the paper's Table 2")
    p.set_defaults(func=_cmd_study)

    from .diagnose import add_diagnose_parser
    from .fast import add_fast_parser

    add_diagnose_parser(sub)
    add_fast_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    import stewart_jax  # noqa: F401  (enables float64)

    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (ValueError, FileNotFoundError) as e:
        print(f"stewart-jax {args.command}: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"stewart-jax {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
