"""How long a record of the FAST cabin's free vibration, and how little noise, the discrepancy
workflow needs to name the cables' inertia — and that it names nothing on a record of the
paper's own quasi-static model.

Records are simulated by the time integrators (lumped-mass cables with N segments for
``cable_inertia``; the quasi-static catenaries for ``none``), released from 20 mm, 10 mm, 5 mm and
0.01°, 0.01°, 0.02° with damping ratio 0.005, at the centre, sampled at 10 Hz; white tracker noise
σ per position coordinate (rotation σ = 0.01° per mm of it) is drawn per seed. Each cell runs
``stewart-jax diagnose --geometry fast``'s workflow (the model with the same N), 30 % held out.

    python benchmarks/fast_cabin_record.py --durations 10,20,40 --noise-mm 1,3,10 --seeds 4
    python benchmarks/fast_cabin_record.py --quick         # 2 durations × 2 noise levels × 2 seeds
    python benchmarks/fast_cabin_record.py --record-segments 8 --durations 20 --noise-mm 1,3 \
        --cases cable_inertia --seeds 4                    # records finer than the model

Results: ``benchmarks/results/fast_cabin_record{,_quick,_records_n8}{,_TAG}.{json,md}`` (the
first and third commands above have been run), rewritten after every cell
(an interrupted run keeps what it has).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # NumPy's threads fight XLA's on small machines

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _common import write_results  # noqa: E402

import stewart_jax  # noqa: E402,F401
from stewart_jax.cable_robot import (  # noqa: E402
    cabin_modal_model,
    lumped_free_decay,
    paper_fast_params,
    quasi_static_free_decay,
)
from stewart_jax.discrepancy import cabin_record_model, diagnose, read_cabin_record  # noqa: E402

POS = (0.0, 0.0, 140.0)
Q0 = np.array([0.02, 0.01, 0.005, *np.deg2rad([0.01, 0.01, 0.02])])
ZETA = 0.005
RATE_HZ = 10.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--segments", type=int, default=4, help="segments per cable of the model")
    ap.add_argument("--record-segments", type=int, default=None,
                    help="segments per cable of the lumped records (default: the model's); finer records "
                         "stand in for the continuous cables the model discretises")
    ap.add_argument("--cases", default="cable_inertia,none")
    ap.add_argument("--tag", default="", help="appended to the results' name")
    ap.add_argument("--durations", default="10,20,40,80", help="record lengths, s")
    ap.add_argument("--noise-mm", default="1,3,10", help="tracker noise σ per position coordinate, mm")
    ap.add_argument("--seeds", type=int, default=5)
    args = ap.parse_args()
    durations = [10.0, 40.0] if args.quick else [float(v) for v in args.durations.split(",")]
    noises = [1.0, 10.0] if args.quick else [float(v) for v in args.noise_mm.split(",")]
    seeds = 2 if args.quick else args.seeds
    name = "fast_cabin_record_quick" if args.quick else "fast_cabin_record"
    n_rec = args.segments if args.record_segments is None else args.record_segments
    if n_rec != args.segments:
        name += f"_records_n{n_rec}"
    if args.tag:
        name += f"_{args.tag}"
    params = paper_fast_params()
    n = args.segments
    t0 = time.perf_counter()
    modal = cabin_modal_model(params, POS, n)
    t_max = max(durations)
    make = {
        "cable_inertia": lambda: lumped_free_decay(params, POS, n_rec, t_max, 5e-3, displacement=Q0,
                                                   damping_ratio=ZETA),
        "none": lambda: quasi_static_free_decay(params, POS, t_max, 5e-3, displacement=Q0, damping_ratio=ZETA),
    }
    decays = {c: make[c]() for c in args.cases.split(",")}
    setup_s = time.perf_counter() - t0
    cells = []
    for duration in durations:
        for sigma in noises:
            for case, dec in decays.items():
                keep = dec.time <= duration + 1e-9
                runs = []
                t1 = time.perf_counter()
                for s in range(seeds):
                    part = dec._replace(time=dec.time[keep], cabin=dec.cabin[keep])  # the record's first T s
                    r = part.sample(RATE_HZ, sigma_mm=sigma, sigma_deg=0.01 * sigma, seed=s)
                    data = read_cabin_record(r)
                    model = cabin_record_model(data, POS, modal=modal, sigma_um=1e3 * sigma,
                                               sigma_arcsec=36.0 * sigma)
                    rep = diagnose(data, model, seed=s)
                    mu = next(c.params[0] for c in rep.ranking if c.effect == "cable_inertia")
                    runs.append({"seed": s, "detected": rep.detected, "named": rep.named_effect,
                                 "partial": [p["effect"] for p in rep.partial],
                                 "explained": rep.explained,
                                 "discovered": [t["description"] for t in rep.discovered],
                                 "indistinguishable_from": rep.indistinguishable_from,
                                 "mass_share": mu, "gap_before": rep.gap_before, "gap_after": rep.gap_after,
                                 "noise_floor": rep.noise_floor, "detect_p": rep.detect_p_value})
                target = case if case != "none" else None
                cell = {"case": case, "duration_s": duration, "sigma_mm": sigma, "runs": runs,
                        "grid_points": {k: len(v) for k, v in model.grids},
                        "named_right": sum(r["named"] == target for r in runs),
                        "named_wrong": sum(r["named"] not in (target, None) for r in runs),
                        "detected": sum(r["detected"] for r in runs), "seconds": time.perf_counter() - t1}
                cells.append(cell)
                print(f"{case:14s} T={duration:5.0f} s σ={sigma:5.1f} mm: right {cell['named_right']}/{seeds}, "
                      f"wrong {cell['named_wrong']}, detected {cell['detected']} ({cell['seconds']:.0f} s)",
                      flush=True)
                _write(name, cells, n, n_rec, seeds, setup_s)


def _write(name, cells, n, n_rec, seeds, setup_s) -> None:
    lines = [
        "# The FAST cabin record: how long a record, how little noise",
        "",
        f"Lumped-mass records (N = {n_rec}) for `cable_inertia`, quasi-static records for `none`; released from "
        f"20, 10, 5 mm and 0.01°, 0.01°, 0.02°, ζ = 0.005, at (0, 0, 140) m, 10 Hz; the model with N = {n}. "
        f"{seeds} noise seeds per cell; rotation noise 0.01° per mm of position noise. *right*: `cable_inertia` "
        "named on the lumped record / nothing named on the quasi-static one; *wrong*: another name; μ: the fitted "
        "share of the cables' mass that moves (1 is the truth); *closed by open terms*: nothing named, and the open "
        "term search's terms close the held-out gap (their descriptions are in the JSON); gaps: held-out RMS / noise "
        "floor (median).",
        "",
        "| record | T (s) | σ (mm) | right | wrong | detected | closed by open terms | μ (median) | gap before "
        "| gap after |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for c in cells:
        r = c["runs"]
        mu = np.median([x["mass_share"] for x in r])
        gb = np.median([x["gap_before"] / x["noise_floor"] for x in r])
        ga = np.median([x["gap_after"] / x["noise_floor"] for x in r])
        lines.append(f"| {c['case']} | {c['duration_s']:.0f} | {c['sigma_mm']:g} | {c['named_right']}/{len(r)} | "
                     f"{c['named_wrong']} | {c['detected']} | "
                     f"{sum(x.get('explained', False) and x['named'] is None for x in r)} | {mu:.3f} | {gb:.2f} | "
                     f"{ga:.2f} |")
    lines.append("")
    lines.append(f"Setup (modal model, both simulations, compile): {setup_s:.0f} s.")
    write_results(name, {"segments": n, "record_segments": n_rec, "seeds": seeds, "rate_hz": RATE_HZ,
                         "damping_ratio": ZETA, "initial_displacement_m_rad": Q0.tolist(), "cells": cells},
                  "\n".join(lines))


if __name__ == "__main__":
    main()
