"""The discrepancy workflow on laser-tracker points: how often a hidden strut scale error is named,
and how often an alarm is raised (or a name given) where nothing is hidden.

Sessions of the Rubin camera hexapod from the independent NumPy simulator of
``tests/_numpy_session.py`` (30 poses uniform in the reachable travel, the geometry's joints and
lengths moved by 30 µm), every one of six platform targets measured at each pose by a tracker
2.9 m away with σ = 5 µm along the line of sight and 2.5 µm/m across it; with a strut scale
error, each strut's readings are divided by ``1 + k_i``, ``|k_i|`` uniform in 2000–4000 ppm with
random signs. Candidates: ``strut_scale`` and ``backlash``; 30 % of the points held out.

    python benchmarks/discrepancy_points.py [--seeds 8]

``--null-seeds N`` measures instead the null distribution of the held-out detection test over N
sessions without a hidden effect (seeds 1000…; candidate ``strut_scale`` only: the detection
depends on the base fit alone), each split two ways: the workflow's random 30 % of the points,
and 30 % of the poses with all their points. Each session is appended to
``results/discrepancy_points_null.jsonl`` as it finishes (a rerun skips those already there);
the summary gives the false-alarm rate at α = 5 % with its exact (Clopper–Pearson) 95 %
interval, and Kolmogorov–Smirnov tests of the p-values against uniform and of the base fit's
training χ² against χ²(dof).

    python benchmarks/discrepancy_points.py --null-seeds 60
"""

from __future__ import annotations

import argparse
import os
import sys

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "tests"))

import test_discrepancy_points as setup_points  # noqa: E402
from _common import write_results  # noqa: E402

import stewart_jax as sj  # noqa: E402
from stewart_jax import discrepancy as dc  # noqa: E402
from stewart_jax.calibration._points_simulation import default_registration, default_targets  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--null-seeds", type=int, default=0)
    args = ap.parse_args()
    cam = sj.mechanism.preset("rubin_camera")
    targets = default_targets(cam)
    rot, t = default_registration(cam)
    setup = (targets, rot, t, sj.calibration.reachable_travel(cam))
    if args.null_seeds:
        null_distribution(cam, setup, args.null_seeds)
        return
    rows = []
    for hidden in (None, "strut_scale"):
        for seed in range(args.seeds):
            data, _ = setup_points.points_session(cam, setup, None, 100 + seed,
                                                  scale_ppm=setup_points.SCALE_PPM if hidden else None)
            r_rows, r0, t0 = dc.point_rows(data, targets, cam, range_um=setup_points.RANGE_UM,
                                           across_um_per_m=setup_points.ACROSS_UM_PER_M)
            r = dc.diagnose(r_rows, dc.points_model(cam, r0, t0), effects=setup_points.CANDIDATES, seed=seed)
            rows.append({"hidden": hidden or "none", "seed": seed, "detected": r.detected,
                         "detect_p_value": r.detect_p_value, "named": r.named_effect,
                         "gap_before_um": r.gap_before, "gap_after_um": r.gap_after, "noise_floor_um": r.noise_floor})
            print(rows[-1], flush=True)
    md = ["# Discrepancy workflow on laser-tracker points (rubin_camera)", "",
          __doc__.split("\n\n")[1].replace("\n", " "), "",
          "| hidden | sessions | detected | named right | named wrong | gap before / after (median, µm) |",
          "|---|---|---|---|---|---|"]
    for hidden in ("none", "strut_scale"):
        sub = [r for r in rows if r["hidden"] == hidden]
        right = sum(r["named"] == hidden for r in sub) if hidden != "none" else 0
        wrong = sum(r["named"] not in (None, hidden) for r in sub)
        med = [sorted(r[k] for r in sub)[len(sub) // 2] for k in ("gap_before_um", "gap_after_um")]
        md.append(f"| {hidden} | {len(sub)} | {sum(r['detected'] for r in sub)} | {right} | {wrong} | "
                  f"{med[0]:.2f} / {med[1]:.2f} |")
    write_results("discrepancy_points", {"sessions": rows}, "\n".join(md))
    print("\n".join(md))


SPLITS = ("points", "poses")
"""The held-out split: a random 30 % of the points (the workflow's), or of the poses."""


def null_distribution(cam, setup, n_seeds: int) -> None:
    """Sessions as above with nothing hidden (seeds 1000…), the detection test of the base fit at
    α = 5 % (candidate ``strut_scale`` only; the detection depends on the base fit alone), the
    held-out 30 % drawn from the points (the workflow's split) or from the poses (all points of a
    held-out pose). Rate: detections / sessions with its exact (Clopper–Pearson) 95 % interval;
    KS: Kolmogorov–Smirnov p-values of the held-out p-values against uniform and of the base fit's
    training χ² against χ²(dof)."""
    import json

    import numpy as np
    from scipy import stats

    from stewart_jax.discrepancy._driver import diagnose_many, select_effects, split_rows

    targets = setup[0]
    log = os.path.join(HERE, "results", "discrepancy_points_null.jsonl")
    done = set()
    if os.path.exists(log):
        with open(log) as f:
            done = {(r["seed"], r["split"]) for r in map(json.loads, f)}
    for seed in range(n_seeds):
        for split in SPLITS:
            if (seed, split) in done:
                continue
            data, _ = setup_points.points_session(cam, setup, None, 1000 + seed)
            rows, r0, t0 = dc.point_rows(data, targets, cam, range_um=setup_points.RANGE_UM,
                                         across_um_per_m=setup_points.ACROSS_UM_PER_M)
            model = dc.points_model(cam, r0, t0)
            if split == "poses":
                n_te = int(round(setup_points.N_POSES * 0.3))
                perm = np.random.default_rng(seed).permutation(setup_points.N_POSES)
                held = np.isin(np.asarray(rows.pose), perm[:n_te])
                train_idx, test_idx = np.flatnonzero(~held), np.flatnonzero(held)
            else:
                train_idx, test_idx = split_rows(model.n_rows(rows), 0.3, seed)
            chosen, _ = select_effects(model, rows, len(train_idx), ("strut_scale",))
            r = diagnose_many(model, chosen, [model.take(rows, train_idx)], [model.take(rows, test_idx)],
                              discover=False)[0]
            rec = {"seed": seed, "split": split, "detect_p_value": r.detect_p_value, "detect_dof": r.detect_dof,
                   "base_chi2": r.base_chi2, "base_dof": r.base_dof,
                   "named": r.named_effect}
            with open(log, "a") as f:
                f.write(json.dumps(rec) + "\n")
            print(rec, flush=True)
    with open(log) as f:
        recs = [r for r in map(json.loads, f) if r["seed"] < n_seeds]
    summary, md = {}, ["# Null distribution of the points diagnosis's held-out test (rubin_camera)", "",
                       " ".join(null_distribution.__doc__.split()), "",
                       "| held-out split | sessions | detected at α = 5 % | rate (95 % interval) | KS p (p-values "
                       "uniform) | KS p (training χ² ~ χ²(dof)) | named |", "|---|---|---|---|---|---|---|"]
    for split in SPLITS:
        sub = [r for r in recs if r["split"] == split]
        if not sub:
            continue
        p = np.array([r["detect_p_value"] for r in sub])
        k, n = int(np.sum(p < 0.05)), len(p)
        ci = stats.binomtest(k, n, 0.05).proportion_ci(0.95, method="exact")
        ks_p = stats.kstest(p, "uniform").pvalue
        ks_chi2 = stats.kstest([stats.chi2.cdf(r["base_chi2"], r["base_dof"]) for r in sub], "uniform").pvalue
        named = sum(r["named"] is not None for r in sub)
        summary[split] = {"sessions": n, "detected": k, "rate": k / n, "rate_ci95": [ci.low, ci.high],
                          "binomial_p_vs_alpha": stats.binomtest(k, n, 0.05).pvalue, "ks_p_values_uniform": ks_p,
                          "ks_training_chi2": ks_chi2, "named": named}
        md.append(f"| {split} | {n} | {k} | {k / n:.3f} ({ci.low:.3f}–{ci.high:.3f}) | {ks_p:.2f} | {ks_chi2:.2f} | "
                  f"{named} |")
    write_results("discrepancy_points_null", {"summary": summary, "sessions": recs}, "\n".join(md))
    print("\n".join(md))


if __name__ == "__main__":
    main()
