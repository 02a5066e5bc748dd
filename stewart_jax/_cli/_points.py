"""``calibrate POINTS.csv --targets T.json`` and ``simulate --points``: the laser tracker's own points."""

from __future__ import annotations

import argparse
import csv
import sys
import time

import numpy as np

from ._common import check_outputs, seed_key, write_json


def tracker_sigma_arg(text: str) -> float | tuple[float, float]:
    """``S`` (one σ, µm) or ``RANGE,ACROSS_PER_M`` (µm, µm per metre), for ``--tracker-sigma-um``."""
    try:
        values = tuple(float(x) for x in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected S or RANGE,ACROSS_PER_M (µm, µm/m), got {text!r}") from None
    if len(values) not in (1, 2) or not all(np.isfinite(v) and v > 0 for v in values):
        raise argparse.ArgumentTypeError(f"expected one or two positive numbers (µm; µm/m), got {text!r}")
    return values[0] if len(values) == 1 else values


def is_points_file(path: str) -> bool:
    """A points file is recognised by its ``target`` column."""
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            header = next(csv.reader(f), [])
    except (OSError, UnicodeDecodeError):
        return False
    return "target" in (h.strip() for h in header)


def tracker_sigma(args) -> tuple[float, float]:
    from ..calibration._points import DEFAULT_TRACKER_SIGMA

    s = args.tracker_sigma_um
    if s is None:
        return DEFAULT_TRACKER_SIGMA
    if not isinstance(s, tuple):
        raise ValueError("a points file's tracker noise is --tracker-sigma-um RANGE,ACROSS_PER_M: σ along the line "
                         "of sight (µm) and across it (µm per metre of distance)")
    return s


def run_calibrate(args: argparse.Namespace) -> int:
    """``stewart-jax calibrate POINTS.csv --geometry G --targets T.json [--tracker-sigma-um R,A]``."""
    range_um, across = _check_calibrate_args(args)

    from ..calibration._points import calibrate_points
    from ..calibration._points_io import read_points_csv, read_targets
    from ._common import load_nominal

    targets = read_targets(args.targets)
    nominal = load_nominal(args)
    data = read_points_csv(args.file, targets, reading_unit=nominal.reading_unit)
    t0 = time.perf_counter()
    cal = calibrate_points(data, targets, nominal, range_um=range_um, across_um_per_m=across,
                           **({"max_steps": args.max_steps} if args.max_steps is not None else {}))
    seconds = time.perf_counter() - t0
    a = cal.assessment
    out = _calibrate_result(cal, data, nominal, seconds, range_um, across)
    print(f"lm-batched (points): χ² = {cal.chi2:.6g} on {a.dof} degrees of freedom, rms point residual "
          f"{out['rms_point_residual_um']:.4g} µm, {data.n_poses} poses ({out['poses_with_1_or_2_targets']} with 1–2 "
          f"targets) in {seconds:.2f} s, status {cal.status}, data {a.status}", file=sys.stderr)
    for w in a.warnings:
        print(f"WARNING: {w}", file=sys.stderr)
    if args.report:
        _write_report(args, out, cal, data, targets, nominal, range_um, across)
    if args.json:
        write_json(args.json, out)
    if args.out_geometry and cal.status != "nonfinite":
        from ..calibration._determined import prior_scale
        from ._common import save_calibrated

        save_calibrated(args.out_geometry, nominal, cal.mechanism, a, prior_scale(nominal.param_units))
    if not args.json:
        from .._files import json_text

        print(json_text(out, indent=None), end="")
    if a.status == "nonfinite":
        return 1
    return 3 if a.status == "rank_deficient" else 0


def _check_calibrate_args(args: argparse.Namespace) -> tuple[float, float]:
    """The tracker noise (µm along the line of sight, µm per metre across it) of a points file's
    ``calibrate``, after refusing the outputs that cannot be written, a missing ``--targets`` and
    the options a points file does not take."""
    check_outputs(args, json="--json", out_geometry="--out-geometry", report="--report")
    if args.targets is None:
        raise ValueError(f"{args.file} is a points file (it has a 'target' column): give the targets' nominal "
                         "coordinates with --targets T.json")
    for flag, value in (("--plot", args.plot), ("--holdout", args.holdout)):
        if value is not None:
            raise ValueError(f"{flag} is for pose files; a points file's report uses every pose")
    if args.method != "lm-batched":
        raise ValueError("a points file is calibrated by the batched Levenberg–Marquardt (--method lm-batched)")
    return tracker_sigma(args)


def _calibrate_result(cal, data, nominal, seconds: float, range_um: float, across: float) -> dict:
    """The JSON result of a points calibration ``cal``: the fit, the registration, the assessment
    (the mechanism's parameters and the registration's standard deviations apart) and, unless the
    data are non-finite, the predicted control error's largest std per pose component."""
    n = nominal.n_params
    a = cal.assessment
    seen = data.targets_per_pose()
    out = {
        "method": "lm-batched",
        "data": "points",
        "params": cal.params.tolist(),
        "param_names": list(nominal.param_names),
        "cost": cal.chi2,
        "n_evaluations": cal.n_steps,
        "seconds": seconds,
        "status": cal.status,
        "n_poses": data.n_poses,
        "n_points": int(len(data.points)),
        "n_references": int(len(data.references)),
        "poses_with_1_or_2_targets": int(np.sum(seen < 3)),
        "rms_point_residual_um": float(np.sqrt(np.mean(np.sum(cal.residuals_um**2, axis=1)))),
        "tracker_sigma_range_um": range_um,
        "tracker_sigma_across_um_per_m": across,
        "registration_rotation": cal.rotation.tolist(),
        "registration_translation_mm": cal.translation.tolist(),
    }
    from .calibrate import _assessment_keys

    out.update(_assessment_keys(a))
    out["param_std"] = out["param_std"][:n]
    out["registration_std"] = [float(s) if np.isfinite(s) else None for s in a.param_std[n:]]
    out["identifiable"] = out["identifiable"][:n]
    if a.status != "nonfinite":
        from ..calibration._identifiability import predicted_control_error_std

        std = predicted_control_error_std(cal.mechanism, cal.poses, a.param_cov[:n, :n])
        out["predicted_control_error_std_max"] = dict(
            zip(("dx_um", "dy_um", "dz_um", "phi_arcsec", "theta_arcsec", "psi_arcsec"),
                np.max(std, axis=0).tolist(), strict=True))
    return out


def _write_report(args, out: dict, cal, data, targets, nominal, range_um: float, across: float) -> None:
    """Write the calibration report of a points calibration to ``--report``: the pose file's
    report, with the implied pose errors under the fitted registration and the points' RMS
    residual in place of the cost."""
    from .._files import write_text_atomic
    from ..calibration._points import implied_point_pose_errors
    from ..calibration._report import calibration_report

    n = nominal.n_params
    a = cal.assessment
    errors = {"nominal geometry": implied_point_pose_errors(nominal, data, targets, cal.rotation, cal.translation),
              "calibrated": implied_point_pose_errors(cal.mechanism, data, targets, cal.rotation, cal.translation)}
    result = dict(out, rms_residual_um=out["rms_point_residual_um"])
    text = calibration_report(
        source={"data": args.file, "targets": args.targets, "geometry": args.geometry,
                "method": "lm-batched on tracker points",
                "tracker noise": f"{range_um} µm along the line of sight, {across} µm/m across"},
        nominal=nominal, calibrated=cal.mechanism, result=result, assessment=a._replace(param_std=a.param_std[:n]),
        pose_errors=errors, heldout=None)
    cost_line = next(x for x in text.splitlines() if x.startswith("- cost S = "))
    text = text.replace(cost_line, f"- {len(data.points)} platform points and {len(data.references)} base "
                        f"references; RMS point residual (3-D) {out['rms_point_residual_um']:.4g} µm")
    write_text_atomic(args.report, text)


def run_simulate(args: argparse.Namespace) -> int:
    """``stewart-jax simulate --points --targets T.json``: a points file with the tracker's noise."""
    import jax

    from ..calibration._points_io import read_targets, write_points_csv, write_targets
    from ..calibration._points_simulation import default_targets, simulate_points
    from ..calibration._simulation import plan_poses, reachable_travel
    from ..mechanism._registry import save_mechanism
    from ._common import nominal_and_true

    check_outputs(args, out="--out", out_true="--out-true")
    if args.targets is None:
        raise ValueError("--points needs --targets T.json (add --default-targets to write a default set there)")
    if args.default_targets:
        check_outputs(args, targets="--targets")
    range_um, across = tracker_sigma(args)
    nominal, true = nominal_and_true(args)
    targets = default_targets(nominal) if args.default_targets else read_targets(args.targets)
    k_plan, k_noise = jax.random.split(seed_key(args.seed))
    commanded = plan_poses(args.plan, k_plan, reachable_travel(nominal))
    sim = simulate_points(k_noise, nominal, true, targets, commanded, range_um=range_um, across_um_per_m=across,
                          visible=args.visible)
    if args.default_targets:
        write_targets(args.targets, targets)
    write_points_csv(args.out, sim.data, targets, reading_unit=nominal.reading_unit)
    if args.out_true:
        save_mechanism(true, args.out_true)
    print(f"wrote {len(sim.data.points)} target points of {sim.data.n_poses} poses and "
          f"{len(sim.data.references)} base references ({args.plan}, seed {args.seed}) to {args.out}", file=sys.stderr)
    return 0
