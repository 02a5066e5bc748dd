"""``stewart-jax diagnose`` (the model-discrepancy workflow of :mod:`stewart_jax.discrepancy` on a
measurement CSV, with the discrepancy model of the geometry's family: 6-PSS, 6-UPS or 6-RUS; or, with
``--geometry fast``, on a record of the FAST cabin's free vibration) and
``stewart-jax simulate-effect`` (measurements of the paper's 6-PSS with one hidden registered
effect). The candidate names come from the effect registry."""

from __future__ import annotations

import argparse
import sys
import time

FAST_SIGMA_UM = 1000.0
"""Default tracker noise of a FAST cabin record per position coordinate (µm)."""
FAST_SIGMA_ARCSEC = 36.0
"""Default tracker noise of a FAST cabin record per rotation component (″, 0.01°)."""


def _cmd_diagnose(args: argparse.Namespace) -> int:
    from ..calibration._csv import read_csv
    from ..discrepancy import diagnose, model_for
    from ..mechanism._registry import load_mechanism
    from ._common import check_outputs
    from ._points import is_points_file

    check_outputs(args, json="--json", out_model="--out-model")
    if args.geometry == "fast":
        return _cmd_diagnose_cabin(args)
    for option, value in (("--position", args.position), ("--segments", args.segments)):
        if value is not None:
            raise ValueError(f"{option} belongs to a FAST cabin record (--geometry fast)")
    args.sigma_um = 0.1 if args.sigma_um is None else args.sigma_um
    args.sigma_arcsec = 0.1 if args.sigma_arcsec is None else args.sigma_arcsec
    effects = [e.strip() for e in args.effects.split(",") if e.strip()] if args.effects else None
    if is_points_file(args.file):
        return _diagnose_points(args, effects)
    if args.targets is not None or args.tracker_sigma_um is not None:
        raise ValueError("--targets and --tracker-sigma-um are for a points file (one with a 'target' column)")
    from .calibrate import PROGRESS_POSES

    geometry = load_mechanism(args.geometry)
    data = read_csv(args.file, reading_unit=geometry.reading_unit)
    reading = "sigma_reading_um" if geometry.reading_unit == "mm" else "sigma_reading_urad"
    model = model_for(geometry, args.sigma_um, args.sigma_arcsec, **{reading: _reading_sigma(args, geometry)})
    report = diagnose(
        data,
        model,
        effects=effects,
        holdout_fraction=args.holdout_fraction,
        seed=args.seed,
        alpha=args.alpha,
        estimate_noise=args.estimate_noise,
        temperature_std_k=args.temperature_std_k,
        progress=_say if data.n_poses >= PROGRESS_POSES else None,
    )
    out = report.to_dict()
    out["file"] = args.file
    out["settings"] = {
        "geometry": args.geometry,
        "family": geometry.family,
        "sigma_um": args.sigma_um,
        "sigma_arcsec": args.sigma_arcsec,
        "sigma_stroke_um": args.sigma_stroke_um,
        "sigma_reading_urad": args.sigma_reading_urad,
        "holdout_fraction": args.holdout_fraction,
        "seed": args.seed,
        "alpha": args.alpha,
        "estimate_noise": args.estimate_noise,
    }
    return _finish(args, report, out)


def _diagnose_points(args: argparse.Namespace, effects) -> int:
    """``diagnose POINTS.csv --geometry G --targets T.json [--tracker-sigma-um R,A]``: the workflow on
    the tracker's points, with its noise model (:func:`~stewart_jax.discrepancy.points_model`)."""
    from ..calibration._points_io import read_points_csv, read_targets
    from ..discrepancy import diagnose, point_rows, points_model
    from ..mechanism._registry import load_mechanism
    from ._points import tracker_sigma

    if args.targets is None:
        raise ValueError(f"{args.file} is a points file (it has a 'target' column): give the targets' nominal "
                         "coordinates with --targets T.json")
    if args.out_model:
        raise ValueError("--out-model writes a model of pose data; for a points file, write the calibrated "
                         "geometry with calibrate --out-geometry")
    from .calibrate import PROGRESS_POSES

    range_um, across = tracker_sigma(args)
    targets = read_targets(args.targets)
    geometry = load_mechanism(args.geometry)
    data = read_points_csv(args.file, targets, reading_unit=geometry.reading_unit)
    rows, rotation, translation = point_rows(data, targets, geometry, range_um=range_um, across_um_per_m=across)
    model = points_model(geometry, rotation, translation)
    report = diagnose(rows, model, effects=effects, holdout_fraction=args.holdout_fraction, seed=args.seed,
                      alpha=args.alpha, estimate_noise=args.estimate_noise,
                      progress=_say if data.n_poses >= PROGRESS_POSES else None)
    out = report.to_dict()
    out["file"] = args.file
    out["data"] = "points"
    out["n_poses"] = data.n_poses
    out["n_points"] = int(len(data.points))
    out["settings"] = {
        "geometry": args.geometry,
        "family": geometry.family,
        "targets": args.targets,
        "tracker_sigma_range_um": range_um,
        "tracker_sigma_across_um_per_m": across,
        "holdout_fraction": args.holdout_fraction,
        "seed": args.seed,
        "alpha": args.alpha,
        "estimate_noise": args.estimate_noise,
    }
    return _finish(args, report, out)


def _finish(args: argparse.Namespace, report, out: dict) -> int:
    if args.plot:
        from ._common import file_backend

        file_backend()
        from ..plotting import plot_residuals

        out["plots"] = plot_residuals(report, args.plot)
    if args.out_model:
        from ..discrepancy import save_fitted_model

        save_fitted_model(report.fitted, args.out_model)
    skipped = "; ".join(f"{s.effect}: {s.reason}" for s in report.skipped)
    for line in report.summary() + ([f"skipped {skipped}"] if skipped else []):
        print(f"diagnose: {line}", file=sys.stderr)
    _emit(args, out)
    return 0


def _cmd_diagnose_cabin(args: argparse.Namespace) -> int:
    """``diagnose RECORD.csv --geometry fast``: the workflow on a record of the FAST cabin's free
    vibration (:mod:`stewart_jax.discrepancy`'s cabin-record model)."""
    from ..discrepancy import diagnose
    from ..discrepancy._cabin_record import cabin_record_model, read_cabin_record

    position, segments, sigma_um, sigma_arcsec = _cabin_settings(args)
    data = read_cabin_record(args.file)
    t0 = time.perf_counter()
    _say(f"building the cabin's model on lumped cables ({segments} segments per cable) and reading the record's "
         f"modes ({len(data.time)} samples) …")
    model = cabin_record_model(data, position, segments=segments, sigma_um=sigma_um, sigma_arcsec=sigma_arcsec)
    _say(f"model built in {time.perf_counter() - t0:.1f} s")
    effects = [e.strip() for e in args.effects.split(",") if e.strip()] if args.effects else None
    report = diagnose(data, model, effects=effects, holdout_fraction=args.holdout_fraction, seed=args.seed,
                      alpha=args.alpha, estimate_noise=args.estimate_noise, progress=_say)
    out = report.to_dict()
    out["file"] = args.file
    out["settings"] = {
        "geometry": "fast",
        "model": model.name,
        "position_m": list(position),
        "segments": segments,
        "sigma_um": sigma_um,
        "sigma_arcsec": sigma_arcsec,
        "holdout_fraction": args.holdout_fraction,
        "seed": args.seed,
        "alpha": args.alpha,
        "estimate_noise": args.estimate_noise,
    }
    out.update(_cabin_fit_summary(data, model, report))
    if args.plot:
        out["plots"] = _cabin_plots(args.plot, report, data)
    if args.out_model:
        _write_cabin_model(args.out_model, model, position, segments, report, out["modes"]["after"])
    skipped = "; ".join(f"{s.effect}: {s.reason}" for s in report.skipped)
    low = lambda m: f"{m['frequencies_hz'][0]:.4f} Hz" if m["frequencies_hz"] else "none"  # noqa: E731
    lines = report.summary() + [f"note: {n}" for n in model.notes]
    lines += _cables_line(report, segments) + _discretisation_note(report.partial, model.duration_s, segments)
    lines.append(f"lowest cabin mode {low(out['modes']['before'])} (quasi-static) → {low(out['modes']['after'])} "
                 "(augmented model); measured on FAST: 0.12–0.2 Hz")
    for line in lines + ([f"skipped {skipped}"] if skipped else []):
        print(f"diagnose: {line}", file=sys.stderr)
    _emit(args, out)
    return 0


def _discretisation_note(partial: list[dict], duration_s: float, segments: int) -> list[str]:
    """The hint a partial ``cable_inertia`` calls for: the lumped model's discretisation."""
    if not any(p["effect"] == "cable_inertia" for p in partial):
        return []
    return [f"note: the model's cables have {segments} segments, carried towards continuous cables by the fitted "
            f"continuum share; over a record of {duration_s:.0f} s that does not resolve every mode of real cables "
            "(at 20 segments their string modes near 1 Hz stay about 1e-3 off): diagnose again with "
            f"--segments (now {segments}) at 40 (a 200 s record of 80-segment cables released from rest was missed "
            "at 20 and named at 40)"]


def _cables_line(report, segments: int) -> list[str]:
    """What the fitted ``cable_inertia`` says of the cables' discretisation (its continuum share γ)."""
    from ..cable_robot._cable_continuum import segments_of

    if report.named_effect != "cable_inertia" and not any(p["effect"] == "cable_inertia" for p in report.partial):
        return []
    gamma = float(next(c for c in report.ranking if c.effect == "cable_inertia").params[2])
    n = segments_of(gamma, segments)
    like = "continuous cables" if n == float("inf") or n > 50 * segments else f"≈ {n:.0f} segments per cable"
    return [f"the cables' continuum share γ = {gamma:.2f}: the record's cables behave as {like} (the model's "
            f"{segments} at γ = 0, continuous at γ = 1)"]


def _say(text: str) -> None:
    # each stage's start and end, on stderr: a cabin record always (its model alone takes tens of
    # seconds), pose and points data from calibrate's PROGRESS_POSES poses
    print(f"diagnose: {text}", file=sys.stderr, flush=True)


def _cabin_settings(args: argparse.Namespace) -> tuple[tuple[float, float, float], int, float, float]:
    """A cabin record's settings, checked: the cabin's position (m), the segments per cable and
    the tracker's noise σ (µm, ″), each defaulted where not given; the options of other data
    refused."""
    from ..discrepancy._cabin_record import DEFAULT_SEGMENTS

    position = (0.0, 0.0, 140.0) if args.position is None else args.position
    segments = DEFAULT_SEGMENTS if args.segments is None else args.segments
    if args.sigma_stroke_um or args.sigma_reading_urad:
        raise ValueError("--sigma-stroke-um and --sigma-reading-urad are an actuator reading's noise; a cabin record "
                         "has none")
    if args.targets is not None or args.tracker_sigma_um is not None:
        raise ValueError("--targets and --tracker-sigma-um are for a points file; a cabin record's noise is "
                         "--sigma-um and --sigma-arcsec")
    sigma_um = FAST_SIGMA_UM if args.sigma_um is None else args.sigma_um
    sigma_arcsec = FAST_SIGMA_ARCSEC if args.sigma_arcsec is None else args.sigma_arcsec
    from ..cable_robot._lumped import check_segments

    check_segments(segments)
    return position, segments, sigma_um, sigma_arcsec


def _cabin_fit_summary(data, model, report) -> dict:
    """The report's ``record`` (rows, duration, rate, the model's notes and fit starts),
    ``base_params`` (before and after, with units) and ``modes`` (before and after, and the
    band measured on FAST) of a cabin record."""
    import numpy as np

    from ..discrepancy._cabin_record import BASE_NAMES, fitted_modes

    t = np.asarray(data.time)
    return {
        "record": {"rows": int(t.size), "duration_s": float(t[-1]), "rate_hz": float((t.size - 1) / t[-1]),
                   "notes": list(model.notes),
                   "fit_starts": {name: list(v) for name, v in model.grids}},
        "base_params": {
            "names": list(BASE_NAMES),
            "units": ["mm"] * 3 + ["mrad"] * 3 + ["mm/s"] * 3 + ["mrad/s"] * 3 + ["1"] + ["mm"] * 3 + ["mrad"] * 3,
            "before": np.asarray(report.base_fitted.base).tolist(),
            "after": np.asarray(report.fitted.base).tolist(),
        },
        "modes": {
            "before": fitted_modes(model),
            "after": fitted_modes(model, report.fitted.effects, report.fitted.thetas),
            "measured_band_hz": [0.12, 0.2],
            "measured_band_source": "Li, Sun, Li, Yao, Universe 10(12):450, 2024 (lowest cabin-cable mode)",
        },
    }


def _cabin_plots(directory: str, report, data) -> list[str]:
    """``--plot``: the residual plots and the record's fit (``record_fit.png``) written to
    ``directory``; their paths."""
    import os

    from ._common import file_backend

    file_backend()
    from ..plotting import plot_cabin_record, plot_residuals, show

    paths = plot_residuals(report, directory)
    path = os.path.join(directory, "record_fit.png")
    show(plot_cabin_record(report, data), path)
    paths.append(path)
    return paths


def _write_cabin_model(path: str, model, position, segments: int, report, modes_after: dict) -> None:
    """``--out-model``: the augmented cabin model as JSON (the base parameters, the effects and
    the modes' frequencies after the fit)."""
    import numpy as np

    from .._files import json_text, write_text_atomic
    from ..discrepancy._cabin_record import BASE_NAMES

    write_text_atomic(path, json_text({
        "model": model.name, "position_m": list(position), "segments": segments,
        "base_params": dict(zip(BASE_NAMES, np.asarray(report.fitted.base).tolist(), strict=True)),
        "effects": report.fitted.effect_report(), "modes_hz": modes_after["frequencies_hz"],
    }))


def _emit(args: argparse.Namespace, out: dict) -> None:
    """The report's JSON: to ``--json`` (atomically), else to standard output."""
    if args.json:
        from ._common import write_json

        write_json(args.json, out)
    else:
        from .._files import json_text

        print(json_text(out, indent=None), end="")


def _position(text: str) -> tuple[float, float, float]:
    import math

    try:
        values = tuple(float(p) for p in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--position must be X,Y,Z in metres, got {text!r}") from None
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"--position must be three finite numbers X,Y,Z, got {text!r}")
    return values  # type: ignore[return-value]


def _reading_sigma(args: argparse.Namespace, geometry) -> float:
    """The reading noise in the readings' report unit: ``--sigma-stroke-um`` (linear readings) or
    ``--sigma-reading-urad`` (a rotary family's crank angles), the other refused."""
    if geometry.reading_unit == "mm":
        if args.sigma_reading_urad:
            raise ValueError(f"--sigma-reading-urad is for crank angles; a {geometry.family} reads mm "
                             "(--sigma-stroke-um)")
        return args.sigma_stroke_um
    if args.sigma_stroke_um:
        raise ValueError(f"a {geometry.family} reads crank angles: give their noise as --sigma-reading-urad")
    return args.sigma_reading_urad


def _cmd_simulate_effect(args: argparse.Namespace) -> int:
    from ..discrepancy import simulate_hidden_effect, write_hidden_csv
    from ._common import check_outputs

    check_outputs(args, out="--out")
    effect = None if args.effect == "none" else args.effect
    sim = simulate_hidden_effect(
        args.seed, effect, args.magnitude, n_random=args.n_random, plan=not args.no_plan,
        sigma_um=args.sigma_um, sigma_arcsec=args.sigma_arcsec,
    )
    write_hidden_csv(args.out, sim)
    print(
        f"wrote {sim.data.n_poses} poses with hidden effect {args.effect} (unabsorbable signature "
        f"{sim.truth.magnitude:.3g}× noise, total {sim.truth.raw_magnitude:.3g}×) to {args.out}",
        file=sys.stderr,
    )
    return 0


def add_diagnose_parser(subparsers) -> argparse.ArgumentParser:
    """Register ``diagnose`` (and ``simulate-effect``) on a ``add_subparsers()`` object."""
    from ..discrepancy import effect_names
    from ..discrepancy._families import model_families
    from ..discrepancy._pss import PSS_MODEL_NAME
    from ._points import tracker_sigma_arg

    names = effect_names(PSS_MODEL_NAME)
    per_family = "; ".join(f"{fam}: {', '.join(effect_names(m))}" for fam, m in model_families().items())
    p = subparsers.add_parser("diagnose", help="model-discrepancy workflow: detect, name, add, show")
    p.add_argument("file", help="measured data CSV (x..rz, q1..q6; dir1..dir6, temperature, time optional), or a "
                   "laser tracker's points file (pose, target, q1..q6, x, y, z) with --targets; with --geometry fast a "
                   "record of the FAST cabin (time,x,y,z,rx,ry,rz)")
    p.add_argument("--geometry", default="nominal",
                   help="starting geometry: preset or JSON/TOML file; its family picks the model and the candidates; "
                   "'fast': the file is a free-vibration record of the FAST cabin (time,x,y,z,rx,ry,rz; candidates: "
                   "cable_inertia, cable_stiffness, cabin_mass, damping)")
    p.add_argument("--targets", help="a points file's targets (JSON, mm): its rows are the tracker's points")
    p.add_argument("--tracker-sigma-um", type=tracker_sigma_arg, metavar="RANGE,ACROSS_PER_M",
                   help="a points file's tracker noise: σ along the line of sight (µm) and across it (µm per metre "
                   "of distance); default 5,2.5")
    p.add_argument("--position", type=_position, default=None, metavar="X,Y,Z",
                   help="--geometry fast: the cabin's position G t_C in metres (default 0,0,140)")
    p.add_argument("--segments", type=int, default=None, metavar="N",
                   help="--geometry fast: lumped-mass segments per cable behind cable_inertia (default 20, as "
                        "fast --free-decay)")
    p.add_argument("--sigma-um", type=float, default=None,
                   help=f"pose noise σ, translation (µm; default 0.1, or {FAST_SIGMA_UM:g} for --geometry fast)")
    p.add_argument("--sigma-arcsec", type=float, default=None,
                   help=f"pose noise σ, angles (″; default 0.1, or {FAST_SIGMA_ARCSEC:g} for --geometry fast)")
    p.add_argument("--sigma-stroke-um", type=float, default=0.0, help="actuator reading noise σ (µm)")
    p.add_argument("--sigma-reading-urad", type=float, default=0.0,
                   help="a rotary family's crank-reading noise σ (µrad)")
    p.add_argument("--estimate-noise", action="store_true",
                   help="estimate the noise scale from the base fit (F tests) instead of trusting σ")
    p.add_argument("--temperature-std-k", type=float, default=0.0,
                   help="σ of the recorded temperature (K): thermal candidates are tested with that error in "
                   "their prediction (default 0: exact)")
    p.add_argument("--holdout-fraction", type=float, default=0.3, help="share of poses held out")
    p.add_argument("--seed", type=int, default=0, help="seed of the train/held-out split")
    p.add_argument("--alpha", type=float, default=0.05, help="false-alarm level of the detection test")
    p.add_argument("--effects", help="comma-separated candidate names (default: all registered for the geometry's "
                   f"family; {per_family})")
    p.add_argument("--json", help="write the report as JSON")
    p.add_argument("--plot", metavar="DIR", help="write residual plots (before/after) to DIR")
    p.add_argument("--out-model", help="write the augmented model (geometry + effect parameters) as JSON")
    p.set_defaults(func=_cmd_diagnose)

    q = subparsers.add_parser("simulate-effect", help="simulated measured data with one hidden effect (CSV)")
    q.add_argument("--out", required=True)
    q.add_argument("--effect", choices=("none",) + names, default="none")
    q.add_argument("--magnitude", type=float, default=3.0, help="unabsorbable signature RMS / noise")
    q.add_argument("--seed", type=int, default=0)
    q.add_argument("--n-random", type=int, default=60, help="random poses added to the 120-pose plan")
    q.add_argument("--no-plan", action="store_true", help="random poses only")
    q.add_argument("--sigma-um", type=float, default=0.1)
    q.add_argument("--sigma-arcsec", type=float, default=0.1)
    q.set_defaults(func=_cmd_simulate_effect)
    return p
