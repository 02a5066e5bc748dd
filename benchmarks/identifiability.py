"""Optimal pose plans and predicted vs Monte Carlo calibration uncertainty.

    python benchmarks/identifiability.py            # 200 seeds, m = 8 and m = 120, 2000 candidates
    python benchmarks/identifiability.py --quick    # 16 seeds, m = 8, 300 candidates (a smoke run)

(a) Pose plans at equal m: the paper's plans (Wang H., Cao X. et al., "Improved cuckoo
calibration method of space telescope secondary mirror adjusting mechanism", Infrared and Laser
Engineering 47(5), 2018 — m = 8: 8 random poses in the travel, a new draw per seed, its §3;
m = 120: the sampling plan of its §4) against plans chosen by ``plan_poses_optimal`` (O1 =
D-optimal and O3 = E-optimal, greedy + exchange) from candidates drawn uniformly in the travel
(±1 mm, ±1°), planned on the nominal geometry. For each plan, the control error at 42 fixed
validation poses: PREDICTED (``identifiability_report`` → ``control_error_sensitivity``,
linearised at the true geometry) and MEASURED (LM calibrations over the seeds, noise
σ = 0.1 µm / 0.1″ as read in docs/conventions.md, Ω = nominal ± 10 mm). Per component: median
and 90th percentile over seeds of the max |error| over the 42 poses (predicted: over Gaussian
draws of the parameter error from the predicted covariance, propagated linearly), and the RMS
over seeds and poses.

(b) Predicted vs Monte Carlo spread: for each fixed plan, per component the median over the
42 validation poses of (predicted std) / (std over seeds of the measured control error).

Results: ``benchmarks/results/identifiability.{json,md}`` (``identifiability_quick`` with --quick).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from _common import write_results  # noqa: E402

import stewart_jax as sj  # noqa: E402
from stewart_jax._units import ARCSEC, COMPONENTS, UM  # noqa: E402
from stewart_jax.calibration._identifiability import control_error_sensitivity  # noqa: E402  (what the prediction uses)
from stewart_jax.optimise._result import status_code  # noqa: E402
from stewart_jax.study import trial_keys  # noqa: E402

HEADERS = ["dx (µm)", "dy (µm)", "dz (µm)", "φ (″)", "θ (″)", "ψ (″)"]


@jax.jit
def _simulate(keys, targets, nominal, actual, sigma_um, sigma_arcsec):
    """One simulated data set per key (targets ``(seeds, m, 6)``) → batched LM problems."""
    sims = jax.vmap(lambda k, t: sj.simulate_measurements(k, nominal, actual, t, sigma_um, sigma_arcsec))(
        keys, targets
    )
    problems = jax.vmap(lambda d: sj.calibration_problem(d, nominal, 10.0))(sims.data)
    return problems, jnp.all(sims.converged)


@jax.jit
def _validation_errors(params, nominal, actual, validation):
    """``(seeds, 42, 6)`` control errors (mm, rad) of each calibrated parameter vector."""
    ce = jax.vmap(lambda p: sj.control_error(nominal.with_params(p), actual, validation))(params)
    return ce.errors, jnp.all(ce.converged)


def monte_carlo(targets, noise_keys, nominal, actual, validation, sigma_um, sigma_arcsec) -> dict:
    """LM calibrations, one per seed → validation control errors in µm / ″."""
    t0 = time.perf_counter()
    problems, sim_ok = _simulate(noise_keys, jnp.asarray(targets), nominal, actual, sigma_um, sigma_arcsec)
    if not bool(sim_ok):
        raise RuntimeError("forward kinematics of the true mechanism failed at a calibration pose")
    res = sj.calibration.calibrate_batch(problems, "lm-batched", noise_keys)
    errors, fk_ok = _validation_errors(res.params, nominal, actual, validation)
    errors = sj.calibration.error_in_report_units(errors)
    status, counts = np.unique(status_code(res.status), return_counts=True)
    return {
        "errors": errors,
        "fk_ok": bool(fk_ok),
        "status_counts": {int(s): int(c) for s, c in zip(status, counts, strict=True)},
        "seconds_including_compile": time.perf_counter() - t0,
    }


def predicted(covs: list[np.ndarray], M: np.ndarray, draws: int, rng: np.random.Generator) -> dict:
    """Predicted validation control error from parameter covariances (one per seed, or one
    for a fixed plan) and the sensitivity ``M`` ``(42, 6, 36)`` (mm or rad per mm)."""
    scale = np.array([1 / UM] * 3 + [1 / ARCSEC] * 3)
    var = np.stack([np.einsum("nik,kl,nil->ni", M, c, M) for c in covs]) * scale**2  # (covs, 42, 6)
    per_cov = max(1, draws // len(covs))
    maxima = []
    for c in covs:
        w, v = np.linalg.eigh(c)
        du = rng.standard_normal((per_cov, 36)) * np.sqrt(np.maximum(w, 0.0)) @ v.T  # (draws, 36)
        dp = np.einsum("nik,dk->dni", M, du) * scale
        maxima.append(np.abs(dp).max(axis=1))
    maxima = np.concatenate(maxima)
    return {
        "var": var,
        "std": np.sqrt(var.mean(axis=0)),  # (42, 6): per pose, pooled over the covariances
        "rms": np.sqrt(var.mean(axis=(0, 1))),
        "max_median": np.median(maxima, axis=0),
        "max_p90": np.percentile(maxima, 90, axis=0),
    }


def fmt_row(values, fmt="{:.3g}") -> str:
    return " | ".join(fmt.format(v) for v in values)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="16 seeds, m = 8, 300 candidates: a smoke run")
    ap.add_argument("--seeds", type=int, default=200)
    ap.add_argument("--sizes", default="8,120", help="plan sizes m (8: paper8, 120: plan120 as the paper's plan)")
    ap.add_argument("--candidates", type=int, default=2000, help="candidate poses for the optimal plans")
    ap.add_argument("--draws", type=int, default=4000, help="Gaussian draws for the predicted max error")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    if args.quick:
        args.seeds, args.sizes, args.candidates = 16, "8", 300
    sizes = [int(m) for m in args.sizes.split(",") if m]
    if any(m not in (8, 120) for m in sizes):
        raise SystemExit("--sizes: the paper's plans have m = 8 (random) and m = 120 (sampling plan)")
    sigma_um = sigma_arcsec = 0.1
    nominal, actual = sj.nominal_geometry(), sj.actual_geometry()
    validation = sj.calibration.validation_poses(jax.random.key(args.seed + 1), 42)
    candidates = sj.calibration.random_poses(jax.random.key(args.seed + 2), args.candidates)
    keys = trial_keys(args.seed, args.seeds)
    split = jax.vmap(lambda k: jax.random.split(k, 2))(keys)
    noise_keys, pose_keys = split[:, 0], split[:, 1]
    M = np.asarray(control_error_sensitivity(actual, validation))
    rng = np.random.default_rng(args.seed)

    # The plans: name → (m, targets (seeds, m, 6), fixed?, planning info)
    plans: dict[str, dict] = {}
    for m in sizes:
        if m == 8:
            per_seed = np.asarray(jax.vmap(lambda k: sj.calibration.random_poses(k, 8))(pose_keys))
            plans["paper8 (8 random poses, new draw per seed)"] = {"m": 8, "targets": per_seed, "fixed": False}
            plans["random 8 (one fixed paper-style draw)"] = {"m": 8, "targets": per_seed[0], "fixed": True}
        else:
            plan120 = np.asarray(sj.plan_poses("plan120", jax.random.key(0)))
            plans["plan120 (Wang et al. §4)"] = {"m": 120, "targets": plan120, "fixed": True}
        for criterion in ("O1", "O3"):
            t0 = time.perf_counter()
            plan = sj.calibration.plan_poses_optimal(nominal, candidates, m, criterion)
            plans[f"{criterion}-optimal {m}"] = {
                "m": m, "targets": plan.poses, "fixed": True,
                "planning": {"seconds": time.perf_counter() - t0, "criterion_history": plan.history,
                             "candidate_index": plan.index.tolist()},
            }

    out: dict[str, dict] = {}
    for name, p in plans.items():
        targets = p["targets"] if not p["fixed"] else np.broadcast_to(p["targets"], (args.seeds, *p["targets"].shape))
        pose_sets = [targets[i] for i in range(args.seeds)] if not p["fixed"] else [p["targets"]]
        report = sj.calibration.identifiability_report
        reports = [report(actual, jnp.asarray(t), sigma_um, sigma_arcsec) for t in pose_sets]
        pred = predicted([r.param_cov for r in reports], M, args.draws, rng)
        nominal_reports = [sj.calibration.identifiability_report(nominal, jnp.asarray(t)) for t in pose_sets[:50]]
        mc = monte_carlo(targets, noise_keys, nominal, actual, validation, sigma_um, sigma_arcsec)
        e = mc["errors"]  # (seeds, 42, 6)
        maxima = np.abs(e).max(axis=1)
        mc_std = e.std(axis=0, ddof=1)  # (42, 6)
        row = {
            "m": p["m"], "fixed_plan": p["fixed"],
            "O1": float(np.median([r.observability["O1"] for r in nominal_reports])),
            "O3": float(np.median([r.observability["O3"] for r in nominal_reports])),
            "condition_number": float(np.median([r.condition_number for r in nominal_reports])),
            "measured": {"max_median": np.median(maxima, axis=0).tolist(),
                         "max_p90": np.percentile(maxima, 90, axis=0).tolist(),
                         "rms": np.sqrt((e**2).mean(axis=(0, 1))).tolist(),
                         "mean_abs_bias": np.abs(e.mean(axis=0)).mean(axis=0).tolist()},
            "predicted": {k: v.tolist() for k, v in pred.items() if k not in ("std", "var")},
            "lm_status_counts": mc["status_counts"], "validation_fk_ok": mc["fk_ok"],
            "seconds_including_compile": mc["seconds_including_compile"],
        }
        if p["fixed"]:
            ratio = pred["std"] / mc_std
            row["std_ratio_pred_over_mc"] = {"median": np.median(ratio, axis=0).tolist(),
                                             "min": ratio.min(axis=0).tolist(), "max": ratio.max(axis=0).tolist()}
            row["poses"] = np.asarray(p["targets"]).tolist()
        if not p["fixed"]:
            # The pose set changes with the seed: pooled over seeds, the RMS is dominated by the few
            # ill-conditioned draws. Per seed: measured / predicted mean square over the 42 poses,
            # and the pooled RMS ratio without the 5 % of draws with the largest predicted variance.
            ms_pred, ms_meas = pred["var"].mean(axis=1), (e**2).mean(axis=1)  # (seeds, 6)
            keep = ms_pred < np.percentile(ms_pred, 95, axis=0)
            row["per_seed_ms_ratio"] = {
                "median": np.median(ms_meas / ms_pred, axis=0).tolist(),
                "max": (ms_meas / ms_pred).max(axis=0).tolist(),
                "rms_ratio_all": np.sqrt(ms_meas.mean(axis=0) / ms_pred.mean(axis=0)).tolist(),
                "rms_ratio_without_top5pct_predicted": np.sqrt(
                    (ms_meas * keep).sum(axis=0) / (ms_pred * keep).sum(axis=0)).tolist(),
            }
        if "planning" in p:
            row["planning"] = p["planning"]
        out[name] = row
        print(f"{name}: MC RMS {np.round(row['measured']['rms'], 4)}, predicted RMS "
              f"{np.round(row['predicted']['rms'], 4)} ({mc['seconds_including_compile']:.1f} s)", flush=True)

    md = [f"## Pose plans and calibration uncertainty: {args.seeds} seeds of LM, σ = 0.1 µm / 0.1″, "
          f"Ω = nominal ± 10 mm, 42 fixed validation poses", "",
          f"Optimal plans: `plan_poses_optimal` on the nominal geometry from {args.candidates} candidates uniform "
          "in the travel (±1 mm, ±1°), greedy + 2 exchange sweeps. O1, O3 and the condition number are those of "
          "the column-scaled identification Jacobian at the nominal geometry (median over seeds for paper8).", "",
          "| plan | m | O1 | O3 | condition number | LM status counts | planning s |", "|---|---|---|---|---|---|---|"]
    for name, r in out.items():
        plan_s = f"{r['planning']['seconds']:.1f}" if "planning" in r else ""
        md.append(f"| {name} | {r['m']} | {r['O1']:.4g} | {r['O3']:.3g} | {r['condition_number']:.3g} | "
                  f"{r['lm_status_counts']} | {plan_s} |")
    md += ["", "### (a) Validation control error: Monte Carlo (LM) vs predicted", "",
           "MC max: median [90th percentile] over seeds of the max |error| over the 42 poses. Predicted max: the "
           f"same from {args.draws} Gaussian draws of the parameter error with the predicted covariance, propagated "
           "linearly. RMS over seeds and poses, MC / predicted.", "",
           "| plan | quantity | " + " | ".join(HEADERS) + " |", "|---|---|" + "---|" * 6]
    for name, r in out.items():
        meas, pr = r["measured"], r["predicted"]
        md.append(f"| {name} | MC max | " + " | ".join(
            f"{a:.3g} [{b:.3g}]" for a, b in zip(meas["max_median"], meas["max_p90"], strict=True)) + " |")
        md.append("| | predicted max | " + " | ".join(
            f"{a:.3g} [{b:.3g}]" for a, b in zip(pr["max_median"], pr["max_p90"], strict=True)) + " |")
        md.append("| | RMS MC / predicted | " + " | ".join(
            f"{a:.3g} / {b:.3g}" for a, b in zip(meas["rms"], pr["rms"], strict=True)) + " |")
    for name, r in out.items():
        if "per_seed_ms_ratio" in r:
            q = r["per_seed_ms_ratio"]
            md += ["", f"`{name.split(' ')[0]}` changes its poses with the seed. MC / predicted RMS pooled over seeds: "
                   f"{fmt_row(q['rms_ratio_all'], '{:.2f}')} (dx … ψ); without the 5 % of draws with the largest "
                   f"predicted variance: {fmt_row(q['rms_ratio_without_top5pct_predicted'], '{:.2f}')}. Per seed, "
                   f"measured / predicted mean square over the 42 poses: median "
                   f"{fmt_row(q['median'], '{:.2f}')}, max {fmt_row(q['max'], '{:.1f}')} (one noise draw per "
                   "seed: a few ill-conditioned draws dominate the pooled RMS)."]
    verdicts = []
    for m in sizes:
        paper = next(n for n, r in out.items() if r["m"] == m and n.startswith(("paper8", "plan120")))
        for crit in ("O1", "O3"):
            opt = out[f"{crit}-optimal {m}"]
            gain_med = np.asarray(out[paper]["measured"]["max_median"]) / np.asarray(opt["measured"]["max_median"])
            gain_rms = np.asarray(out[paper]["measured"]["rms"]) / np.asarray(opt["measured"]["rms"])
            beats = bool(np.all(gain_med > 1) and np.all(gain_rms > 1))
            verdicts.append({"m": m, "criterion": crit, "paper_plan": paper, "beats_on_every_component": beats,
                             "ratio_max_median_paper_over_optimal": gain_med.tolist(),
                             "ratio_rms_paper_over_optimal": gain_rms.tolist()})
            md += ["", f"m = {m}, {crit}-optimal vs `{paper.split(' ')[0]}`: measured median max error "
                   f"paper/optimal = {fmt_row(gain_med, '{:.2f}')} (dx … ψ), RMS ratio "
                   f"{fmt_row(gain_rms, '{:.2f}')} → the {crit} plan "
                   f"{'beats' if beats else 'does NOT beat'} the paper's plan on every component."]
    md += ["", "### (b) Predicted / Monte Carlo standard deviation of the validation control error", "",
           "Per component, median over the 42 validation poses [min – max] of the predicted std divided by the "
           f"std over {args.seeds} seeds of the LM control error (fixed plans; target 1 ± 0.2).", "",
           "| plan | " + " | ".join(HEADERS) + " | within ±20 % |", "|---|" + "---|" * 7]
    for name, r in out.items():
        if "std_ratio_pred_over_mc" not in r:
            continue
        q = r["std_ratio_pred_over_mc"]
        ok = all(0.8 <= v <= 1.2 for v in q["median"])
        md.append(f"| {name} | " + " | ".join(
            f"{a:.2f} [{b:.2f} – {c:.2f}]" for a, b, c in zip(q["median"], q["min"], q["max"], strict=True))
            + f" | {'yes' if ok else 'no'} |")
    text = "\n".join(md)
    print(text)
    payload = {"seeds": args.seeds, "sizes": sizes, "candidates": args.candidates, "draws": args.draws,
               "seed": args.seed, "sigma_um": sigma_um, "sigma_arcsec": sigma_arcsec, "half_width_mm": 10.0,
               "components": list(COMPONENTS), "units": ["um", "um", "um", "arcsec", "arcsec", "arcsec"],
               "validation_poses": np.asarray(validation).tolist(), "plans": out, "verdicts": verdicts}
    write_results("identifiability_quick" if args.quick else "identifiability", payload, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
