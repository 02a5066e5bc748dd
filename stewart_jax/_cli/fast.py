"""``stewart-jax fast``: the scenario of Yin et al., *Dynamic modeling of a cable-driven parallel
robot with a Stewart platform for use in FAST*, §6 (eqs. 61–66, Table 2), at one cabin position.

JSON keys: ``axes`` → ``x``/``y``/``z`` → ``correlation``, ``std_m``, ``amplitude_m`` (max |extra
error|), ``peak_to_peak_m``; plus ``position_m``, ``duration_s``, ``dt_s``, ``start``, ``method``,
``static_converged``, ``failed_cable_solves``, ``s0_m``, ``tension0_N`` and, at Table 2's
positions, ``paper`` (the published std and amplitude per axis).
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np


def _position(text: str) -> tuple[float, float, float]:
    parts = text.split(",")
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--position must be X,Y,Z in metres, got {text!r}") from None
    if len(values) != 3 or not all(np.isfinite(values)):
        raise argparse.ArgumentTypeError(f"--position must be three finite numbers X,Y,Z, got {text!r}")
    return values  # type: ignore[return-value]


def add_fast_parser(subparsers) -> argparse.ArgumentParser:
    """Register the ``fast`` subcommand on an ``argparse`` subparsers object."""
    p = subparsers.add_parser(
        "fast",
        help="FAST feed support: cable + Stewart coupled vibration scenario (Yin et al., Table 2)",
        description="Run the 5 Hz, 10 mm lower-platform scenario of Yin et al. §6 at one cabin "
        "position and report Table 2's columns per axis.",
    )
    p.add_argument("--position", type=_position, default=(0.0, 0.0, 140.0),
                   help="cabin position G t_C(0) as X,Y,Z in metres (default 0,0,140)")
    p.add_argument("--json", metavar="OUT.json", help="write the results as JSON")
    p.add_argument("--duration", type=float, default=2.0, help="simulated time in s (default 2)")
    p.add_argument("--dt", type=float, default=1e-3, help="time step in s (default 0.001)")
    p.add_argument("--start", choices=("momentum", "rest"), default="momentum",
                   help="initial velocity state (default momentum: zero total momentum)")
    p.add_argument("--method", choices=("verlet", "rk4"), default="verlet",
                   help="time integrator (default verlet)")
    p.add_argument("--plot", metavar="OUT.png", help="save Figs. 6-9 (time series) to a PNG")
    p.set_defaults(func=run_fast)
    return p


def run_fast(args: argparse.Namespace) -> int:
    """Handler of ``stewart-jax fast``; returns the exit status."""
    import jax
    import jax.numpy as jnp

    import stewart_jax  # noqa: F401  (float64)

    from ..cable_robot import PAPER_TABLE2, paper_fast_params, run_scenario_jit

    if not (args.duration > 0 and args.dt > 0 and args.dt <= args.duration):
        print("error: need 0 < dt <= duration", file=sys.stderr)
        return 2
    params = paper_fast_params()
    t0 = time.perf_counter()
    res = run_scenario_jit(params, jnp.asarray(args.position, jnp.float64), duration=args.duration,
                           dt=args.dt, start=args.start, method=args.method)
    jax.block_until_ready(res)
    seconds = time.perf_counter() - t0
    e = np.asarray(res.extra_error)
    out = {
        "position_m": list(args.position),
        "duration_s": args.duration,
        "dt_s": args.dt,
        "start": args.start,
        "method": args.method,
        "static_converged": bool(res.static_ok),
        "failed_cable_solves": int(res.n_failed),
        "s0_m": np.asarray(res.s0).tolist(),
        "tension0_N": np.asarray(res.tension0).tolist(),
        "seconds": seconds,
        "axes": {
            ax: {
                "correlation": float(res.correlation[k]),
                "std_m": float(res.std[k]),
                "amplitude_m": float(res.amplitude[k]),
                "peak_to_peak_m": float(np.ptp(e[:, k])),
            }
            for k, ax in enumerate("xyz")
        },
    }
    key = tuple(float(v) for v in args.position)
    if key in PAPER_TABLE2:
        out["paper"] = {ax: {"std_m": v[0], "amplitude_m": v[1]} for ax, v in PAPER_TABLE2[key].items()}
    ok = out["static_converged"] and out["failed_cable_solves"] == 0
    if not out["static_converged"]:
        print(f"warning: no static equilibrium with positive cable lengths at {list(args.position)} "
              "(G R_C = I); results are not meaningful", file=sys.stderr)
    print(f"FAST scenario at {list(args.position)} m, {args.duration} s, dt {args.dt} s, "
          f"start={args.start}, {args.method} ({seconds:.1f} s incl. compile)")
    print(f"{'axis':>4} {'correlation':>12} {'std (m)':>12} {'amplitude (m)':>14} {'p-p (m)':>12}"
          + (f" {'paper std':>11} {'paper amp':>11}" if "paper" in out else ""))
    for ax, v in out["axes"].items():
        line = (f"{ax:>4} {v['correlation']:12.4f} {v['std_m']:12.4e} {v['amplitude_m']:14.4e} "
                f"{v['peak_to_peak_m']:12.4e}")
        if "paper" in out:
            line += f" {out['paper'][ax]['std_m']:11.4e} {out['paper'][ax]['amplitude_m']:11.4e}"
        print(line)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=2)
    if args.plot:
        _plot(res, args.plot)
    return 0 if ok else 1


def _plot(res, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")  # --plot only writes a file
    from .. import plotting

    plotting.show(plotting.plot_fast_time_series(res, title="Yin et al. Figs. 6–9"), path)
