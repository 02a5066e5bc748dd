"""``stewart-jax study``: the Table 2 simulation study of Wang et al. (2018) over many seeds."""

from __future__ import annotations

import argparse
import sys

from ..calibration._methods import METHOD_REGISTRY
from ._common import check_outputs, file_backend, geometry_args, noise_args, nominal_and_true, write_json


def run(args: argparse.Namespace) -> int:
    from ..study._study import format_study_table, run_study

    check_outputs(args, json="--json", plot="--plot", checkpoint="--checkpoint")
    methods = (list(METHOD_REGISTRY) if args.methods.strip() == "all"
               else [m.strip() for m in args.methods.split(",") if m.strip()])
    unknown = sorted(set(methods) - set(METHOD_REGISTRY))
    if unknown:
        raise SystemExit(f"unknown method(s) {unknown}; choose from {tuple(METHOD_REGISTRY)}")
    options = {}
    if args.max_evaluations is not None:
        options = {m: {"max_evaluations": args.max_evaluations} for m in methods
                   if METHOD_REGISTRY[m].kind != "least_squares"}
    print(
        f"simulation study (Table 2 protocol of Wang et al. 2018) of {args.geometry}: plan {args.plan}, "
        f"{args.trials} trials, "
        f"σ = {args.sigma_um} µm / "
        f"{args.sigma_arcsec}″, Ω = nominal ± {args.half_width} mm",
        file=sys.stderr,
    )
    nominal, actual = nominal_and_true(args)
    try:
        result = run_study(
            methods, args.trials, args.seed, args.plan, args.sigma_um, args.sigma_arcsec, args.tracker,
            args.half_width, options, chunk_size=args.chunk, checkpoint=args.checkpoint,
            n_devices=args.devices, first_trial=args.first_trial, nominal=nominal, actual=actual,
        )
    except KeyboardInterrupt:
        if args.checkpoint:
            print(f"\ninterrupted: every finished chunk is in {args.checkpoint}; rerun the same command to "
                  "resume from it", file=sys.stderr)
        else:
            print("\ninterrupted: the finished trials were not saved. To keep them across an interruption, "
                  "run with --checkpoint PATH --chunk N (each finished chunk of N trials is saved to PATH; "
                  "rerunning the same command resumes from it)", file=sys.stderr)
        return 130
    print("\nMax control error at the calibration poses — median [90th percentile] over trials:\n")
    print(format_study_table(result, "calibration"))
    print("\nMax control error at 42 validation poses — median [90th percentile] over trials:\n")
    print(format_study_table(result, "validation"))
    if args.json:
        write_json(args.json, result)
    if args.plot:
        file_backend()
        from .. import plotting

        rows = {k: r["calibration"] for k, r in result["rows"].items()}
        paper = result["paper_table2"] if args.plan == "paper8" else None
        plotting.show(plotting.plot_table_comparison(rows, paper=paper, title=f"{args.plan}, {args.trials} trials"),
                      args.plot)
    return 0


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("study", help="the Table 2 simulation study of Wang et al. (2018) over many seeds")
    p.add_argument("--methods", default="lm-batched",
                   help=f"comma-separated, from {tuple(METHOD_REGISTRY)}, or 'all' (every registered method)")
    p.add_argument("--trials", type=int, default=10)
    geometry_args(p, true=True)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--plan", choices=("paper8", "plan120"), default="paper8")
    noise_args(p)
    p.add_argument("--tracker", action="store_true")
    p.add_argument("--half-width", type=float, default=10.0)
    p.add_argument("--max-evaluations", type=int, help="evaluation budget of the metaheuristics")
    p.add_argument("--chunk", type=int, help="trials per chunk (progress; checkpoint granularity)")
    p.add_argument("--checkpoint", help="save finished chunks here; rerun with it to resume (hosts running "
                                         "their own --first-trial ranges may share one file)")
    p.add_argument("--devices", type=int, default=1,
                   help="split each chunk's trials over this many local JAX devices")
    p.add_argument("--first-trial", type=int, default=0,
                   help="run trials first..first+trials-1 of the seed's sequence (one range per host)")
    p.add_argument("--json", help="write the full result as JSON")
    p.add_argument("--plot", metavar="OUT.png", help="max control error per method beside the paper's Table 2")
    p.set_defaults(func=run)
    return p
