"""Fitting a compensation table from a campaign: held-out error against a fit that knows the true
polynomial shapes, and the stated uncertainty against the error.

The truth is the Rubin Observatory's published v7 camera table (``tests/data/compensation_v7.yaml``)
or, for a truth outside the polynomial family, a gravity/thermal flexure model
(``stewart_jax.compensation.FlexureModel``, cos/sin of elevation and rotator angle). Per campaign
design and seed: a simulated campaign (tracker pose noise σ per axis), ``fit_table`` (degrees by
5-fold cross-validation, one-standard-error rule, noise coefficients dropped), and on 1000
held-out attitudes (elevation U[0, 90], rotation U[−90, 90], temperature U over the campaign's)
the RMS error against the truth per axis; beside it the same for the oracle (least squares with
the truth's own 2-D degrees; for the flexure model, no oracle) and the ratio of the error to the
fit's own stated prediction σ (RMS over the domain; 1 when the σ is right and the fit unbiased).

    python benchmarks/compensation_fit.py [--seeds 5]
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings

import jax
import numpy as np
from numpy.polynomial.polynomial import polyvander2d

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _common import RESULTS, write_results  # noqa: E402

import stewart_jax  # noqa: E402,F401
from stewart_jax.compensation import FlexureModel, fit_table, load_table, simulate_campaign  # noqa: E402

TABLE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "data", "compensation_v7.yaml")
DESIGNS = {  # elevations, rotations, temperatures, σ µm, σ ″
    "10°×30°, 5 µm/1″": (np.arange(0, 91, 10.0), np.arange(-90, 91, 30.0), None, 5.0, 1.0),
    "10°×15°, 20 µm/3″": (np.arange(0, 91, 10.0), np.arange(-90, 91, 15.0), None, 20.0, 3.0),
    "5°×10°, 5 µm/1″": (np.arange(0, 91, 5.0), np.arange(-90, 91, 10.0), None, 5.0, 1.0),
    "5°×10°, 1 µm/0.2″": (np.arange(0, 91, 5.0), np.arange(-90, 91, 10.0), None, 1.0, 0.2),
    "10°×15°×3 temps, 5 µm/1″": (np.arange(0, 91, 10.0), np.arange(-90, 91, 15.0), [-5.0, 5.0, 15.0], 5.0, 1.0),
}


def oracle_error(truth, camp, e, r, want) -> np.ndarray:
    c = np.asarray(truth.elevation_rotation)
    out = []
    for i in range(6):
        rows, cols = np.flatnonzero(np.any(c[i] != 0, 1)), np.flatnonzero(np.any(c[i] != 0, 0))
        deg = (rows.max() if rows.size else 0, cols.max() if cols.size else 0)
        a = polyvander2d(camp.elevation_deg / 90, camp.rotation_deg / 90, deg)
        coef = np.linalg.lstsq(a, camp.offsets[:, i], rcond=None)[0]
        out.append(np.sqrt(np.mean((polyvander2d(e / 90, r / 90, deg) @ coef - want[:, i]) ** 2)))
    return np.array(out)


def flexure() -> FlexureModel:
    from stewart_jax.compensation._campaign import camera_flexure

    return camera_flexure()


def run(seeds: int) -> dict:
    truths = {"v7 camera table": load_table(TABLE, "camera"), "flexure model": flexure()}
    rng = np.random.default_rng(12345)
    e, r = rng.uniform(0, 90, 1000), rng.uniform(-90, 90, 1000)
    rows = []
    for tname, truth in truths.items():
        for dname, (el, ro, temps, su, sa) in DESIGNS.items():
            t = rng.uniform(min(temps), max(temps), 1000) if temps else np.zeros(1000)
            want = np.asarray(truth.offsets(e, r, 0.0, t))
            for seed in range(seeds):
                camp = simulate_campaign(jax.random.key(seed), truth, el, ro, temps, sigma_um=su, sigma_arcsec=sa)
                fit = fit_table(camp, seed=seed)
                err = np.sqrt(np.mean((np.asarray(fit.table.offsets(e, r, 0.0, t)) - want) ** 2, axis=0))
                orc = oracle_error(truth, camp, e, r, want) if tname.startswith("v7") else np.full(6, np.nan)
                rows.append({"truth": tname, "design": dname, "seed": seed, "n_attitudes": len(camp.elevation_deg),
                             "error": err.tolist(), "oracle_error": orc.tolist(),
                             "stated_std_rms": [a.prediction_std_rms for a in fit.axes],
                             "degrees": [list(a.degrees) for a in fit.axes],
                             "kept": [sum(x.kept for x in a.terms) for a in fit.axes]})
    return {"seeds": seeds, "rows": rows}


def markdown(res: dict) -> str:
    lines = ["Held-out RMS error of the fitted table against the truth, per axis (x, y, z in µm; u, v, w in "
             "arc-seconds), mean over seeds; `ratio` = ours / the fit that knows the true shapes (worst seed); "
             "`err/σ` = error / the fit's stated prediction σ (RMS over the domain; mean over seeds, w left out: "
             "its truth is 0).", "",
             "| truth | design | n | error x, y, z (µm) | error u, v, w (″) | ratio to oracle, worst (x…w) | err/σ |",
             "|---|---|---|---|---|---|---|"]
    groups: dict = {}
    for row in res["rows"]:
        groups.setdefault((row["truth"], row["design"]), []).append(row)
    for (tname, dname), rows in groups.items():
        err = np.array([r["error"] for r in rows])
        orc = np.array([r["oracle_error"] for r in rows])
        std = np.array([r["stated_std_rms"] for r in rows])
        with warnings.catch_warnings():  # an all-NaN column (no oracle) is expected
            warnings.simplefilter("ignore", RuntimeWarning)
            ratio = np.nanmax(np.where(orc > 0, err / np.where(orc > 0, orc, 1), np.nan), axis=0)
        m = err.mean(0)
        ratio_text = "–" if np.all(np.isnan(orc)) else ", ".join(f"{x:.2f}" if np.isfinite(x) else "–" for x in ratio)
        cover = np.mean(err[:, :5] / np.maximum(std[:, :5], 1e-300))
        lines.append(f"| {tname} | {dname} | {rows[0]['n_attitudes']} | {m[0]:.2f}, {m[1]:.2f}, {m[2]:.2f} | "
                     f"{m[3] * 3600:.3f}, {m[4] * 3600:.3f}, {m[5] * 3600:.3f} | {ratio_text} | {cover:.2f} |")
    return "\n".join(lines)


def figure() -> None:
    import matplotlib

    matplotlib.use("Agg")
    from stewart_jax.plotting import plot_table_offsets, show

    truth = load_table(TABLE, "camera")
    camp = simulate_campaign(jax.random.key(0), truth, *DESIGNS["10°×15°, 20 µm/3″"][:3], sigma_um=20.0,
                             sigma_arcsec=3.0)
    fit = fit_table(camp)
    show(plot_table_offsets({"published v7": truth, "fitted (20 µm, 3″ campaign)": fit.table},
                            title="Rubin camera hexapod: published v7 table and a table fitted to a campaign"),
         os.path.join(RESULTS, "compensation_fit.png"))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=5)
    args = p.parse_args()
    res = run(args.seeds)
    write_results("compensation_fit", res, markdown(res))
    figure()
    print(markdown(res))


if __name__ == "__main__":
    main()
