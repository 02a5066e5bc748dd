"""``stewart-jax fast``: the scenario of Yin et al., *Dynamic modeling of a cable-driven parallel
robot with a Stewart platform for use in FAST*, §6 (eqs. 61–66, Table 2), at one cabin position.

JSON keys: ``axes`` → ``x``/``y``/``z`` → ``correlation``, ``std_m``, ``amplitude_m`` (max |extra
error|), ``peak_to_peak_m``; plus ``position_m``, ``duration_s``, ``dt_s``, ``start``, ``method``,
``static_converged``, ``failed_cable_solves``, ``s0_m``, ``tension0_N`` and, at Table 2's
positions, ``paper`` (the published std and amplitude per axis).

Beyond the paper: ``status`` (``"ok"`` or why not), ``workspace_status`` (feasible,
no_equilibrium, slack, sag_on_reflector, loop_branch), ``attitude`` (the reading, rotation
vector, tilt, ``G R_C``), ``tensions_n`` (six tensions at the cabin anchors),
``min_tension_n``, ``slack_margin_n``, ``clearance_m`` and, with ``--modes``, ``modes`` →
``frequencies_hz`` and ``shapes`` (per mode: ``translation_m`` and ``rotation_rad`` of the
M-normalised shape) and ``cable_string_hz``. The JSON is strict: a number that is not finite
is written as ``null``. A cabin whose statics are infeasible is reported, with its JSON, before
any simulation, with exit status 1; a cabin below the reflector's surface is refused (exit 2).

With ``--cables lumped --segments N --modes`` (lumped-mass cables; no time simulation): ``cables``
→ ``model``, ``segments``, ``degrees_of_freedom``, ``anchor_tension_n``, ``top_tension_n``,
``cabin_offset_m``/``cabin_offset_rad`` (the lumped equilibrium's offset from the catenary pose),
``static_residual_n``; ``modes`` → ``frequencies_hz`` (every mode below ``cutoff_hz``, ascending),
``kind`` (``cabin``/``string``), ``cabin_energy_share``, ``compliance_share`` (per coordinate
``swing_x`` … ``yaw``, one value per listed mode), ``dominant`` (per coordinate: ``mode``, its
0-based index among all modes, ``frequency_hz``, ``compliance_share``).
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
    p.add_argument("--attitude", default="level",
                   choices=("auto", "level", "towards-centre", "smallest-tilt", "max-min-tension"),
                   help="cabin attitude G R_C (default level, the paper's; auto: level where "
                   "feasible, else the smallest feasible tilt; towards-centre: feed axis along "
                   "the focal-surface normal)")
    p.add_argument("--modes", action="store_true",
                   help="add the cabin's natural frequencies and mode shapes on its cables")
    p.add_argument("--cables", choices=("quasi-static", "lumped"), default="quasi-static",
                   help="cable model (default quasi-static, Yin et al.'s elastic catenaries); lumped: "
                   "N lumped-mass segments per cable (MoorDyn's discretisation), with --modes only: "
                   "statics and every mode of cabin and cables, no time simulation")
    p.add_argument("--segments", type=int, default=20, metavar="N",
                   help="segments per cable for --cables lumped (N >= 2, default 20)")
    p.add_argument("--cutoff-hz", type=float, default=1.5,
                   help="--cables lumped: list the modes below this frequency in Hz (default 1.5)")
    g = p.add_argument_group(
        "free-decay record (--free-decay)",
        "Displace the cabin, release it and write its pose as a tracker samples it (CSV columns time,x,y,z,rx,ry,rz: "
        "s; mm, C's origin in G from its static position; degrees, rotation vector in G), simulated on "
        "--cables quasi-static (elastic catenaries) or lumped (N lumped-mass segments per cable); "
        "--duration is the record's length, --dt the integrator's step")
    g.add_argument("--free-decay", action="store_true", help="write a free-decay record of the cabin to --out")
    g.add_argument("--out", metavar="RECORD.csv", help="the record (CSV)")
    g.add_argument("--rate-hz", type=float, default=10.0, help="sampling rate of the record in Hz (default 10)")
    g.add_argument("--initial-mm", type=_triple("--initial-mm"), default=(20.0, 10.0, 5.0), metavar="X,Y,Z",
                   help="initial displacement of C's origin in mm (default 20,10,5)")
    g.add_argument("--initial-deg", type=_triple("--initial-deg"), default=(0.01, 0.01, 0.02), metavar="RX,RY,RZ",
                   help="initial rotation vector in degrees (default 0.01,0.01,0.02)")
    g.add_argument("--velocity-mm-s", type=_triple("--velocity-mm-s"), default=(0.0, 0.0, 0.0), metavar="X,Y,Z",
                   help="initial velocity of C's origin in mm/s (default 0)")
    g.add_argument("--velocity-deg-s", type=_triple("--velocity-deg-s"), default=(0.0, 0.0, 0.0), metavar="RX,RY,RZ",
                   help="initial angular velocity in degrees/s (default 0)")
    g.add_argument("--damping", default="0.005", metavar="Z or SWING,HEAVE,ROTATION",
                   help="modal damping ratio of every mode (default 0.005), or one per mode group (swing, heave, "
                        "rotation; quasi-static cables only)")
    g.add_argument("--noise-mm", type=float, default=1.0,
                   help="tracker noise σ per position coordinate, mm (default 1)")
    g.add_argument("--noise-deg", type=float, default=0.01,
                   help="tracker noise σ per rotation component, degrees (default 0.01)")
    g.add_argument("--seed", type=int, default=0, help="seed of the tracker noise (default 0)")
    g.add_argument("--ea-scale", type=float, default=1.0,
                   help="the cables' EA is this × the paper's (statics solved again at the position; default 1)")
    g.add_argument("--cabin-mass-scale", type=float, default=1.0,
                   help="every mass and inertia of the cabin assembly is this × the paper's (default 1)")
    p.set_defaults(func=run_fast)
    return p


def _triple(option: str):
    def parse(text: str) -> tuple[float, float, float]:
        try:
            values = tuple(float(v) for v in text.split(","))
        except ValueError:
            raise argparse.ArgumentTypeError(f"{option} must be three numbers A,B,C, got {text!r}") from None
        if len(values) != 3 or not all(np.isfinite(values)):
            raise argparse.ArgumentTypeError(f"{option} must be three finite numbers A,B,C, got {text!r}")
        return values  # type: ignore[return-value]

    return parse


def _finite(x):
    """``x`` with every non-finite float replaced by ``None`` (strict JSON)."""
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_finite(v) for v in x]
    if isinstance(x, float | np.floating):
        return float(x) if np.isfinite(x) else None
    return x


def _write_json(path: str, out: dict) -> None:
    from .._files import write_text_atomic

    write_text_atomic(path, json.dumps(_finite(out), indent=2, allow_nan=False))


def _statics(args, params):
    """Attitude and statics at ``args.position``; ``(solution, reading used)``."""
    from ..cable_robot import solve_attitude

    if args.attitude != "auto":
        return solve_attitude(params, np.asarray(args.position), args.attitude)
    level = solve_attitude(params, np.asarray(args.position), "level")
    if bool(level.statics.feasible):
        return level
    return solve_attitude(params, np.asarray(args.position), "smallest-tilt")


def run_fast(args: argparse.Namespace) -> int:
    """Handler of ``stewart-jax fast``; returns the exit status: the options checked, the statics
    at the position, then the free-decay record, the lumped cables' modes or the scenario."""
    import stewart_jax  # noqa: F401  (float64)

    from ..cable_robot import WORKSPACE_STATUS, paper_fast_params
    from ..cable_robot._attitude import attitude_summary
    from ._common import check_outputs

    check_outputs(args, json="--json", plot="--plot", out="--out")
    problem = _option_problem(args)
    if problem:
        print(f"error: {problem}", file=sys.stderr)
        return 2
    params = paper_fast_params()
    from ..cable_robot._inputs import check_time_step, focal_surface_warning, highest_mode_bound_hz, position_problem
    from ..cable_robot._scenario import PAPER_FREQUENCY

    problem = position_problem(args.position, params.towers)
    if problem:
        print(f"error: {problem}", file=sys.stderr)
        return 2
    step_note = (None if getattr(args, "free_decay", False)
                 else check_time_step(args.dt, PAPER_FREQUENCY, highest_mode_bound_hz(params, args.position)))
    for note in (focal_surface_warning(args.position), step_note):
        if note:
            print(f"warning: {note}", file=sys.stderr)
    sol = _statics(args, params)
    cs = sol.statics
    status = WORKSPACE_STATUS[int(cs.status)]
    out = {
        "position_m": list(args.position),
        "attitude": attitude_summary(sol),
        "workspace_status": status,
        "tensions_n": np.asarray(cs.tension_n).tolist(),
        "min_tension_n": np.asarray(cs.min_tension_n).tolist(),
        "slack_margin_n": float(cs.slack_margin_n),
        "clearance_m": np.asarray(cs.clearance_m).tolist(),
    }
    if status != "feasible":
        return _report_infeasible(args, sol, status, out)
    if getattr(args, "free_decay", False):
        return _run_free_decay(args, params, sol, out)
    if getattr(args, "cables", "quasi-static") == "lumped":
        return _run_lumped(args, params, sol, out)
    return _run_scenario(args, params, sol, out)


def _option_problem(args) -> str | None:
    """What is wrong with the options (checked before any work), or ``None``."""
    if getattr(args, "free_decay", False):
        problem = _free_decay_problem(args)
        if problem:
            return problem
    elif getattr(args, "out", None):
        return "--out writes a free-decay record: add --free-decay"
    if getattr(args, "cables", "quasi-static") == "lumped" and not getattr(args, "free_decay", False):
        if not args.modes:
            return ("--cables lumped computes the statics and modes only; add --modes "
                    "(the time simulation runs on quasi-static cables)")
        if not (np.isfinite(args.cutoff_hz) and args.cutoff_hz > 0):
            return f"--cutoff-hz must be a positive frequency in Hz, got {args.cutoff_hz}"
    if getattr(args, "cables", "quasi-static") == "lumped":
        from ..cable_robot._lumped import check_segments

        try:
            check_segments(args.segments)
        except ValueError as e:
            return f"--segments: {e}"
    if not (args.duration > 0 and args.dt > 0 and args.dt <= args.duration):
        return "need 0 < dt <= duration"
    return None


def _report_infeasible(args, sol, status: str, out: dict) -> int:
    """A cabin whose statics are infeasible (``status``): reported, with its JSON, not simulated
    (exit status 1)."""
    out["status"] = status
    if status == "no_equilibrium":
        out["tensions_n"] = out["min_tension_n"] = [None] * 6
        out["slack_margin_n"], out["clearance_m"] = None, [None] * 6
    print(f"error: no feasible static equilibrium at {list(args.position)} m with the "
          f"{sol.kind} attitude (tilt {np.rad2deg(sol.tilt_rad):.2f}°): {status.replace('_', ' ')}"
          "; not simulated (try --attitude auto)", file=sys.stderr)
    if args.json:
        _write_json(args.json, out)
    return 1


def _run_scenario(args, params, sol, out: dict) -> int:
    """The scenario of Yin et al. §6 on quasi-static cables (and, with ``--modes``, the cabin's
    modes): Table 2's columns per axis added to ``out``, printed, written."""
    import jax
    import jax.numpy as jnp

    from ..cable_robot import PAPER_TABLE2
    from ..cable_robot._scenario import run_scenario_jit

    R = None if sol.kind == "level" or not float(sol.tilt_rad) else jnp.asarray(sol.R)
    t0 = time.perf_counter()
    res = run_scenario_jit(params, jnp.asarray(args.position, jnp.float64), duration=args.duration,
                           dt=args.dt, start=args.start, method=args.method, attitude=R)
    jax.block_until_ready(res)
    seconds = time.perf_counter() - t0
    e = np.asarray(res.extra_error)
    out.update({
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
    })
    key = tuple(float(v) for v in args.position)
    if key in PAPER_TABLE2:
        out["paper"] = {ax: {"std_m": v[0], "amplitude_m": v[1]} for ax, v in PAPER_TABLE2[key].items()}
    if args.modes:
        out["modes"] = _cabin_modes(args, params, sol)
    ok = out["static_converged"] and out["failed_cable_solves"] == 0
    out["status"] = "ok" if ok else "simulation_failed"
    _print_scenario(args, sol, out, seconds)
    if args.json:
        _write_json(args.json, out)
    if args.plot:
        _plot(res, args.plot)
    return 0 if ok else 1


def _cabin_modes(args, params, sol) -> dict:
    """``--modes``: the cabin's natural frequencies (Hz) and M-orthonormal mode shapes on its
    quasi-static cables, and the cables' taut-string frequencies (Hz)."""
    import jax.numpy as jnp

    from ..cable_robot import cable_string_modes
    from ..cable_robot._modes import cabin_modes_jit

    cs = sol.statics
    pos = jnp.asarray(args.position, jnp.float64)
    m = cabin_modes_jit(params, pos, jnp.asarray(sol.R), cs.static)
    shapes = np.asarray(m.shapes)
    return {
        "status": "ok" if bool(m.ok) and bool(m.stable) else ("unstable" if bool(m.ok) else "failed"),
        "frequencies_hz": np.asarray(m.frequencies_hz).tolist(),
        "shapes": [{"translation_m": shapes[:3, k].tolist(), "rotation_rad": shapes[3:, k].tolist()}
                   for k in range(6)],
        "shape_normalisation": "M-orthonormal: shapeᵀ M shape = 1 (M in kg, kg·m, kg·m²)",
        "cable_string_hz": np.asarray(cable_string_modes(params, pos, cs.static, sol.R)
                                      .taut_string_hz).tolist(),
    }


def _print_scenario(args, sol, out: dict, seconds: float) -> None:
    """The scenario's summary on standard output: the settings, the cable tensions (kN), Table 2's
    columns per axis (beside the paper's at its positions) and, with ``--modes``, the cabin's
    frequencies."""
    print(f"FAST scenario at {list(args.position)} m ({sol.kind} attitude, tilt "
          f"{np.rad2deg(sol.tilt_rad):.3f}°), {args.duration} s, dt {args.dt} s, "
          f"start={args.start}, {args.method} ({seconds:.1f} s incl. compile)")
    print("cable tensions at the cabin (kN): " + ", ".join(f"{t / 1e3:.1f}" for t in out["tensions_n"]))
    print(f"{'axis':>4} {'correlation':>12} {'std (m)':>12} {'amplitude (m)':>14} {'p-p (m)':>12}"
          + (f" {'paper std':>11} {'paper amp':>11}" if "paper" in out else ""))
    for ax, v in out["axes"].items():
        line = (f"{ax:>4} {v['correlation']:12.4f} {v['std_m']:12.4e} {v['amplitude_m']:14.4e} "
                f"{v['peak_to_peak_m']:12.4e}")
        if "paper" in out:
            line += f" {out['paper'][ax]['std_m']:11.4e} {out['paper'][ax]['amplitude_m']:11.4e}"
        print(line)
    if args.modes:
        print("natural frequencies (Hz): " + ", ".join(f"{f:.4f}" for f in out["modes"]["frequencies_hz"]))


def _run_lumped(args, params, sol, out: dict) -> int:
    """Statics and modes of the cabin on lumped-mass cables (``--cables lumped --modes``)."""
    import jax.numpy as jnp

    from ..cable_robot._lumped import CABIN_COORDINATES, lumped_modes
    from ..cable_robot._lumped_low import modal_summary

    pos = jnp.asarray(args.position, jnp.float64)
    t0 = time.perf_counter()
    try:
        m = lumped_modes(params, pos, args.segments, jnp.asarray(sol.R), sol.statics.static)
    except ValueError as err:
        out["status"] = "no_lumped_equilibrium"
        out["cables"] = {"model": "lumped", "segments": args.segments}
        print(f"error: {err}", file=sys.stderr)
        if args.json:
            _write_json(args.json, out)
        return 1
    s = modal_summary(m, args.cutoff_hz)
    seconds = time.perf_counter() - t0
    st = m.statics
    out["cables"] = {
        "model": "lumped",
        "segments": args.segments,
        "degrees_of_freedom": int(m.frequencies_hz.shape[0]),
        "anchor_tension_n": np.asarray(st.anchor_tension_n).tolist(),
        "top_tension_n": np.asarray(st.top_tension_n).tolist(),
        "cabin_offset_m": np.asarray(st.q[:3]).tolist(),
        "cabin_offset_rad": np.asarray(st.q[3:]).tolist(),
        "static_residual_n": float(st.residual_n),
    }
    out["modes"] = {
        "status": "ok" if bool(m.ok) and bool(m.stable) else ("unstable" if bool(m.ok) else "failed"),
        "cutoff_hz": args.cutoff_hz,
        "frequencies_hz": s.frequencies_hz.tolist(),
        "kind": s.kind,
        "cabin_energy_share": s.cabin_energy_share.tolist(),
        "compliance_share": {c: s.compliance_share[:, k].tolist() for k, c in enumerate(CABIN_COORDINATES)},
        "dominant": {c: {"mode": i, "frequency_hz": f, "compliance_share": sh}
                     for c, (i, f, sh) in s.dominant.items()},
        "string_share": 0.01,
        "seconds": seconds,
    }
    out["status"] = "ok" if out["modes"]["status"] == "ok" else out["modes"]["status"]
    print(f"FAST cabin on lumped-mass cables at {list(args.position)} m ({sol.kind} attitude), "
          f"{args.segments} segments per cable, {out['cables']['degrees_of_freedom']} degrees of freedom "
          f"({seconds:.1f} s incl. compile)")
    print("cable tensions at the cabin (kN): " + ", ".join(f"{t / 1e3:.1f}" for t in out["cables"]["anchor_tension_n"]))
    print(f"{len(s.frequencies_hz)} modes below {args.cutoff_hz} Hz ({s.kind.count('string')} string modes)")
    print(f"{'coordinate':>10} {'mode':>5} {'f (Hz)':>8} {'compliance share':>17}")
    for c, (i, f, sh) in s.dominant.items():
        print(f"{c:>10} {i:5d} {f:8.4f} {sh:17.3f}")
    if args.json:
        _write_json(args.json, out)
    return 0 if out["status"] == "ok" else 1


def _damping(text: str) -> tuple[float, tuple[float, float, float]] | None:
    """``--damping``: one ratio, or one per mode group → (common ratio, change per group)."""
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        return None
    if len(values) == 1:
        return values[0], (0.0, 0.0, 0.0)
    if len(values) == 3:
        return values[0], (0.0, values[1] - values[0], values[2] - values[0])
    return None


def _free_decay_problem(args) -> str | None:
    """What is wrong with the free-decay options (checked before any work), or ``None``."""
    if not args.out:
        return "--free-decay writes its record to --out RECORD.csv; give --out"
    if args.modes or args.plot:
        return "--free-decay writes a record only: drop --modes/--plot"
    if args.attitude != "level":
        return ("--free-decay simulates the level attitude (Yin et al.'s), the one that "
                "`stewart-jax diagnose --geometry fast` assumes")
    d = _damping(args.damping)
    if d is None:
        return f"--damping must be one ratio or three (swing, heave, rotation), got {args.damping!r}"
    zs = [d[0] + c for c in d[1]]
    if not all(np.isfinite(z) and 0 <= z < 1 for z in zs):
        return f"--damping ratios must lie in [0, 1), got {args.damping!r}"
    if args.cables == "lumped" and any(c != 0 for c in d[1]):
        return "--damping per mode group needs --cables quasi-static (the lumped cables take one ratio)"
    if not (np.isfinite(args.rate_hz) and args.rate_hz > 0):
        return f"--rate-hz must be a positive sampling rate, got {args.rate_hz}"
    if args.rate_hz * args.dt > 1.0:
        return f"--rate-hz {args.rate_hz} is faster than the integrator's step --dt {args.dt} s"
    for name, v in (("--noise-mm", args.noise_mm), ("--noise-deg", args.noise_deg)):
        if not (np.isfinite(v) and v >= 0):
            return f"{name} must be a finite number >= 0, got {v}"
    for name, v in (("--ea-scale", args.ea_scale), ("--cabin-mass-scale", args.cabin_mass_scale)):
        if not (np.isfinite(v) and v > 0):
            return f"{name} must be a positive factor, got {v}"
    return None


def _run_free_decay(args, params, sol, out: dict) -> int:
    """``--free-decay``: simulate the release of the displaced cabin and write the record."""
    from ..cable_robot import lumped_free_decay, quasi_static_free_decay
    from ..cable_robot._cabin_modal import scaled_params
    from ..cable_robot._free_decay import write_record

    zeta, change = _damping(args.damping)
    q0 = np.concatenate([np.asarray(args.initial_mm) * 1e-3, np.deg2rad(args.initial_deg)])
    v0 = np.concatenate([np.asarray(args.velocity_mm_s) * 1e-3, np.deg2rad(args.velocity_deg_s)])
    p = scaled_params(params, args.ea_scale, args.cabin_mass_scale)
    t0 = time.perf_counter()
    if args.cables == "lumped":
        dec = lumped_free_decay(p, args.position, args.segments, args.duration, args.dt, displacement=q0,
                                velocity=v0, damping_ratio=zeta)
    else:
        dec = quasi_static_free_decay(p, args.position, args.duration, args.dt, displacement=q0, velocity=v0,
                                      damping_ratio=zeta, damping_change=change)
    seconds = time.perf_counter() - t0
    rec = dec.sample(args.rate_hz, sigma_mm=args.noise_mm, sigma_deg=args.noise_deg, seed=args.seed)
    write_record(args.out, rec)
    low = dec.frequencies_hz[dec.frequencies_hz > 0]
    ok = dec.failed_solves == 0
    out.update({
        "status": "ok" if ok else "simulation_failed",
        "record": args.out,
        "cables": {"model": dec.cables, "segments": dec.segments},
        "duration_s": float(rec.time[-1]),
        "dt_s": float(dec.time[1] - dec.time[0]),
        "rate_hz": float(1.0 / (rec.time[1] - rec.time[0])),
        "rows": int(len(rec.time)),
        "initial": {"displacement_mm": list(args.initial_mm), "rotation_deg": list(args.initial_deg),
                    "velocity_mm_s": list(args.velocity_mm_s), "angular_velocity_deg_s": list(args.velocity_deg_s)},
        "damping_ratio": zeta,
        "damping_groups": {"groups": ["swing", "heave", "rotation"], "ratio": [zeta + c for c in change]},
        "ea_scale": args.ea_scale,
        "cabin_mass_scale": args.cabin_mass_scale,
        "noise": {"sigma_mm": args.noise_mm, "sigma_deg": args.noise_deg, "seed": args.seed},
        "frequencies_hz": dec.frequencies_hz[dec.frequencies_hz < args.cutoff_hz].tolist(),
        "cutoff_hz": args.cutoff_hz,
        "failed_cable_solves": dec.failed_solves,
        "max_segment_strain": dec.max_strain,
        "seconds": seconds,
    })
    print(f"free decay of the cabin at {list(args.position)} m on {dec.cables} cables"
          + (f" ({dec.segments} segments)" if dec.segments else "")
          + f": {len(rec.time)} samples at {out['rate_hz']:.4g} Hz over {out['duration_s']:.4g} s "
          f"(dt {out['dt_s']:.3g} s, {seconds:.1f} s incl. compile) written to {args.out}")
    print(f"lowest mode {low[0]:.4f} Hz; noise σ {args.noise_mm} mm, {args.noise_deg}° (seed {args.seed})")
    if out["duration_s"] < 2.0 / low[0]:
        print(f"warning: the record lasts {out['duration_s']:.3g} s, less than two periods of the lowest mode "
              f"({2.0 / low[0]:.3g} s); `stewart-jax diagnose` needs at least two periods of the quasi-static "
              "model's lowest mode", file=sys.stderr)
    if not ok:
        print(f"error: {dec.failed_solves} catenary solves missed their tolerance; the record is not trustworthy",
              file=sys.stderr)
    if args.json:
        _write_json(args.json, out)
    return 0 if ok else 1


def _plot(res, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")  # --plot only writes a file
    from .. import plotting

    plotting.show(plotting.plot_fast_time_series(res, title="Yin et al. Figs. 6–9"), path)
