"""``stewart-jax calibrate``: calibrate a mechanism's parameters from a measured CSV with any registered method."""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

from .._units import ascii_unit, is_angle, report_factor, report_unit
from ..calibration._methods import METHOD_REGISTRY
from ._common import (
    check_outputs,
    file_backend,
    load_nominal,
    noise_args,
    param_set_arg,
    save_calibrated,
    seed_key,
    write_json,
)


def _reading_labels(mechanism) -> tuple[str, str, str]:
    """The JSON key of the RMS reading residual (``rms_residual_um`` or ``rms_residual_urad``), the
    readings' report unit and the cost's unit (``mm²`` or ``rad²``)."""
    unit = report_unit(mechanism.reading_unit)
    return f"rms_residual_{ascii_unit(unit)}", unit, f"{mechanism.reading_unit}²"


def run(args: argparse.Namespace) -> int:
    """``stewart-jax calibrate FILE.csv [--method M] [--geometry G] …``: a points file goes to
    :func:`._points.run_calibrate`; a pose file is fitted, assessed, printed and written."""
    from . import _points

    if _points.is_points_file(args.file):
        return _points.run_calibrate(args)
    if args.targets is not None and os.path.isfile(args.file):
        raise ValueError(f"--targets is for a laser tracker's points file (one with a 'target' column); {args.file} "
                         "has none: a pose file is calibrated without --targets")
    holdout = _check_args(args)

    import jax

    from ..calibration._assessment import hold_undetermined
    from ..calibration._csv import read_csv
    from ..calibration._methods import calibrate
    from ..calibration._problem import calibration_problem, reading_residuals_compiled
    from ..mechanism._registry import save_mechanism

    nominal, file_warnings = _load_nominal_warned(args)
    data = read_csv(args.file, reading_unit=nominal.reading_unit)
    _check_reachable(nominal, data, args)
    problem = calibration_problem(data, nominal, args.half_width, args.half_width_mrad)
    options = {}
    if args.max_evaluations is not None:
        options["max_evaluations"] = args.max_evaluations
    if args.max_steps is not None:
        options["max_steps"] = args.max_steps
    big = data.n_poses >= PROGRESS_POSES
    _progress(big, f"fitting {data.n_poses} poses with {args.method} …")
    t0 = time.perf_counter()
    result = jax.block_until_ready(calibrate(problem, args.method, seed_key(args.seed), **options))
    params = np.asarray(result.params)
    if np.all(np.isfinite(params)):
        params = hold_undetermined(nominal, data, params, args.sigma_um, args.sigma_arcsec)
        result = result._replace(params=params, cost=float(np.sum(np.asarray(
            reading_residuals_compiled(params, data, nominal)) ** 2)))
    seconds = time.perf_counter() - t0
    rms_key, reading_unit, cost_unit = _reading_labels(nominal)
    out = _fit_keys(args, nominal, problem, result, params, data.n_poses, seconds)
    if args.json:
        write_json(args.json, out)  # the fit first: a later step that fails never loses it
    _progress(big, f"fit done in {seconds:.1f} s (status {out['status']})"
              + (f", written to {args.json}" if args.json else ""))
    calibrated = nominal.with_params(params)
    assessment = _assess(args, out, nominal, calibrated, data, params, big)
    _plausibility(out, nominal, params, problem, file_warnings)
    print(
        f"{args.method}: S = {out['cost']:.6g} {cost_unit} (rms reading residual {out[rms_key]:.4g} {reading_unit}) "
        f"after {out['n_evaluations']} evaluations in {seconds:.2f} s, status {out['status']}"
        + (f", data {out['data_status']}" if "data_status" in out else ""),
        file=sys.stderr,
    )
    for w in out.get("warnings", []):
        print(f"WARNING: {w}", file=sys.stderr)
    if args.report and assessment is not None:
        _write_report(args, out, nominal, calibrated, data, assessment, holdout, options)
    if args.json:
        write_json(args.json, out)
    if args.out_geometry and out["status"] != "nonfinite":
        if assessment is None:
            save_mechanism(calibrated, args.out_geometry)
        else:
            from ..calibration._determined import prior_scale

            save_calibrated(args.out_geometry, nominal, calibrated, assessment, prior_scale(nominal.param_units))
    if args.plot:
        _plot(args, nominal, data, result.params, reading_unit)
    if not args.json:
        from .._files import json_text

        print(json_text(out, indent=None), end="")
    if out["status"] == "nonfinite" or out.get("data_status") == "nonfinite":
        return 1
    return 3 if out.get("data_status") == "rank_deficient" else 0


def _check_args(args: argparse.Namespace) -> float:
    """The fraction of the poses held out for the report's check, after refusing (before any
    work) the options a pose file does not take, outputs that cannot be written and out-of-range
    numbers."""
    if args.tracker_sigma_um is not None:
        raise ValueError("--tracker-sigma-um is for a points file (with --targets); a pose file takes --sigma-um "
                         "and --sigma-arcsec")
    check_outputs(args, json="--json", out_geometry="--out-geometry", plot="--plot", report="--report")
    for name, value, least in (("--max-evaluations", args.max_evaluations, 1), ("--max-steps", args.max_steps, 1)):
        if value is not None and value < least:
            raise ValueError(f"{name} must be >= {least}, got {value}")
    if not (np.isfinite(args.half_width) and args.half_width > 0):
        raise ValueError(f"--half-width must be a positive number (mm), got {args.half_width}")
    if args.half_width_mrad is not None and not (np.isfinite(args.half_width_mrad) and args.half_width_mrad > 0):
        raise ValueError(f"--half-width-mrad must be a positive number (mrad), got {args.half_width_mrad}")
    if not (args.sigma_um > 0 and args.sigma_arcsec > 0 and np.isfinite(args.sigma_um + args.sigma_arcsec)):
        raise ValueError(f"--sigma-um and --sigma-arcsec must be positive (the pose noise of the data), got "
                         f"{args.sigma_um} µm, {args.sigma_arcsec}″")
    holdout = args.holdout if args.holdout is not None else (0.2 if args.report else 0.0)
    if not 0 <= holdout < 1:
        raise ValueError(f"--holdout must be a fraction in [0, 1), got {holdout}")
    if args.max_evaluations is not None and METHOD_REGISTRY[args.method].kind == "least_squares":
        raise ValueError("--max-evaluations applies to the metaheuristics; LM takes --max-steps")
    return holdout


def _load_nominal_warned(args) -> tuple:
    """The nominal mechanism and the geometry file's warnings (their messages), each printed on
    stderr as it is recorded."""
    import warnings

    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        nominal = load_nominal(args)
    file_warnings = [str(w.message) for w in seen if issubclass(w.category, UserWarning)]
    for w in file_warnings:
        print(f"WARNING: {w}", file=sys.stderr)
    return nominal, file_warnings


def _fit_keys(args, nominal, problem, result, params, m: int, seconds: float) -> dict:
    """The JSON keys of the fit of ``m`` poses (``params``: ``Float[np.ndarray, "n"]``, the
    parameters' units; ``result``: the solver's): the parameters, the cost, status and time, the
    RMS reading residual (the readings' report unit), whether the fit ended in the box, the box
    and the seed."""
    from ..optimise._result import status_name

    rms_key, _, cost_unit = _reading_labels(nominal)
    out = {
        "method": args.method,
        "params": params.tolist(),
        "param_names": list(nominal.param_names),
        "param_units": list(nominal.param_units),
        "cost": float(result.cost),
        "cost_unit": cost_unit,
        "n_evaluations": int(result.n_evaluations),
        "seconds": seconds,
        "status": status_name(result.status),
        "n_poses": m,
        rms_key: float(np.sqrt(float(result.cost) / (6 * m)) * report_factor(nominal.reading_unit)),
        "in_box": bool(np.all((params >= np.asarray(problem.lower)) & (params <= np.asarray(problem.upper)))),
        "half_width_mm": args.half_width,
        "seed": args.seed,
    }
    if any(is_angle(u) for u in nominal.param_units):
        out["half_width_mrad"] = args.half_width if args.half_width_mrad is None else args.half_width_mrad
    return out


def _assess(args, out: dict, nominal, calibrated, data, params, big: bool):
    """Assess a finite fit (``params``: ``Float[np.ndarray, "n"]``) with :func:`assess_calibration`
    and add its keys and the predicted control error's largest std per pose component to ``out``;
    the assessment, or ``None`` for a non-finite fit, which ``out`` then marks as such with its
    warning."""
    from ..calibration._assessment import assess_calibration

    if out["status"] != "nonfinite" and np.all(np.isfinite(params)):
        _progress(big, "assessing the calibration (identifiability, goodness of fit, predicted control error) …")
        t_assess = time.perf_counter()
        assessment = assess_calibration(calibrated, data, args.sigma_um, args.sigma_arcsec, nominal=nominal)
        out.update(_assessment_keys(assessment))
        if assessment.status != "nonfinite":
            from ..calibration._identifiability import predicted_control_error_std

            std = predicted_control_error_std(calibrated, data.poses, assessment.param_cov)
            out["predicted_control_error_std_max"] = dict(
                zip(("dx_um", "dy_um", "dz_um", "phi_arcsec", "theta_arcsec", "psi_arcsec"),
                    np.max(std, axis=0).tolist(), strict=True))
        _progress(big, f"assessment done in {time.perf_counter() - t_assess:.1f} s")
        return assessment
    out["data_status"] = "nonfinite"
    out["warnings"] = ["the solver met a non-finite cost: a row the geometry cannot reach or a NaN in the data; "
                       "check the units (mm, degrees) of the CSV and of the geometry"]
    return None


def _write_report(args, out: dict, nominal, calibrated, data, assessment, holdout: float, options: dict) -> None:
    """Write the calibration report to ``--report``, with the implied pose errors before and after
    calibration and, for ``holdout > 0``, at poses held out of a second calibration."""
    from .._files import write_text_atomic
    from ..calibration._assessment import implied_pose_errors
    from ..calibration._report import calibration_report

    heldout = _heldout(args, data, nominal, holdout, options) if holdout > 0 else None
    errors = {"nominal geometry": implied_pose_errors(nominal, data),
              "calibrated": implied_pose_errors(calibrated, data)}
    text = calibration_report(
        source={"data": args.file, "geometry": args.geometry, "method": args.method,
                "pose noise": f"{args.sigma_um} µm, {args.sigma_arcsec}″"},
        nominal=nominal, calibrated=calibrated, result=out, assessment=assessment, pose_errors=errors,
        heldout=heldout)
    write_text_atomic(args.report, text)


def _plot(args, nominal, data, params, reading_unit: str) -> None:
    """Plot the reading residuals (``(m, 6)``, the readings' report unit) at the nominal and at the
    calibrated ``params`` to ``--plot``."""
    from ..calibration._problem import reading_residuals_compiled

    file_backend()
    from .. import plotting
    factor = report_factor(nominal.reading_unit)
    before = np.asarray(reading_residuals_compiled(nominal.params, data, nominal)).reshape(-1, 6) * factor
    after = np.asarray(reading_residuals_compiled(params, data, nominal)).reshape(-1, 6) * factor
    series = {"nominal": before, f"calibrated ({args.method})": after}
    figure = (plotting.plot_reading_residuals(series, sigma_um=args.sigma_um) if nominal.reading_unit == "mm"
              else plotting.plot_reading_residuals(series, unit=reading_unit))
    plotting.show(figure, args.plot)


def _check_reachable(nominal, data, args) -> None:
    """Refuse rows the nominal geometry cannot reach, naming them (wrong units, swapped columns)."""
    from ..calibration._identifiability import kinematic_snapshot

    # the program the assessment runs later: checking here compiles nothing of its own
    bad = np.flatnonzero(~kinematic_snapshot(nominal, data.poses, args.sigma_um, args.sigma_arcsec).reachable)
    if bad.size:
        raise ValueError(
            f"{args.file}: rows {(bad + 1).tolist()[:10]}{' …' if bad.size > 10 else ''} (1-based, after the header) "
            f"are poses the nominal geometry {args.geometry!r} cannot reach — are the lengths in mm and the angles "
            "in degrees, and is this the right geometry?")


PROGRESS_POSES = 1000
"""A calibration of at least this many poses says on stderr when each stage (the fit, the
assessment) starts and ends, with its time: at 10⁴ poses each takes from seconds to minutes."""


def _progress(show: bool, text: str) -> None:
    if show:
        print(f"calibrate: {text}", file=sys.stderr, flush=True)


PLAUSIBLE_BOX_FACTOR = 10.0
"""A calibrated parameter further from nominal than this many half-widths of the stated box is
implausible (a unit slip, the wrong geometry): the data status is never ``ok`` then."""


def _plausibility(out: dict, nominal, params, problem, file_warnings: list[str]) -> None:
    """The geometry file's unit-slip warnings and parameters far outside the stated box turn the
    data status from ``ok`` to ``implausible``, with a warning naming the parameter."""
    half = 0.5 * (np.asarray(problem.upper) - np.asarray(problem.lower))
    moved = np.abs(params - np.asarray(nominal.params)) / np.where(half > 0, half, np.inf)
    found = [f"the geometry file looks wrong, so the fit is not trusted: {w}" for w in file_warnings[:1]]
    if np.any(moved > PLAUSIBLE_BOX_FACTOR):
        i = int(np.argmax(moved))
        found.append(f"parameter {nominal.param_names[i]} moved {abs(params[i] - float(nominal.params[i])):.4g} "
                     f"{nominal.param_units[i]} from nominal, {moved[i]:.3g}× the half-width of the stated box "
                     f"(±{half[i]:.4g} {nominal.param_units[i]}); {int(np.sum(moved > PLAUSIBLE_BOX_FACTOR))} "
                     f"parameter(s) past {PLAUSIBLE_BOX_FACTOR:g}×: a unit slip (a file in metres or radians) or "
                     "the wrong geometry, not a calibration")
    if found:
        out["warnings"] = list(out.get("warnings", [])) + found
        if out.get("data_status") == "ok":
            out["data_status"] = "implausible"


def _assessment_keys(a) -> dict:
    return {
        "data_status": a.status,
        "warnings": a.warnings,
        "identification_rank": a.rank,
        "determined_directions": a.n_determined,
        "identification_condition_number": a.condition_number,
        "identifiable": a.identifiable.tolist(),
        "param_std": [float(s) if np.isfinite(s) else None for s in a.param_std],
        "duplicate_rows": [[i + 1 for i in g] for g in a.duplicate_rows],
        "chi2": a.chi2, "dof": a.dof, "p_value": a.p_value, "residual_to_noise_ratio": a.rms_ratio,
    }


def _heldout(args, data, nominal, fraction, options) -> dict:
    """Calibrate without a random ``fraction`` of the rows; the held-out rows' implied pose errors."""

    from ..calibration._assessment import hold_undetermined, implied_pose_errors
    from ..calibration._methods import calibrate
    from ..calibration._problem import calibration_problem

    m = data.n_poses
    k = int(round(fraction * m))
    rng = np.random.default_rng(args.seed)
    test = np.sort(rng.choice(m, size=k, replace=False))
    train = np.setdiff1d(np.arange(m), test)
    if 6 * len(train) < nominal.n_params or k == 0:
        raise ValueError(f"--holdout {fraction}: {m} poses leave {len(train)} to calibrate {nominal.n_params} "
                         "parameters with; use a smaller fraction or --holdout 0")
    res = calibrate(calibration_problem(data.take(train), nominal, args.half_width, args.half_width_mrad), args.method,
                    seed_key(args.seed), **options)
    params = np.asarray(res.params)
    if np.all(np.isfinite(params)):
        params = hold_undetermined(nominal, data.take(train), params, args.sigma_um, args.sigma_arcsec)
    fitted = nominal.with_params(params)
    held = data.take(test)
    return {"rows": (test + 1).tolist(),
            "errors": {"nominal geometry": implied_pose_errors(nominal, held),
                       "calibrated without them": implied_pose_errors(fitted, held)}}


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser("calibrate", help="calibrate a mechanism's parameters from a measured CSV")
    p.add_argument("file", help="measured data CSV (q1..q6, x, y, z, rx, ry, rz)")
    p.add_argument("--method", choices=tuple(METHOD_REGISTRY), default="lm-batched",
                   help="calibration method (default: lm-batched, the fast LM; lm: optimistix's, the reference)")
    p.add_argument("--seed", type=int, default=0, help="PRNG seed of the stochastic methods")
    noise_args(p)
    p.add_argument("--json", help="write the result as JSON")
    p.add_argument("--geometry", default="nominal", help="starting/nominal geometry: preset or file")
    param_set_arg(p)
    p.add_argument("--half-width", type=float, default=10.0, help="Ω = nominal ± this for each length parameter (mm)")
    p.add_argument("--half-width-mrad", type=float, default=None,
                   help="Ω = nominal ± this for each angle parameter (mrad; default the --half-width number)")
    p.add_argument("--max-evaluations", type=int, help="objective-evaluation budget (metaheuristics)")
    p.add_argument("--max-steps", type=int, help="iteration budget (LM)")
    p.add_argument("--out-geometry", help="write the calibrated geometry as JSON")
    p.add_argument("--plot", metavar="OUT.png", help="stroke residuals before/after calibration")
    p.add_argument("--report", metavar="OUT.md", help="write the calibration report (Markdown): fit, "
                   "identifiability, before/after pose errors at calibration and held-out poses, parameters")
    p.add_argument("--holdout", type=float, help="fraction of the poses held out for the report's check "
                   "(default 0.2 with --report)")
    p.add_argument("--targets", metavar="T.json", help="a points file's target coordinates (mm): "
                   '{"platform_targets": {NAME: [x, y, z]}, "base_references": {NAME: [x, y, z]}}')
    p.add_argument("--tracker-sigma-um", metavar="RANGE,ACROSS_PER_M", type=_points_sigma,
                   help="a points file's tracker noise: σ along the line of sight (µm) and across it (µm per m "
                        "of distance); default 5,2.5")
    p.set_defaults(func=run)
    return p


def _points_sigma(text):
    from ._points import tracker_sigma_arg

    return tracker_sigma_arg(text)
