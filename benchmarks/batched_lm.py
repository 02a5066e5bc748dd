"""Batched Levenberg–Marquardt against every LM the project has and the strongest SciPy peer.

    python benchmarks/batched_lm.py            # batches of 1, 100, 1000
    python benchmarks/batched_lm.py --quick    # batches of 1, 10, 50: a seconds-long smoke run

The calibration of Wang et al. (2018), "Improved cuckoo calibration method of space telescope
secondary mirror adjusting mechanism" (residual eq. 8, from the nominal parameters), on the
seed-0 Monte Carlo problems of ``stewart_jax.study.simulate_trials`` (σ = 0.1 µm, 0.1″):

- 6-PSS, 36 parameters, the 8-pose plan (48 residuals) and the 120-pose plan (720 residuals);
- one strut preset (6-UPS ``rubin_camera``, 42 parameters), 120-pose plan, laser tracker σ = 3 µm,
  true mechanism perturbed by N(0, 0.5 mm).

Rows, per problem set and batch size (time per calibration, compilation timed apart):

- ``lm-batched``: :func:`stewart_jax.calibration.calibrate_batch` with the batched LM (one
  least-squares block per leg, a refilled working set);
- ``lm (optimistix), vmapped``: ``calibrate_batch(..., "lm")``;
- ``lm (optimistix), one at a time``: the same solver jitted for one problem, a Python loop;
- ``lm-jaxopt, vmapped``: ``calibrate_batch(..., "lm-jaxopt")``;
- ``SciPy lm, NumPy residual + analytic Jacobian``: the strong peer — the 6-PSS inverse
  kinematics (eq. 4) and its 48 × 36 (or 720 × 36) Jacobian written here in vectorised NumPy,
  independent of the library, ``scipy.optimize.least_squares(method="lm")`` per problem (MINPACK
  ``lmder``). 6-PSS only.

A slow row is run on fewer problems than the batch (its time per calibration does not depend on
the batch: one at a time; optimistix one at a time is run at the smallest and largest batch only)
or skipped where it would take longer than ``--row-budget`` seconds (estimated from the smaller
batch); the table says which. ``--quick`` runs the vmapped baselines at batch 1 only. Every JAX
timing blocks on the result.

``--conditioning``: the NOTE of ``stewart_jax/optimise/_batched_lm.py`` — on one 8-pose problem,
the rank of J, and for the damping values the solver visits the condition number of
``JᵀJ + μD`` and the difference between the Cholesky step and the QR solution of the augmented
least-squares system.

Results: ``benchmarks/results/batched_lm{,_quick}.{json,md}``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import jax  # noqa: E402
import numpy as np  # noqa: E402
from _common import write_results  # noqa: E402
from scipy.optimize import least_squares as scipy_least_squares  # noqa: E402

import stewart_jax as sj  # noqa: E402
from stewart_jax.calibration import calibrate_batch, perturbed  # noqa: E402
from stewart_jax.mechanism import preset  # noqa: E402
from stewart_jax.optimise import LevenbergMarquardt, status_name  # noqa: E402
from stewart_jax.study import run_study, simulate_trials, trial_keys  # noqa: E402

# ---- the strong SciPy peer: 6-PSS residual and Jacobian in plain NumPy ---------------------


def _rotation(poses):
    """``T = Rz(ψ)·Ry(θ)·Rx(φ)`` for poses (m, 6) → (m, 3, 3)."""
    phi, th, ps = poses[:, 3], poses[:, 4], poses[:, 5]
    cf, sf, ct, st, cp, sp = np.cos(phi), np.sin(phi), np.cos(th), np.sin(th), np.cos(ps), np.sin(ps)
    return np.stack([
        np.stack([cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf], -1),
        np.stack([sp * ct, sp * st * sf + cp * cf, sp * st * cf - cp * sf], -1),
        np.stack([-st, ct * sf, ct * cf], -1),
    ], -2)


class NumpyPSS:
    """``r(u) = q' − IK(P', u)`` (Wang et al. 2018, eqs. 4, 7, 8) and its Jacobian for one problem.

    With ``e = Ac + v0 − Bc`` (zero-pose rod, ``L² = |e|²``), ``a = T·Ac + d + v0`` and
    ``Δx = Bc_x − a_x``, ``Δy = Bc_y − a_y``, ``h = sqrt(L² − Δx² − Δy²)``, the stroke is
    ``q = a_z − Bc_z − h``; so ``∂q/∂Ac = T[2] − (e + Δx·T[0] + Δy·T[1])/h`` and
    ``∂q/∂Bc = ((e_x + Δx)/h, (e_y + Δy)/h, e_z/h − 1)``; the residual's Jacobian is minus that.
    """

    def __init__(self, readings, poses, v0):
        self.q = np.asarray(readings)
        self.poses = np.asarray(poses)
        self.v0 = np.asarray(v0)
        self.rot = _rotation(self.poses)  # (m, 3, 3)
        self.m = self.q.shape[0]

    def _parts(self, u):
        ac, bc = u[:18].reshape(6, 3), u[18:].reshape(6, 3)
        a = np.einsum("mjk,ik->mij", self.rot, ac) + self.poses[:, None, :3] + self.v0  # (m, 6, 3)
        e = ac + self.v0 - bc  # (6, 3)
        dx, dy = bc[:, 0] - a[..., 0], bc[:, 1] - a[..., 1]
        h = np.sqrt(np.maximum(np.sum(e**2, -1) - dx**2 - dy**2, 0.0))
        return a, bc, e, dx, dy, h

    def residual(self, u):
        a, bc, _, _, _, h = self._parts(u)
        return (self.q - (a[..., 2] - bc[:, 2] - h)).reshape(-1)

    def jacobian(self, u):
        _, _, e, dx, dy, h = self._parts(u)
        rot = self.rot[:, None]  # (m, 1, 3, 3)
        d_ac = rot[..., 2, :] - (e + dx[..., None] * rot[..., 0, :] + dy[..., None] * rot[..., 1, :]) / h[..., None]
        d_bc = np.stack([(e[:, 0] + dx) / h, (e[:, 1] + dy) / h, e[:, 2] / h - 1.0], -1)  # (m, 6, 3)
        jac = np.zeros((self.m, 6, 36))
        legs = np.arange(6)
        for k in range(3):
            jac[:, legs, 3 * legs + k] = -d_ac[..., k]
            jac[:, legs, 18 + 3 * legs + k] = -d_bc[..., k]
        return jac.reshape(6 * self.m, 36)


def scipy_peer(problem):
    """One calibration by MINPACK's LM on the NumPy residual and Jacobian → (u, S, evaluations)."""
    p = NumpyPSS(problem.data.readings, problem.data.poses, problem.mechanism.v0)
    r = scipy_least_squares(p.residual, np.asarray(problem.initial), jac=p.jacobian, method="lm",
                            xtol=1e-15, ftol=1e-15, gtol=1e-15)
    return r.x, 2.0 * r.cost, r.nfev


# ---- timing helpers ------------------------------------------------------------------------


def take(tree, n):
    return jax.tree.map(lambda x: x[:n], tree)


def timed(fn, repeats):
    """Best of ``repeats`` wall times (s) and the last output; the machine is shared, so the
    best run is the one least disturbed."""
    best, out = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = jax.block_until_ready(fn())
        best = min(best, time.perf_counter() - t0)
    return best, out


def batch_row(method, problems, n, repeats):
    keys = jax.random.split(jax.random.key(0), n)
    batch = take(problems, n)
    t0 = time.perf_counter()
    jax.block_until_ready(calibrate_batch(batch, method, keys))  # compilation (and one run)
    first = time.perf_counter() - t0
    sec, res = timed(lambda: calibrate_batch(batch, method, keys), repeats)
    return {"n_run": n, "seconds": sec, "compile_seconds": max(first - sec, 0.0),
            "cost": np.asarray(res.cost).tolist(), "steps": np.asarray(res.n_evaluations).tolist(),
            "status": [str(s) for s in status_name(res.status)]}


_ONE_LM = {}


def optimistix_one_at_a_time(problems, n):
    lm = LevenbergMarquardt()
    key = jax.tree.structure(problems).num_leaves, problems.data.poses.shape[-2]
    if key not in _ONE_LM:
        _ONE_LM[key] = jax.jit(lambda p: lm.run(lambda u, pp: pp.residuals(u), p.initial, p, lambda u, pp: pp.cost(u)))
    f = _ONE_LM[key]
    t0 = time.perf_counter()
    jax.block_until_ready(f(jax.tree.map(lambda x: x[0], problems)))
    first = time.perf_counter() - t0
    ones = [jax.tree.map(lambda x, k=k: x[k], problems) for k in range(n)]
    costs, steps = [], []
    t0 = time.perf_counter()
    for p in ones:
        r = jax.block_until_ready(f(p))
        costs.append(float(r.cost))
        steps.append(int(r.n_evaluations))
    sec = time.perf_counter() - t0
    return {"n_run": n, "seconds": sec, "compile_seconds": max(first - sec / n, 0.0), "cost": costs, "steps": steps}


def scipy_rows(problems, n):
    ones = [jax.tree.map(lambda x, k=k: np.asarray(x[k]), problems) for k in range(n)]
    costs, steps = [], []
    t0 = time.perf_counter()
    for p in ones:
        _, c, nfev = scipy_peer(p)
        costs.append(c)
        steps.append(int(nfev))
    return {"n_run": n, "seconds": time.perf_counter() - t0, "compile_seconds": None, "cost": costs, "steps": steps}


# ---- flop count ----------------------------------------------------------------------------


def solver_flops(m: int, n_blocks: int, n_k: int) -> int:
    """Floating-point operations of one iteration's linear algebra (K blocks of m_k × n_k):
    ``JᵀJ`` (2·m_k·n_k², the full product), ``Jᵀr`` (2·m_k·n_k), Cholesky (n_k³/3) and the two
    triangular solves (2·n_k²); the residual and Jacobian evaluation are not counted."""
    m_k = m // n_blocks
    return n_blocks * (2 * m_k * n_k**2 + 2 * m_k * n_k + n_k**3 // 3 + 2 * n_k**2)


def peak_gflops() -> tuple[float, str]:
    """Double-precision peak of this machine from ``lscpu``: AVX2 + FMA gives 2 FMA units ×
    4 doubles × 2 flops = 16 flops per cycle per core (AMD Zen 2/3, Intel since Haswell)."""
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return float("nan"), "lscpu unavailable"
    info = dict(line.split(":", 1) for line in out.splitlines() if ":" in line)
    info = {k.strip(): v.strip() for k, v in info.items()}
    cores = int(info.get("CPU(s)", "1"))
    mhz = info.get("CPU max MHz") or info.get("CPU MHz")
    ghz = float(mhz) / 1e3 if mhz else float(info.get("BogoMIPS", "0")) / 2e3
    flags = info.get("Flags", "")
    per_cycle = 16 if ("avx2" in flags and "fma" in flags) else 4
    how = (f"{info.get('Model name', '?')}: {cores} cores × {per_cycle} double flops/cycle × {ghz:.2f} GHz "
           f"({'CPU MHz' if mhz else 'BogoMIPS / 2'}; no boost assumed)")
    return cores * per_cycle * ghz, how


# ---- the conditioning NOTE -----------------------------------------------------------------


def conditioning() -> dict:
    """Cholesky vs QR on the rank-deficient 8-pose normal equations (dense, 36 parameters)."""
    problems, *_ = simulate_trials(trial_keys(0, 1), sj.nominal_geometry(), sj.actual_geometry(), "paper8")
    p = jax.tree.map(lambda x: np.asarray(x[0]), problems)
    peer = NumpyPSS(p.data.readings, p.data.poses, p.mechanism.v0)
    u = np.asarray(p.initial)
    r, j = peer.residual(u), peer.jacobian(u)
    sv = np.linalg.svd(j, compute_uv=False)
    rank = int(np.sum(sv > sv[0] * 1e-12))
    a, g = j.T @ j, j.T @ r
    d = np.diag(a)
    rows = []
    for mu in (1e-3, 1e-6, 1e-9, 1e-12):
        damped = a + mu * np.diag(d)
        c = np.linalg.cholesky(damped)
        h_chol = -np.linalg.solve(c.T, np.linalg.solve(c, g))
        aug = np.vstack([j, np.diag(np.sqrt(mu * d))])
        h_qr = np.linalg.lstsq(aug, np.concatenate([-r, np.zeros(36)]), rcond=None)[0]
        s_chol = np.sum(peer.residual(u + h_chol) ** 2)
        s_qr = np.sum(peer.residual(u + h_qr) ** 2)
        rows.append({"mu": mu, "cond": float(np.linalg.cond(damped)),
                     "step_rel_diff": float(np.linalg.norm(h_chol - h_qr) / np.linalg.norm(h_qr)),
                     "cost_rel_diff": float(abs(s_chol - s_qr) / s_qr)})
    return {"rank": rank, "singular_values_top_bottom": [float(sv[0]), float(sv[rank - 1]), float(sv[-1])],
            "rows": rows}


# ---- the whole Monte Carlo trial -------------------------------------------------------------


def whole_trials(n: int, rows) -> list[dict]:
    """``run_study(("lm-batched",), n)`` per plan: compiled by a first run, timed on a second
    (another seed), against the SciPy peer's time per calibration at the same batch."""
    out = []
    for plan in ("paper8", "plan120"):
        run_study(("lm-batched",), n, seed=1, plan=plan, log=lambda _: None)
        t0 = time.perf_counter()
        res = run_study(("lm-batched",), n, seed=2, plan=plan, log=lambda _: None)
        wall = time.perf_counter() - t0
        cal = sum(res["rows"]["LM (batched)"]["seconds_per_chunk_including_compile"])
        peer = next(r for r in rows if r["problem"] == f"6-PSS {plan}" and r["batch"] == n
                    and r["method"].startswith("SciPy"))
        t = {"plan": plan, "trials": n, "ms_per_trial": 1e3 * wall / n, "calibration_ms_per_trial": 1e3 * cal / n,
             "scipy_ms_per_calibration": peer["ms_per_calibration"]}
        t["scipy_over_trial"] = t["scipy_ms_per_calibration"] / t["ms_per_trial"]
        print(f"whole trial {plan}: {t['ms_per_trial']:.3f} ms/trial ({t['scipy_over_trial']:.1f}x cheaper than one "
              "SciPy calibration)", flush=True)
        out.append(t)
    return out


# ---- main ----------------------------------------------------------------------------------


def problem_sets(n: int):
    nominal, actual = sj.nominal_geometry(), sj.actual_geometry()
    keys = trial_keys(0, n)
    out = {}
    for plan in ("paper8", "plan120"):
        out[f"6-PSS {plan}"] = simulate_trials(keys, nominal, actual, plan)[0]
    cam = preset("rubin_camera")
    out["6-UPS rubin_camera plan120"] = simulate_trials(keys, cam, perturbed(cam, jax.random.key(1), 0.5), "plan120",
                                                        tracker=True, half_width=5.0)[0]
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="batches of 1, 10, 50")
    ap.add_argument("--row-budget", type=float, default=None, help="seconds a slow row may take (default 20; 2 quick)")
    ap.add_argument("--conditioning", action="store_true", help="only the Cholesky-vs-QR measurement")
    args = ap.parse_args(argv)
    if args.conditioning:
        c = conditioning()
        print(c)
        return 0
    batches = (1, 10, 50) if args.quick else (1, 100, 1000)
    budget = args.row_budget or (2.0 if args.quick else 20.0)
    repeats = 2 if args.quick else 3
    sets = problem_sets(batches[-1])
    peak, peak_how = peak_gflops()
    rows = []

    def add(pset, method, batch, r, note=""):
        r = {"problem": pset, "method": method, "batch": batch, "note": note, **r}
        if "seconds" in r:
            r["ms_per_calibration"] = 1e3 * r["seconds"] / r["n_run"]
            r["median_cost"] = float(np.median(r["cost"]))
            r["median_steps"] = float(np.median(r["steps"]))
            r["max_steps"] = int(np.max(r["steps"]))
        rows.append(r)
        ms = f"{r['ms_per_calibration']:9.3f} ms/cal" if "seconds" in r else f"skipped: {note}"
        print(f"{pset:28s} {method:42s} {batch:5d} {ms}", flush=True)

    for pset, problems in sets.items():
        pss = pset.startswith("6-PSS")
        per_cal = {}  # method -> latest ms per calibration, for the budget estimate
        for batch in batches:
            # --quick: the new solver against the SciPy peer; the slow baselines at batch 1 only
            vmapped = ("lm-batched", "lm", "lm-jaxopt") if (batch == 1 or not args.quick) else ("lm-batched",)
            for method in vmapped:
                label = {"lm-batched": "lm-batched", "lm": "lm (optimistix), vmapped",
                         "lm-jaxopt": "lm-jaxopt, vmapped"}[method]
                est = per_cal.get(method, 0.0) * batch / 1e3
                if est > budget:
                    add(pset, label, batch, {}, f"estimated {est:.0f} s > row budget {budget:.0f} s")
                    continue
                r = batch_row(method, problems, batch, repeats if batch < 1000 else 1)
                per_cal[method] = 1e3 * r["seconds"] / r["n_run"]
                add(pset, label, batch, r)
            # one at a time: the time per calibration does not depend on the batch; run
            # min(batch, what fits the budget) problems
            for label, fn in (("lm (optimistix), one at a time (jit)", optimistix_one_at_a_time),
                              ("SciPy lm, NumPy residual + analytic Jacobian", scipy_rows)):
                if (label.startswith("SciPy") and not pss) or (label.startswith("lm") and batch not in
                                                               (batches[0], batches[-1])):
                    continue
                n = batch if label not in per_cal else int(min(batch, max(1, budget * 1e3 / per_cal[label])))
                r = fn(problems, n)
                per_cal[label] = 1e3 * r["seconds"] / r["n_run"]
                add(pset, label, batch, r, "" if n == batch else f"{n} of {batch} problems, one at a time")

    # GFLOP/s of lm-batched's linear algebra at the largest batch
    flops = {}
    for pset, problems in sets.items():
        m = problems.data.poses.shape[-2] * 6
        n_k = len(problems.mechanism.leg_parameters[0])
        r = next(x for x in rows if x["problem"] == pset and x["method"] == "lm-batched" and x["batch"] == batches[-1])
        iters = float(np.sum(r["steps"]))
        f = solver_flops(m, 6, n_k) * iters / r["n_run"]
        dense = solver_flops(m, 1, 6 * n_k) * iters / r["n_run"]
        flops[pset] = {"flops_per_calibration": f, "dense_equivalent_flops_per_calibration": dense,
                       "gflops_achieved": f / (r["ms_per_calibration"] * 1e6),
                       "dense_equivalent_gflops": dense / (r["ms_per_calibration"] * 1e6)}

    trials = whole_trials(batches[-1], rows)
    cond = conditioning()
    md = [f"## Time per calibration (ms), compile apart; batches {', '.join(map(str, batches))}", "",
          "| problems | method | batch | problems run | ms / calibration | compile s | median steps | max steps "
          "| median S (mm²) | × SciPy peer | note |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        if "seconds" not in r:
            md.append(f"| {r['problem']} | {r['method']} | {r['batch']} | – | – | – | – | – | – | – | {r['note']} |")
            continue
        peer = next((x for x in rows if x["problem"] == r["problem"] and x["batch"] == r["batch"]
                     and x["method"].startswith("SciPy")), None)
        ratio = f"{peer['ms_per_calibration'] / r['ms_per_calibration']:.1f}×" if peer else "–"
        cs = "" if r["compile_seconds"] is None else f"{r['compile_seconds']:.1f}"
        md.append(f"| {r['problem']} | {r['method']} | {r['batch']} | {r['n_run']} | {r['ms_per_calibration']:.3f} | "
                  f"{cs} | {r['median_steps']:.0f} | {r['max_steps']} | {r['median_cost']:.4g} | {ratio} | "
                  f"{r['note']} |")
    md += ["", f"Steps: LM iterations + 1 (JAX rows), residual evaluations (SciPy). Peak: {peak:.0f} GFLOP/s — "
           f"{peak_how}.", "",
           f"## lm-batched: achieved GFLOP/s of its linear algebra at batch {batches[-1]}", "",
           "| problems | flops / calibration (per-leg blocks) | GFLOP/s | % of peak "
           "| dense 36/42-parameter equivalent flops | equivalent GFLOP/s |", "|---|---|---|---|---|---|"]
    for pset, f in flops.items():
        md.append(f"| {pset} | {f['flops_per_calibration']:.3g} | {f['gflops_achieved']:.2f} | "
                  f"{100 * f['gflops_achieved'] / peak:.1f} % | {f['dense_equivalent_flops_per_calibration']:.3g} | "
                  f"{f['dense_equivalent_gflops']:.2f} |")
    md += ["", f"## The whole Monte Carlo trial: `stewart-jax study --methods lm-batched --trials {batches[-1]}`", "",
           "`run_study` once to compile, then timed on fresh trials (another seed): simulation (FK of the true "
           "mechanism, noise), the uncalibrated row's and lm-batched's control errors at the calibration and 42 "
           "validation poses (FK of the true mechanism from each command), and the calibrations.", "",
           "| plan | trials | ms / trial, whole study | of which lm-batched's calibrations | "
           "SciPy peer ms / calibration (same run) | one SciPy calibration / one whole trial |",
           "|---|---|---|---|---|---|"]
    for t in trials:
        md.append(f"| {t['plan']} | {t['trials']} | {t['ms_per_trial']:.3f} | {t['calibration_ms_per_trial']:.3f} | "
                  f"{t['scipy_ms_per_calibration']:.3f} | {t['scipy_over_trial']:.1f}× |")
    md += ["", "## Cholesky vs QR on the 8-pose normal equations (dense, at the nominal start)", "",
           f"rank J = {cond['rank']} of 36; singular values {cond['singular_values_top_bottom']}", "",
           "| μ (× diag JᵀJ) | cond(JᵀJ + μD) | ‖h_chol − h_qr‖/‖h_qr‖ | |S_chol − S_qr|/S_qr |", "|---|---|---|---|"]
    for c in cond["rows"]:
        md.append(f"| {c['mu']:.0e} | {c['cond']:.2e} | {c['step_rel_diff']:.1e} | {c['cost_rel_diff']:.1e} |")
    text = "\n".join(md)
    print("\n" + text)
    write_results("batched_lm_quick" if args.quick else "batched_lm",
                  {"batches": list(batches), "rows": rows, "flops": flops, "peak_gflops": peak,
                   "peak_how": peak_how, "whole_trials": trials, "conditioning": cond}, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
