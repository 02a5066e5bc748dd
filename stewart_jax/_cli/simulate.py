"""``stewart-jax simulate``: simulated measured data of a nominal and a true mechanism, as CSV."""

from __future__ import annotations

import argparse
import sys

import numpy as np

from ._common import noise_args


def run(args: argparse.Namespace) -> int:
    import jax

    from ..calibration._csv import write_csv
    from ..calibration._simulation import default_tracker, plan_poses, simulate_measurements
    from ..mechanism._registry import load_mechanism

    nominal, true = load_mechanism(args.nominal), load_mechanism(args.true)
    if type(nominal) is not type(true):
        raise SystemExit(
            f"simulate: --nominal is a {nominal.family}, --true a {true.family}; give one family"
        )
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


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "simulate", help="write simulated measured data (the Table 2 study of Wang et al. 2018) as CSV"
    )
    p.add_argument("--out", required=True, help="output CSV (q1..q6, x..rz; plus target_* and true_*)")
    p.add_argument("--plan", choices=("paper8", "plan120", "validation42"), default="paper8")
    p.add_argument("--seed", type=int, default=0)
    noise_args(p)
    p.add_argument("--tracker", action="store_true", help="measure poses with the 3-ball laser tracker")
    p.add_argument("--tracker-sigma-um", type=float, default=3.0, help="tracker σ per coordinate (µm)")
    p.add_argument("--nominal", default="nominal", help="model geometry: preset or JSON/TOML file")
    p.add_argument("--true", default="actual", help="true geometry: preset or JSON/TOML file")
    p.set_defaults(func=run)
    return p
