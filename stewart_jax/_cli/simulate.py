"""``stewart-jax simulate``: simulated measured data of a nominal and a true mechanism, as CSV."""

from __future__ import annotations

import argparse
import sys

import numpy as np

from ._common import check_outputs, geometry_args, noise_args, nominal_and_true, seed_key


def run(args: argparse.Namespace) -> int:
    if args.campaign:
        from .lut import run_campaign

        return run_campaign(args)
    if args.points:
        from ._points import run_simulate

        return run_simulate(args)
    if isinstance(args.tracker_sigma_um, tuple):
        raise ValueError("--tracker-sigma-um RANGE,ACROSS_PER_M is the noise of --points; --tracker takes one σ")
    if args.tracker_sigma_um is None:
        args.tracker_sigma_um = 3.0
    import jax

    from ..calibration._csv import write_csv
    from ..calibration._simulation import plan_poses, reachable_travel, simulate_measurements, tracker_for
    from ..mechanism._registry import save_mechanism

    check_outputs(args, out="--out", out_true="--out-true")
    if args.sigma_um < 0 or args.sigma_arcsec < 0 or args.tracker_sigma_um < 0:
        raise ValueError("the noise sigmas must be >= 0 (µm, ″)")
    nominal, true = nominal_and_true(args)
    k_plan, k_noise = jax.random.split(seed_key(args.seed))
    targets = plan_poses(args.plan, k_plan, reachable_travel(nominal))
    tracker = tracker_for(nominal, sigma_um=args.tracker_sigma_um) if args.tracker else None
    sim = simulate_measurements(k_noise, nominal, true, targets, args.sigma_um, args.sigma_arcsec, tracker)
    if not bool(np.all(sim.converged)):
        failed = (np.flatnonzero(~np.asarray(sim.converged)) + 1).tolist()
        raise ValueError(f"forward kinematics of the true mechanism ({args.true or 'default'}) failed at target "
                         f"pose(s) {failed[:10]}{' …' if len(failed) > 10 else ''} of {len(targets)}: the true "
                         "mechanism cannot reach them; check its lengths and limits and their units (mm, "
                         "degrees), and that --geometry and --true describe one hexapod")
    extra = {}
    for prefix, poses in (("target", sim.targets), ("true", sim.true_poses)):
        p = np.array(poses)
        p[:, 3:] = np.degrees(p[:, 3:])
        extra[",".join(f"{prefix}_{c}" for c in ("x", "y", "z", "rx", "ry", "rz"))] = p
    write_csv(args.out, sim.data, extra, reading_unit=nominal.reading_unit)
    if args.out_true:
        save_mechanism(true, args.out_true)
    print(f"wrote {len(targets)} poses ({args.plan}, seed {args.seed}) to {args.out}", file=sys.stderr)
    return 0


def _tracker_sigma(text):
    from ._points import tracker_sigma_arg

    return tracker_sigma_arg(text)


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "simulate", help="write simulated measured data of any mechanism as CSV (poses in its travel)"
    )
    p.add_argument("--out", required=True, help="output CSV (q1..q6, x..rz; plus target_* and true_*)")
    p.add_argument("--plan", choices=("paper8", "plan120", "validation42"), default="paper8")
    p.add_argument("--seed", type=int, default=0)
    noise_args(p)
    p.add_argument("--tracker", action="store_true", help="measure poses with the 3-ball laser tracker")
    p.add_argument("--tracker-sigma-um", type=_tracker_sigma, default=None,
                   help="--tracker: σ per coordinate (µm, default 3); --points: RANGE,ACROSS_PER_M, σ along the line "
                        "of sight (µm) and across it (µm per m of distance), default 5,2.5")
    p.add_argument("--points", action="store_true", help="write a laser tracker's target points (a points file)")
    p.add_argument("--targets", metavar="T.json", help="--points: the targets' nominal coordinates")
    p.add_argument("--default-targets", action="store_true",
                   help="--points: write a default target set to --targets instead of reading it")
    p.add_argument("--visible", type=float, default=0.7,
                   help="--points: probability that a platform target is seen at a pose (at least one is)")
    geometry_args(p, true=True)
    p.add_argument("--out-true", help="also write the true geometry (JSON), e.g. to check a calibration")
    from .lut import campaign_args

    campaign_args(p)
    p.set_defaults(func=run)
    return p
