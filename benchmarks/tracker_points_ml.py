"""Tracker-point calibration (``calibrate_points``) against an independent joint least-squares fit.

The reference is written here in NumPy/SciPy, apart from the library: ``scipy.optimize.least_squares``
(MINPACK's Levenberg–Marquardt, forward-difference Jacobian) over every unknown at once — the
parameters of the hexapod (a 6-UPS strut hexapod's 42, the 6-PSS's 36, the 6-RUS's 54, each family's
inverse kinematics written here from its paper), the tracker registration (translation, Euler-angle
correction of the base references' Kabsch fit) and every reached pose — with the residuals

- each platform target point and base reference, whitened by the anisotropic tracker noise
  (along the line of sight ``(u·e)/σ∥``, across it ``(e − (u·e)u)/σ⊥``, σ⊥ ∝ distance);
- the readings against the inverse kinematics (σ = 0.1 µm or 0.1 µrad: the simulated readings are
  exact);
- ``--prior``: the parameters against nominal at the prior scale (1 mm, 1 mrad), the maximum a
  posteriori fit with the library's stated prior;
- ``--isotropic``: the points weighted isotropically at σ∥ (5 µm) instead, a simpler estimator that
  uses less of what is known about the noise (its χ² is still reported under the anisotropic noise);
- ``--determined-std T``: the library holds the directions whose data std exceeds ``T`` prior
  scales (``calibrate_points(determined_std=T)``; default its own, half a prior scale).

The case (Lee & al. style laser-tracker set-up): a hexapod given as a geometry, 60 poses in
its travel, 4 platform targets and 3 base references, the tracker ~3 m away and turned ~34°, σ =
5 µm along the line of sight and 2 µm/m across it, 10 % of target measurements missing, every
parameter of the truth moved by σ = 0.5 mm (0.5 mrad for an angle). Both fits are judged on 40
validation poses: the control error (command with the calibrated model, move the true mechanism),
its worst value and its RMS per component (the RMS ratio pooled over seeds), the χ² of the point
residuals at each optimum, and the coverage of each fit's predicted control-error uncertainty
(share of |error| ≤ 2σ over poses and components; 95.4 % when right).

    python benchmarks/tracker_points_ml.py [--seeds 10] [--prior] [--isotropic] [--determined-std T]
        [--geometry rubin_camera|rubin_m2|nominal|rotary_stewart]
    python benchmarks/tracker_points_ml.py --compare-references A.json B.json
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import jax
import numpy as np
import scipy.optimize

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _common import write_results  # noqa: E402

from stewart_jax.calibration import (  # noqa: E402
    TrackerTargets,
    calibrate_points,
    control_error,
    perturbed,
    random_poses,
    reachable_travel,
    validation_poses,
)
from stewart_jax.calibration._identifiability import predicted_control_error_std  # noqa: E402
from stewart_jax.calibration._points_simulation import default_targets, simulate_points  # noqa: E402
from stewart_jax.mechanism import preset  # noqa: E402

UNITS = np.array([1e3] * 3 + [180 / np.pi * 3600] * 3)  # mm → µm, rad → ″
COMPONENTS = ("dx_um", "dy_um", "dz_um", "phi_arcsec", "theta_arcsec", "psi_arcsec")
PRIOR_MM = 1.0


# ---- the reference, in NumPy ---------------------------------------------------------------------


def rot(a):
    """``Rz(ψ)·Ry(θ)·Rx(φ)`` for ``a = (..., 3) = [φ, θ, ψ]``."""
    f, t, p = a[..., 0], a[..., 1], a[..., 2]
    cf, sf, ct, st, cp, sp = np.cos(f), np.sin(f), np.cos(t), np.sin(t), np.cos(p), np.sin(p)
    return np.stack([np.stack([cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf], -1),
                     np.stack([sp * ct, sp * st * sf + cp * cf, sp * st * cf - cp * sf], -1),
                     np.stack([-st, ct * sf, ct * cf], -1)], -2)


def _legs(poses, joints, v0, base):
    """``(m, 6, 3)``: each platform joint in B minus its base point, ``T(P)·a_i + d + v0 − b_i``."""
    return np.einsum("mij,kj->mki", rot(poses[:, 3:]), joints) + poses[:, None, :3] + v0 - base


def strut_ik(u, poses, v0, _):
    """6-UPS readings ``(m, 6)`` (mm): ``u = [platform (18), base (18), lengths0 (6)]``, ``|l_i| − lengths0_i``."""
    return np.linalg.norm(_legs(poses, u[:18].reshape(6, 3), v0, u[18:36].reshape(6, 3)), axis=-1) - u[36:42]


def slider_ik(u, poses, v0, _):
    """6-PSS readings (mm), Wang et al. (2018) eq. 4: ``u = [Ac (18), Bc (18)]``, sliders along ``e_z``,
    rods ``L_i = |Ac_i + v0 − Bc_i|``: ``q_i = w_z − sqrt(L_i² − |w|² + w_z²)``."""
    upper, lower = u[:18].reshape(6, 3), u[18:36].reshape(6, 3)
    rods2 = np.sum((upper + v0 - lower) ** 2, axis=-1)
    w = _legs(poses, upper, v0, lower)
    return w[..., 2] - np.sqrt(rods2 - np.sum(w**2, axis=-1) + w[..., 2] ** 2)


def crank_ik(u, poses, v0, azimuth):
    """6-RUS readings (rad), Eisele (2019): ``u = [platform (18), base (18), cranks a (6), rods s (6),
    crank zeros (6)]``, ``α = atan2(l_z, e) − atan2(sqrt(e² + l_z² − g²), g)``, ``e = (cos β, sin β, 0)·l``,
    ``g = (|l|² + a² − s²)/(2a)``; the reading ``α − zero``."""
    a, s, zero = u[36:42], u[42:48], u[48:54]
    lv = _legs(poses, u[:18].reshape(6, 3), v0, u[18:36].reshape(6, 3))
    e = np.cos(azimuth) * lv[..., 0] + np.sin(azimuth) * lv[..., 1]
    g = (np.sum(lv**2, axis=-1) + a**2 - s**2) / (2 * a)
    return np.arctan2(lv[..., 2], e) - np.arctan2(np.sqrt(e**2 + lv[..., 2] ** 2 - g**2), g) - zero


IK = {"6-UPS": strut_ik, "6-PSS": slider_ik, "6-RUS": crank_ik}
"""The reference's inverse kinematics per family, written from the papers (the library's parameter order)."""
SIGMA_READING = {"mm": 1e-4, "rad": 1e-7}
"""The readings' σ in the reference (the simulated readings are exact): 0.1 µm, 0.1 µrad."""


def numpy_fk(ik, u, q, v0, extra, iters=30):
    """Newton forward kinematics from the zero pose (central-difference pose Jacobian)."""
    p = np.zeros((len(q), 6))
    for _ in range(iters):
        r = q - ik(u, p, v0, extra)
        jac = np.stack([(ik(u, p + h, v0, extra) - ik(u, p - h, v0, extra)) / 2e-7
                        for h in 1e-7 * np.eye(6)], axis=-1)
        p = p + np.linalg.solve(jac, r[..., None])[..., 0]
        if np.max(np.abs(r)) < 1e-12:
            break
    return p


def whiten(e, measured, range_um, across_um_per_m):
    """``(n, 4)``: the along-sight component over σ∥ and the across-sight vector over σ⊥."""
    dist = np.linalg.norm(measured, axis=1)
    u = measured / dist[:, None]
    along = np.sum(e * u, axis=1)
    across = e - along[:, None] * u
    return np.concatenate([(along / (range_um * 1e-3))[:, None],
                           across / (across_um_per_m * 1e-3 * dist / 1000.0)[:, None]], axis=1)


def kabsch(body, measured):
    cb, cm = body.mean(0), measured.mean(0)
    a, _, bt = np.linalg.svd((body - cb).T @ (measured - cm))
    d = np.sign(np.linalg.det(bt.T @ a.T))
    r = bt.T @ np.diag([1.0, 1.0, d]) @ a.T
    return r, cm - r @ cb


class JointFit:
    """``y = [u (n), registration (6), poses (6m)]`` and the residual of the module docstring."""

    def __init__(self, data, targets, nominal, range_um, across_um_per_m, prior, isotropic=False):
        self.ik = IK[nominal.family]
        self.extra = np.asarray(nominal.azimuth) if nominal.family == "6-RUS" else None
        self.sigma_reading = SIGMA_READING[nominal.reading_unit]
        self.q, self.j = np.asarray(data.readings), np.asarray(data.pose_index)
        self.a = targets.platform[data.target_index]
        self.pts, self.refs = np.asarray(data.points), np.asarray(data.references)
        self.b = targets.base[data.reference_index]
        self.v0, self.u0 = np.asarray(nominal.v0), np.asarray(nominal.params)
        self.n = len(self.u0)
        self.scale = np.asarray(nominal.natural_scales(PRIOR_MM))
        self.sigma = (range_um, across_um_per_m)
        self.prior, self.isotropic = prior, isotropic
        self.rot0, self.t0 = kabsch(self.b, self.refs)
        self.m = len(self.q)

    def split(self, y):
        n = self.n
        return y[:n], y[n:n + 6], y[n + 6:].reshape(self.m, 6)

    def point_residuals(self, y, isotropic=False):
        u, reg, poses = self.split(y)
        r_w, t_w = self.rot0 @ rot(reg[3:]), self.t0 + reg[:3]
        p = poses[self.j]
        in_b = np.einsum("nij,nj->ni", rot(p[:, 3:]), self.a) + p[:, :3] + self.v0
        e_pts = self.pts - (in_b @ r_w.T + t_w)
        e_refs = self.refs - (self.b @ r_w.T + t_w)
        if isotropic:
            return np.concatenate([e_pts.ravel(), e_refs.ravel()]) / (self.sigma[0] * 1e-3)
        return np.concatenate([whiten(e_pts, self.pts, *self.sigma).ravel(),
                               whiten(e_refs, self.refs, *self.sigma).ravel()])

    def residuals(self, y):
        u, _, poses = self.split(y)
        out = [self.point_residuals(y, self.isotropic),
               ((self.q - self.ik(u, poses, self.v0, self.extra)) / self.sigma_reading).ravel()]
        if self.prior:
            out.append((u - self.u0) / self.scale)
        return np.concatenate(out)

    def solve(self):
        """MINPACK's Levenberg–Marquardt (dense forward-difference Jacobian) to its tolerances.

        NOTE: SciPy's trf with a sparse Jacobian (lsmr inner solves) stopped at its 200 evaluations
        short of the optimum (rubin_m2, seed 1: χ² 638.9, against 625.6 here in 34 evaluations)."""
        y0 = np.concatenate([self.u0, np.zeros(6), numpy_fk(self.ik, self.u0, self.q, self.v0, self.extra).ravel()])
        res = scipy.optimize.least_squares(self.residuals, y0, method="lm", x_scale="jac", xtol=1e-15, ftol=1e-15,
                                           gtol=1e-15, max_nfev=20000)
        jac = res.jac
        cov = np.linalg.pinv(jac.T @ jac, hermitian=True)
        chi2 = float(np.sum(self.point_residuals(res.x) ** 2))
        return res, cov[:self.n, :self.n], chi2


# ---- the case ------------------------------------------------------------------------------------


def case(geometry, seed):
    nominal = preset(geometry)
    key = jax.random.key(seed)
    true = perturbed(nominal, jax.random.fold_in(key, 1), 0.5)
    half = reachable_travel(nominal)
    poses = random_poses(jax.random.fold_in(key, 2), 60, half=half)
    full = default_targets(nominal)
    targets = TrackerTargets(full.platform_names[:4], full.platform[:4], full.base_names[:3], full.base[:3])
    axis = np.array(jax.random.normal(jax.random.fold_in(key, 4), (3,)))
    axis /= np.linalg.norm(axis)
    angle = np.radians(34.0)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    r_reg = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k
    centre = 3000.0 * np.array([0.8, 0.45, -0.4]) / np.linalg.norm([0.8, 0.45, -0.4])
    t_reg = centre - r_reg @ np.asarray(nominal.v0)
    sim = simulate_points(jax.random.fold_in(key, 5), nominal, true, targets, poses, range_um=5.0,
                          across_um_per_m=2.0, registration=(r_reg, t_reg), visible=0.9)
    val = validation_poses(jax.random.fold_in(key, 6), 40, poses, half=half)
    return nominal, true, targets, sim.data, val


def one(geometry, seed, prior, isotropic=False, determined_std=None):
    nominal, true, targets, data, val = case(geometry, seed)
    t0 = time.perf_counter()
    held = {} if determined_std is None else {"determined_std": determined_std}
    cal = calibrate_points(data, targets, nominal, range_um=5.0, across_um_per_m=2.0, **held)
    t_lib = time.perf_counter() - t0
    t0 = time.perf_counter()
    ref, cov_ref, chi2_ref = JointFit(data, targets, nominal, 5.0, 2.0, prior, isotropic).solve()
    t_ref = time.perf_counter() - t0
    n = nominal.n_params
    ref_mech = nominal.with_params(ref.x[:n])
    out = {"seed": seed, "seconds_library": t_lib, "seconds_reference": t_ref,
           "chi2_library": cal.chi2, "chi2_reference": chi2_ref, "status_library": cal.status,
           "data_status_library": cal.assessment.status, "determined_directions": cal.assessment.n_determined,
           "reference_nfev": int(ref.nfev), "reference_status": int(ref.status), "unknowns": nominal.n_params + 6}
    for label, mech, cov in (("library", cal.mechanism, cal.assessment.param_cov[:n, :n]),
                             ("reference", ref_mech, cov_ref)):
        err = np.asarray(control_error(mech, true, val).errors) * UNITS
        std = np.asarray(predicted_control_error_std(mech, val, cov))
        out[f"worst_{label}"] = dict(zip(COMPONENTS, np.max(np.abs(err), axis=0).tolist(), strict=True))
        out[f"mean_square_{label}"] = dict(zip(COMPONENTS, np.mean(err**2, axis=0).tolist(), strict=True))
        out[f"z_{label}"] = (err / std).tolist()
        out[f"param_error_max_mm_{label}"] = float(np.max(np.abs(np.asarray(mech.params) - np.asarray(true.params))))
    ratio = [out["worst_library"][c] / out["worst_reference"][c] for c in COMPONENTS]
    out["ratio"] = dict(zip(COMPONENTS, ratio, strict=True))
    out["ratio_worst_component"] = float(max(ratio))
    return out


def compare_references(first: str, second: str) -> None:
    """The statistics of this benchmark between the references of two of its result files (the same
    geometry and seeds): how far two estimators of the same points differ on them."""
    import json

    runs = [json.load(open(f))["runs"] for f in (first, second)]
    worst = [max(a["worst_reference"][c] / b["worst_reference"][c] for c in COMPONENTS)
             for a, b in zip(*runs, strict=True)]
    rms = {c: float(np.sqrt(sum(a["mean_square_reference"][c] for a in runs[0])
                            / sum(b["mean_square_reference"][c] for b in runs[1]))) for c in COMPONENTS}
    print(f"{first} against {second}, {len(worst)} seeds: worst component ratio median {np.median(worst):.2f}, "
          f"max {np.max(worst):.2f}, above 1.2 on {int(np.sum(np.array(worst) > 1.2))}; RMS ratio pooled over "
          "seeds " + ", ".join(f"{c} {v:.2f}" for c, v in rms.items()))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--geometry", default="rubin_camera")
    ap.add_argument("--prior", action="store_true", help="the reference with the library's prior (MAP)")
    ap.add_argument("--isotropic", action="store_true", help="the reference's points weighted isotropically at 5 µm")
    ap.add_argument("--determined-std", type=float, default=None,
                    help="the library's threshold, prior scales (default calibrate_points's own)")
    ap.add_argument("--compare-references", nargs=2, metavar="RESULT_JSON",
                    help="compare the references of two result files (nothing is fitted)")
    args = ap.parse_args()
    if args.compare_references:
        return compare_references(*args.compare_references)
    rows = []
    for seed in range(args.seeds):
        r = one(args.geometry, seed, args.prior, args.isotropic, args.determined_std)
        rows.append(r)
        print(f"seed {seed}: ratio worst component {r['ratio_worst_component']:.2f}, χ² lib {r['chi2_library']:.1f} "
              f"ref {r['chi2_reference']:.1f}, param error max lib {r['param_error_max_mm_library']:.2f} mm "
              f"ref {r['param_error_max_mm_reference']:.2f} mm", flush=True)
    summary = {}
    for label in ("library", "reference"):
        z = np.concatenate([np.ravel(r[f"z_{label}"]) for r in rows])
        summary[f"coverage_2sigma_{label}"] = float(np.mean(np.abs(z) <= 2))
        summary[f"rms_z_{label}"] = float(np.sqrt(np.mean(z**2)))
    worst = [r["ratio_worst_component"] for r in rows]
    summary["median_ratio_per_component"] = {c: float(np.median([r["ratio"][c] for r in rows])) for c in COMPONENTS}
    summary["median_ratio_worst_component"] = float(np.median(worst))
    summary["max_ratio_worst_component"] = float(np.max(worst))
    summary["seeds_above_1_2"] = int(np.sum(np.array(worst) > 1.2))
    # NOTE: fitting k more directions to noise alone lowers χ² by k on average (χ²_k): a reference
    # that fits the held directions should end that much lower, no more.
    summary["mean_chi2_library_minus_reference"] = float(np.mean([r["chi2_library"] - r["chi2_reference"]
                                                                  for r in rows]))
    summary["mean_held_directions"] = float(np.mean([r["unknowns"] - (r["determined_directions"] or r["unknowns"])
                                                     for r in rows]))
    summary["rms_ratio_over_seeds_per_component"] = {
        c: float(np.sqrt(sum(r["mean_square_library"][c] for r in rows)
                         / sum(r["mean_square_reference"][c] for r in rows))) for c in COMPONENTS}
    for r in rows:
        r.pop("z_library"), r.pop("z_reference")
    name = (f"tracker_points_ml_{args.geometry}" + ("_prior" if args.prior else "")
            + ("_isotropic" if args.isotropic else "")
            + ("" if args.determined_std is None else f"_held{args.determined_std:g}"))
    lines = [f"# Tracker points: library vs independent joint fit ({args.geometry}"
             + (", reference with the prior" if args.prior else "")
             + (", reference weighted isotropically" if args.isotropic else "")
             + ("" if args.determined_std is None else f", library holding above {args.determined_std:g} prior scales")
             + ")", "",
             f"{args.seeds} seeds; worst validation control error per component over 40 poses.", "",
             "| seed | library (µm×3, ″×3) | reference | worst ratio | χ² lib / ref | held directions |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['seed']} | " + ", ".join(f"{v:.3g}" for v in r["worst_library"].values()) + " | "
                     + ", ".join(f"{v:.3g}" for v in r["worst_reference"].values())
                     + f" | {r['ratio_worst_component']:.2f} | {r['chi2_library']:.1f} / {r['chi2_reference']:.1f} | "
                     f"{r['unknowns'] - (r['determined_directions'] or r['unknowns'])} |")
    lines += ["", "| summary | value |", "|---|---|"] + [f"| {k} | {v} |" for k, v in summary.items()]
    write_results(name, {"geometry": args.geometry, "prior": args.prior, "isotropic": args.isotropic,
                         "determined_std": args.determined_std,
                         "summary": summary, "runs": rows},
                  "\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
