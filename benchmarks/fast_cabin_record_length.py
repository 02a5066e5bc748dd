"""Cabin records of practical length: naming rate and time against the record's length, the
tracker noise and how the cabin was released, for ``stewart-jax diagnose --geometry fast``.

Records are simulated by the time integrators (never by the modal sum the workflow fits) at the
centre, ζ = 0.005, sampled at ``--rate-hz``; white tracker noise σ per position coordinate
(rotation σ = 0.01° per mm of it) drawn per seed. Release types:

- ``offset-equilibrium``: the cabin released from 20, 10, 5 mm and 0.01°, 0.01°, 0.02°, the
  cables in the quasi-static shape of that offset (a static offset under a load);
- ``offset-rest``: the same offset, the cables' nodes at rest in the static pose;
- ``impulse``: the cabin struck at the static pose (10, 5, 2 mm/s), the cables at rest;
- ``none``: the paper's quasi-static cables released from the offset (nothing may be named).

Lumped-mass records use ``--record-segments`` segments per cable, the model ``--segments`` (a
comma-separated list: each model diagnoses the same records).
Each cell runs the workflow (30 % held out) on the record's first T seconds.

    python benchmarks/fast_cabin_record_length.py --durations 20,60,200 --noise-mm 1 --seeds 1
    python benchmarks/fast_cabin_record_length.py --durations 200 --record-segments 20 --segments 8 \
        --releases offset-equilibrium,none --tag cli_records

Results: ``benchmarks/results/fast_cabin_record_length{_TAG}.{json,md}``, rewritten after every
cell (an interrupted run keeps what it has).
"""

from __future__ import annotations

import argparse
import itertools
import os
import resource
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
V0 = np.array([0.01, 0.005, 0.002, 0.0, 0.0, 0.0])
ZETA = 0.005


def _decay(release, params, n_rec, t_max, dt):
    if release == "none":
        return quasi_static_free_decay(params, POS, t_max, dt, displacement=Q0, damping_ratio=ZETA)
    if release == "impulse":
        return lumped_free_decay(params, POS, n_rec, t_max, dt, displacement=np.zeros(6), velocity=V0,
                                 damping_ratio=ZETA, cable_nodes="rest")
    nodes = "equilibrium" if release == "offset-equilibrium" else "rest"
    return lumped_free_decay(params, POS, n_rec, t_max, dt, displacement=Q0, damping_ratio=ZETA, cable_nodes=nodes)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--segments", default="8", help="segments per cable of the model(s), comma-separated")
    ap.add_argument("--record-segments", type=int, default=None, help="segments of the lumped records")
    ap.add_argument("--releases", default="offset-equilibrium,offset-rest,impulse,none")
    ap.add_argument("--durations", default="20,60,200", help="record lengths, s")
    ap.add_argument("--noise-mm", default="1", help="tracker noise σ per position coordinate, mm")
    ap.add_argument("--rate-hz", type=float, default=10.0)
    ap.add_argument("--dt", type=float, default=None, help="integrator step (s; default 5e-3, or the "
                    "lumped integrator's own for records finer than N = 8)")
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--tag", default="")
    args = ap.parse_args()
    durations = [float(v) for v in args.durations.split(",")]
    noises = [float(v) for v in args.noise_mm.split(",")]
    models = [int(v) for v in args.segments.split(",")]
    n_rec = models[0] if args.record_segments is None else args.record_segments
    dt = args.dt if args.dt is not None else (5e-3 if n_rec <= 8 else None)
    name = "fast_cabin_record_length" + (f"_{args.tag}" if args.tag else "")
    params = paper_fast_params()
    modal, setup_s = {}, {}
    for n_model in models:
        t0 = time.perf_counter()
        modal[n_model] = cabin_modal_model(params, POS, n_model)
        setup_s[n_model] = time.perf_counter() - t0
    cells = []
    for release in args.releases.split(","):
        t1 = time.perf_counter()
        dec = _decay(release, params, n_rec, max(durations), dt if release != "none" else 5e-3)
        sim_s = time.perf_counter() - t1
        for duration in durations:
            keep = dec.time <= duration + 1e-9
            part = dec._replace(time=dec.time[keep], cabin=dec.cabin[keep])
            for sigma, n_model in itertools.product(noises, models):
                runs = []
                for s in range(args.seeds):
                    data = read_cabin_record(part.sample(args.rate_hz, sigma_mm=sigma, sigma_deg=0.01 * sigma, seed=s))
                    t2 = time.perf_counter()
                    model = cabin_record_model(data, POS, modal=modal[n_model], sigma_um=1e3 * sigma,
                                               sigma_arcsec=36.0 * sigma)
                    t3 = time.perf_counter()
                    rep = diagnose(data, model, seed=s)
                    t4 = time.perf_counter()
                    ci = next(c for c in rep.ranking if c.effect == "cable_inertia")
                    runs.append({"seed": s, "samples": int(data.time.shape[0]), "named": rep.named_effect,
                                 "detected": rep.detected, "explained": rep.explained,
                                 "partial": [p["effect"] for p in rep.partial],
                                 "discovered": [t["description"] for t in rep.discovered],
                                 "mass_share": ci.params[0], "node_lag": ci.params[1],
                                 "continuum": ci.params[2],
                                 "starts": {k: list(v) for k, v in model.grids},
                                 "gap_before_um_urad": rep.gap_before, "gap_after_um_urad": rep.gap_after,
                                 "noise_floor_um_urad": rep.noise_floor,
                                 "model_s": t3 - t2, "diagnose_s": t4 - t3,
                                 "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024})
                target = None if release == "none" else "cable_inertia"
                cell = {"release": release, "duration_s": duration, "sigma_mm": sigma, "model_segments": n_model,
                        "runs": runs, "simulation_s": sim_s,
                        "named_right": sum(r["named"] == target for r in runs),
                        "named_wrong": sum(r["named"] not in (target, None) for r in runs)}
                cells.append(cell)
                print(f"{release:20s} T={duration:6.0f} s σ={sigma:4.1f} mm N={n_model}: "
                      f"right {cell['named_right']}/{len(runs)} "
                      f"wrong {cell['named_wrong']}, diagnose {np.median([r['diagnose_s'] for r in runs]):.0f} s",
                      flush=True)
                _write(name, cells, args, n_rec, models, setup_s)


def _write(name, cells, args, n_rec, models, setup_s) -> None:
    lines = [
        "# FAST cabin records of practical length",
        "",
        f"Lumped-mass records (N = {n_rec}), the model with N = {', '.join(map(str, models))}; at (0, 0, 140) m, "
        "ζ = 0.005, "
        f"{args.rate_hz:g} Hz; {args.seeds} noise seed(s) per cell, rotation noise 0.01° per mm. *right*: "
        "`cable_inertia` named on a lumped record, nothing on the quasi-static one (`none`); μ, β: the fitted share "
        "of the cables' mass and lag of their nodes (truth 1, and 0 for offset-equilibrium, 1 for offset-rest and "
        "impulse); γ: the fitted continuum share of the cables' discretisation (truth 1 − (N model / N record)², "
        "the model at γ stands for N / √(1 − γ) segments); gaps: held-out RMS over the six coordinates (µm, µrad), "
        "median; time: `cabin_record_model` "
        "(record's modes and starts) + `diagnose`, wall clock on the machine below, median.",
        "",
        "| release | T (s) | samples | σ (mm) | N model | right | wrong | μ | β | γ | gap before | gap after | floor "
        "| model (s) | diagnose (s) | peak RSS (MB) |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for c in cells:
        r = c["runs"]

        def med(k, r=r):
            return float(np.median([x[k] for x in r]))

        lines.append(
            f"| {c['release']} | {c['duration_s']:.0f} | {r[0]['samples']} | {c['sigma_mm']:g} | "
            f"{c['model_segments']} | "
            f"{c['named_right']}/{len(r)} | {c['named_wrong']} | {med('mass_share'):.3f} | {med('node_lag'):.2f} | "
            f"{med('continuum'):.2f} | "
            f"{med('gap_before_um_urad'):.0f} | {med('gap_after_um_urad'):.0f} | {med('noise_floor_um_urad'):.0f} | "
            f"{med('model_s'):.0f} | {med('diagnose_s'):.0f} | {max(x['peak_rss_mb'] for x in r):.0f} |")
    built = ", ".join(f"N = {k}: {v:.0f} s" for k, v in setup_s.items())
    lines += ["", f"Modal model (statics, tables, compile): {built}."]
    write_results(name, {"segments": models, "record_segments": n_rec, "rate_hz": args.rate_hz,
                         "damping_ratio": ZETA, "initial_displacement_m_rad": Q0.tolist(),
                         "impulse_velocity_m_s": V0.tolist(), "cells": cells}, "\n".join(lines))


if __name__ == "__main__":
    main()
