"""Point-based calibration from laser-tracker points against the two-step path (rigid pose fit, then
the pose-based calibration), on simulated tracker data with anisotropic noise.

Per trial: a true mechanism (every parameter of the nominal moved by σ = 0.5 mm), the 120-pose plan,
each platform target seen with probability 0.6 (poses with one or two targets occur), the tracker
2.9 m away with σ = 5 µm along the line of sight and 2.5 µm/m across it. Both paths are judged on
42 validation poses off the plan (Wang et al. 2018, §3–4): the control error (command with the
calibrated model, move the true mechanism) and the coverage of the predicted control-error
uncertainty: over every trial, validation pose and component, the share of errors within 2σ of
the prediction (95.4 % when the prediction is right) and the RMS of error/σ (1 when right). Within
one trial the 252 components share one parameter error, so only the pooled figures mean anything.

The two-step path is what a user of the pose CSV does: register the tracker by the base
references' rigid fit, fit a rigid pose to every pose with ≥ 3 targets (the others are dropped),
calibrate the poses with ``lm-batched``, and take the pose noise for the uncertainty from 200
repeated rigid fits at the zero pose (generous: a user measures ten).

    python benchmarks/tracker_points.py [--trials 20] [--geometry rubin_m2] [--quick]
    python benchmarks/tracker_points.py --timing   # seconds against 120, 300 and 600 poses, beside SciPy
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _common import write_results  # noqa: E402

import stewart_jax  # noqa: E402,F401
from stewart_jax.calibration import (  # noqa: E402
    assess_calibration,
    calibrate,
    calibrate_points,
    calibration_problem,
    control_error,
    make_calibration_data,
    perturbed,
    plan_poses,
    reachable_travel,
)
from stewart_jax.calibration._identifiability import predicted_control_error_std  # noqa: E402
from stewart_jax.calibration._points import DEFAULT_TRACKER_SIGMA, rigid_poses, start_values  # noqa: E402
from stewart_jax.calibration._points_simulation import (  # noqa: E402
    _tracker_noise,
    default_registration,
    default_targets,
    simulate_points,
)
from stewart_jax.mechanism import preset  # noqa: E402

UNITS = np.array([1e3] * 3 + [180 / np.pi * 3600] * 3)  # mm → µm, rad → ″


def pose_noise(nominal, targets, n=200, seed=0):
    """σ (µm, ″) of the rigid-fit pose at the zero pose, all targets seen, from ``n`` repeats."""
    rot, t = default_registration(nominal)
    in_b = targets.platform + np.asarray(nominal.v0)
    exact = in_b @ rot.T + t
    refs = targets.base @ rot.T + t
    poses = []
    for k in range(n):
        key = jax.random.fold_in(jax.random.key(seed), k)
        k1, k2 = jax.random.split(key)
        pts = exact + _tracker_noise(k1, exact, *DEFAULT_TRACKER_SIGMA)
        r = refs + _tracker_noise(k2, refs, *DEFAULT_TRACKER_SIGMA)
        data = _point_data(pts, r, targets)
        rot0, t0, _, _ = start_values(data, targets, nominal)
        p, _ = rigid_poses(data, targets, rot0, t0, np.asarray(nominal.v0))
        poses.append(p[0])
    std = np.std(np.array(poses), axis=0) * UNITS
    return float(np.mean(std[:3])), float(np.mean(std[3:]))


def _point_data(points, refs, targets):
    from stewart_jax.calibration import PointData

    k = len(targets.platform)
    return PointData(("0",), np.zeros((1, 6)), np.zeros(k, int), np.arange(k), points,
                     np.arange(len(targets.base)), refs)


def coverage(errors, std):
    return float(np.mean(np.abs(errors) <= 2 * std))


def pooled(rows, key):
    """Over every trial, validation pose and component: the share of |error| ≤ 2σ_pred and RMS of error/σ_pred."""
    z = np.concatenate([np.ravel(r[key]) for r in rows])
    return float(np.mean(np.abs(z) <= 2)), float(np.sqrt(np.mean(z**2)))


# ---- the peer: SciPy's least_squares on the same model, written as a user would ------------------


def _rotation_and_derivatives(a):
    """``R = Rz(ψ)·Ry(θ)·Rx(φ)`` for ``a = (..., 3)`` and its derivatives in φ, θ, ψ: ``(4, ..., 3, 3)``."""
    f, t, p = a[..., 0], a[..., 1], a[..., 2]
    z, o = np.zeros_like(f), np.ones_like(f)

    def m(*rows):
        return np.stack([np.stack(r, -1) for r in rows], -2)

    cf, sf, ct, st, cp, sp = np.cos(f), np.sin(f), np.cos(t), np.sin(t), np.cos(p), np.sin(p)
    rx, ry, rz = m((o, z, z), (z, cf, -sf), (z, sf, cf)), m((ct, z, st), (z, o, z), (-st, z, ct)), \
        m((cp, -sp, z), (sp, cp, z), (z, z, o))
    drx, dry, drz = m((z, z, z), (z, -sf, -cf), (z, cf, -sf)), m((-st, z, ct), (z, z, z), (-ct, z, -st)), \
        m((-sp, -cp, z), (cp, -sp, z), (z, z, z))
    return np.stack([rz @ ry @ rx, rz @ ry @ drx, rz @ dry @ rx, drz @ ry @ rx])


class ScipyPointModel:
    """The point model of a 6-UPS in NumPy for ``scipy.optimize.least_squares``: unknowns
    ``y = [platform (18), base (18), lengths0 (6), registration correction (6)]``, each pose
    eliminated by a vectorised Newton forward kinematics, the analytic Jacobian by the implicit
    function theorem (``∂P/∂u = −(∂q/∂P)⁻¹·∂q/∂u``), whitened by the tracker noise. Residual and
    Jacobian share one evaluation (cached by ``y``)."""

    def __init__(self, data, targets, nominal, range_um, across_um_per_m):
        from stewart_jax.calibration._points import tracker_whitening

        self.q = np.asarray(data.readings)
        self.j = np.asarray(data.pose_index)
        self.a = targets.platform[data.target_index]
        self.pts = np.asarray(data.points)
        self.b = targets.base[data.reference_index]
        self.refs = np.asarray(data.references)
        self.w = tracker_whitening(self.pts, range_um, across_um_per_m)
        self.w_refs = tracker_whitening(self.refs, range_um, across_um_per_m)
        self.v0 = np.asarray(nominal.v0)
        rot0, t0, poses, _ = start_values(data, targets, nominal)
        self.rot0, self.t0, self.poses = rot0, t0, np.asarray(poses)
        self.y0 = np.concatenate([np.asarray(nominal.params), np.zeros(6)])
        self._key, self._value = None, None

    def _forward(self, platform, base, lengths0):
        poses = self.poses.copy()
        for _ in range(30):
            r = _rotation_and_derivatives(poses[:, 3:])  # (4, m, 3, 3)
            ra = np.einsum("kmij,lj->kmli", r, platform)  # (4, m, 6, 3)
            s = ra[0] + poses[:, None, :3] + self.v0 - base
            length = np.linalg.norm(s, axis=-1)
            n = s / length[..., None]
            jac = np.concatenate([n, np.einsum("mli,kmli->mlk", n, ra[1:])], axis=-1)  # (m, 6, 6) ∂q/∂P
            res = length - lengths0 - self.q
            if np.max(np.abs(res)) < 1e-11:
                break
            poses = poses - np.linalg.solve(jac, res[..., None])[..., 0]
        self.poses = poses  # the next evaluation starts here
        return poses, r[0], n, jac

    def _evaluate(self, y):
        if self._key is not None and np.array_equal(y, self._key):
            return self._value
        platform, base, lengths0 = y[:18].reshape(6, 3), y[18:36].reshape(6, 3), y[36:42]
        poses, rot, n, jp = self._forward(platform, base, lengths0)
        m = len(poses)
        dq_du = np.zeros((m, 6, 42))  # ∂q/∂u at fixed pose
        for i in range(6):
            dq_du[:, i, 3 * i:3 * i + 3] = np.einsum("mk,mkj->mj", n[:, i], rot)
            dq_du[:, i, 18 + 3 * i:21 + 3 * i] = -n[:, i]
            dq_du[:, i, 36 + i] = -1.0
        dp_du = -np.linalg.solve(jp, dq_du)  # (m, 6, 42)
        rg = _rotation_and_derivatives(y[45:48])
        rot_reg, t_reg = self.rot0 @ rg[0], self.t0 + y[42:45]
        r = _rotation_and_derivatives(poses[self.j, 3:])  # (4, n, 3, 3)
        x_b = np.einsum("nij,nj->ni", r[0], self.a) + poses[self.j, :3] + self.v0
        pred = x_b @ rot_reg.T + t_reg
        d_pose = np.concatenate([np.broadcast_to(rot_reg, (len(x_b), 3, 3)),
                                 np.einsum("ij,knjl,nl->nik", rot_reg, r[1:], self.a)], axis=-1)  # (n, 3, 6)
        d_u = np.einsum("nik,nkp->nip", d_pose, dp_du[self.j])
        d_reg = np.concatenate([np.broadcast_to(np.eye(3), (len(x_b), 3, 3)),
                                np.einsum("ij,kjl,nl->nik", self.rot0, rg[1:], x_b)], axis=-1)
        pred_refs = self.b @ rot_reg.T + t_reg
        d_refs = np.concatenate([np.broadcast_to(np.eye(3), (len(self.b), 3, 3)),
                                 np.einsum("ij,kjl,nl->nik", self.rot0, rg[1:], self.b)], axis=-1)
        res = np.concatenate([np.einsum("nij,nj->ni", self.w, self.pts - pred).ravel(),
                              np.einsum("nij,nj->ni", self.w_refs, self.refs - pred_refs).ravel()])
        jac_pts = -np.einsum("nij,njk->nik", self.w, np.concatenate([d_u, d_reg], axis=-1)).reshape(-1, 48)
        jac_refs = -np.einsum("nij,njk->nik", self.w_refs,
                              np.concatenate([np.zeros((len(self.b), 3, 42)), d_refs], axis=-1)).reshape(-1, 48)
        self._key, self._value = y.copy(), (res, np.concatenate([jac_pts, jac_refs]))
        return self._value

    def residuals(self, y):
        return self._evaluate(y)[0]

    def jacobian(self, y):
        return self._evaluate(y)[1]


def scipy_calibrate_points(data, targets, nominal, method: str = "lm"):
    """SciPy's ``least_squares`` on :class:`ScipyPointModel`; returns (parameters, χ², evaluations)."""
    from scipy.optimize import least_squares

    model = ScipyPointModel(data, targets, nominal, *DEFAULT_TRACKER_SIGMA)
    res = least_squares(model.residuals, model.y0, jac=model.jacobian, method=method, x_scale="jac",
                        xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=200)
    return res.x[:42], float(2 * res.cost), int(res.nfev), int(res.njev or 0)


def timing(geometry: str, sizes=(120, 300, 600), repeats: int = 3) -> None:
    """Seconds per point-based calibration against the number of poses (compilation apart), beside
    SciPy's ``least_squares`` on the same model (:class:`ScipyPointModel`: ``trf`` and MINPACK's
    ``lm``), on the same data (every target seen); each timed from the files' arrays to the
    calibrated parameters (start values included)."""
    from stewart_jax.calibration import random_poses

    nominal = preset(geometry)
    targets = default_targets(nominal)
    half = reachable_travel(nominal)
    true = perturbed(nominal, jax.random.key(1), 0.5)
    rows = []
    for m in sizes:
        sim = simulate_points(jax.random.key(m), nominal, true, targets, random_poses(jax.random.key(2), m, half=half),
                              visible=1.0)
        t0 = time.perf_counter()
        cal = calibrate_points(sim.data, targets, nominal)
        first = time.perf_counter() - t0
        row = {"poses": m, "points": int(len(sim.data.points)), "first_call_seconds": first}
        times = {"ours": [], "scipy_trf": [], "scipy_lm": []}
        out = {}
        for _ in range(repeats):  # interleaved, so that the machine's load falls on all alike
            t0 = time.perf_counter()
            cal = calibrate_points(sim.data, targets, nominal)
            times["ours"].append(time.perf_counter() - t0)
            for method in ("trf", "lm"):
                t0 = time.perf_counter()
                out[method] = scipy_calibrate_points(sim.data, targets, nominal, method)
                times[f"scipy_{method}"].append(time.perf_counter() - t0)
        row.update({f"{k}_median_seconds": float(np.median(v)) for k, v in times.items()})
        row.update(ours_evaluations=cal.n_steps, ours_status=cal.status, ours_chi2=cal.chi2,
                   scipy_trf_evaluations=out["trf"][2], scipy_trf_chi2=out["trf"][1],
                   scipy_lm_evaluations=out["lm"][2], scipy_lm_chi2=out["lm"][1])
        rows.append(row)
        print(rows[-1], flush=True)
    md = [f"# Tracker points: seconds per point-based calibration ({geometry}, every target seen)", "",
          "Medians of 3 interleaved runs after compilation, from the arrays to the calibrated parameters (start "
          "values included); SciPy's `least_squares` on the same model in NumPy (poses eliminated by a "
          "vectorised Newton forward kinematics, analytic Jacobian by the implicit function theorem), "
          "`x_scale='jac'`, tolerances 1e-12.", "",
          "| poses | points | ours s (evaluations) | SciPy trf s (evaluations) | SciPy lm s (evaluations) "
          "| χ²: ours − trf | first call, ours (compiling) |",
          "|---|---|---|---|---|---|---|"]
    md += [f"| {r['poses']} | {r['points']} | {r['ours_median_seconds']:.2f} ({r['ours_evaluations']}) | "
           f"{r['scipy_trf_median_seconds']:.2f} ({r['scipy_trf_evaluations']}) | "
           f"{r['scipy_lm_median_seconds']:.2f} ({r['scipy_lm_evaluations']}) | "
           f"{r['ours_chi2'] - r['scipy_trf_chi2']:.2g} | {r['first_call_seconds']:.1f} |" for r in rows]
    write_results("tracker_points_timing", {"rows": rows}, "\n".join(md))
    print("\n".join(md))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--geometry", default="rubin_m2")
    ap.add_argument("--visible", type=float, default=0.6)
    ap.add_argument("--quick", action="store_true", help="3 trials, results named *_quick")
    ap.add_argument("--timing", action="store_true", help="only the seconds against 120, 300 and 600 poses")
    args = ap.parse_args()
    if args.timing:
        timing(args.geometry)
        return
    trials = 3 if args.quick else args.trials
    nominal = preset(args.geometry)
    n = nominal.n_params
    targets = default_targets(nominal)
    half = reachable_travel(nominal)
    commanded = plan_poses("plan120", jax.random.key(0), half)
    sigma_um, sigma_arcsec = pose_noise(nominal, targets)
    rows = []
    for trial in range(trials):
        key = jax.random.fold_in(jax.random.key(2026), trial)
        k_true, k_sim, k_val = jax.random.split(key, 3)
        true = perturbed(nominal, k_true, 0.5)
        sim = simulate_points(k_sim, nominal, true, targets, commanded, visible=args.visible)
        val = plan_poses("validation42", k_val, half)
        row = {"trial": trial, "poses_with_1_or_2_targets": int(np.sum(sim.data.targets_per_pose() < 3))}
        # point-based
        t0 = time.perf_counter()
        cal = calibrate_points(sim.data, targets, nominal)
        row["points_seconds"] = time.perf_counter() - t0
        err = np.asarray(control_error(cal.mechanism, true, val).errors) * UNITS
        std = predicted_control_error_std(cal.mechanism, jnp.asarray(val), cal.assessment.param_cov[:n, :n])
        row.update(points_rms=np.sqrt(np.mean(err**2, axis=0)).tolist(), points_coverage=coverage(err, std),
                   points_z=(err / std).tolist(),
                   points_status=cal.assessment.status, points_p_value=cal.assessment.p_value)
        # two-step: registration and rigid poses, then the pose-based calibration
        t0 = time.perf_counter()
        rot0, tr0, _, _ = start_values(sim.data, targets, nominal)
        poses, fitted = rigid_poses(sim.data, targets, rot0, tr0, np.asarray(nominal.v0))
        data = make_calibration_data(sim.data.readings[fitted], poses[fitted])
        res = calibrate(calibration_problem(data, nominal), "lm-batched", jax.random.key(trial))
        params = jax.block_until_ready(res.params)
        row["two_step_seconds"] = time.perf_counter() - t0
        two = nominal.with_params(params)
        a = assess_calibration(two, data, sigma_um, sigma_arcsec)
        err2 = np.asarray(control_error(two, true, val).errors) * UNITS
        std2 = predicted_control_error_std(two, jnp.asarray(val), a.param_cov)
        row.update(two_step_rms=np.sqrt(np.mean(err2**2, axis=0)).tolist(), two_step_coverage=coverage(err2, std2),
                   two_step_z=(err2 / std2).tolist(),
                   two_step_status=a.status, two_step_p_value=a.p_value, two_step_poses_used=int(np.sum(fitted)))
        rows.append(row)
        print(f"trial {trial}: points rms {np.round(row['points_rms'], 2)} cov {row['points_coverage']:.3f}; "
              f"two-step rms {np.round(row['two_step_rms'], 2)} cov {row['two_step_coverage']:.3f}", flush=True)

    def med(key):
        return np.median(np.array([r[key] for r in rows]), axis=0)

    later = rows[1:] if len(rows) > 1 else rows  # the first trial includes compilation
    summary = {
        "geometry": args.geometry, "trials": trials, "visible": args.visible,
        "tracker_sigma_range_um": DEFAULT_TRACKER_SIGMA[0], "tracker_sigma_across_um_per_m": DEFAULT_TRACKER_SIGMA[1],
        "two_step_pose_sigma_um": sigma_um, "two_step_pose_sigma_arcsec": sigma_arcsec,
        "points_median_rms": med("points_rms").tolist(), "two_step_median_rms": med("two_step_rms").tolist(),
        "points_coverage_2sigma_pooled": pooled(rows, "points_z")[0],
        "points_z_rms_pooled": pooled(rows, "points_z")[1],
        "two_step_coverage_2sigma_pooled": pooled(rows, "two_step_z")[0],
        "two_step_z_rms_pooled": pooled(rows, "two_step_z")[1],
        "points_ok_fits": sum(r["points_status"] == "ok" for r in rows),
        "two_step_ok_fits": sum(r["two_step_status"] == "ok" for r in rows),
        "points_median_seconds_after_compile": float(np.median([r["points_seconds"] for r in later])),
        "two_step_median_seconds_after_compile": float(np.median([r["two_step_seconds"] for r in later])),
        "first_trial_seconds_with_compile": {"points": rows[0]["points_seconds"],
                                             "two_step": rows[0]["two_step_seconds"]},
    }
    comp = ("dx µm", "dy µm", "dz µm", "φ ″", "θ ″", "ψ ″")
    md = [f"# Tracker points: point-based calibration vs the two-step path ({args.geometry}, {trials} trials)", "",
          __doc__.split("\n\n")[1].replace("\n", " "), "",
          "Validation control error, median over trials of the per-trial RMS:", "",
          "| path | " + " | ".join(comp) + " | within 2σ_pred (pooled) | RMS error/σ_pred | fits passing χ² "
          "| s per calibration |",
          "|---" * 11 + "|"]
    for label, key in (("point-based", "points"), ("two-step (rigid fit + lm-batched)", "two_step")):
        md.append(f"| {label} | " + " | ".join(f"{x:.3g}" for x in summary[f"{key}_median_rms"])
                  + f" | {summary[f'{key}_coverage_2sigma_pooled']:.3f} | {summary[f'{key}_z_rms_pooled']:.3g} "
                  f"| {summary[f'{key}_ok_fits']}/{trials} | "
                  f"{summary[f'{key}_median_seconds_after_compile']:.2f} |")
    md += ["", f"Two-step pose noise used for its uncertainty: {sigma_um:.3g} µm, {sigma_arcsec:.3g}″ (200 repeated "
           "rigid fits at the zero pose). Seconds exclude the first trial (compilation: "
           f"{rows[0]['points_seconds']:.1f} s point-based, {rows[0]['two_step_seconds']:.1f} s two-step)."]
    write_results("tracker_points_quick" if args.quick else "tracker_points", {"summary": summary, "trials": rows},
                  "\n".join(md))
    print("\n".join(md))


if __name__ == "__main__":
    main()
