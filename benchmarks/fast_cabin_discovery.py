"""Hidden effects in records of the FAST cabin's free vibration: the rates of the discrepancy
workflow on the four registered effects, two effects the registry lacks, and the null case, at
the default tracker noise and at 3×.

Records: the time integrators (never the modal superposition the workflow fits), as in
``tests/test_discrepancy_cabin_record.py``: the quasi-static catenaries of Yin, Jiang, Chen, Yao,
"Dynamic modeling of a cable-driven parallel robot with a Stewart platform for use in FAST", or
lumped-mass cables (N = 3) for ``cable_inertia``; the cabin at (0, 0, 140) m released from 20,
10, 5 mm and 0.01°, 0.01°, 0.02°, ζ = 0.005; 20 s at 5 Hz; white tracker noise σ = 1 mm and
0.01° per coordinate (``--noise 1,3``: and 3×), drawn per seed; 30 % of the samples held out.

One more record of the cables' inertia comes from outside the library: ``cable_inertia_moordyn``,
the same cabin on N = 4 lumped-mass cables in MoorDyn v2 (Hall and Goupee 2015, "Validation of a
lumped-mass mooring line model with DeepCwind semisubmersible model test data", Ocean
Engineering 104; the system of ``benchmarks/fast_moordyn.py``: no hydrodynamics, no internal
damping, RK4 at 1 ms), displaced by the same amount after MoorDyn's static solve, its cabin pose
read every 0.2 s; the tracker noise is added here; the model has N = 4 too. (N = 4, not the
other records' 3: MoorDyn's static solve with 3 segments per cable leaves the cabin sinking,
10 mm in the first second, so its record would carry a transient from a state that is not an
equilibrium; with 4 or more the cabin stays where it is. ``--no-moordyn`` leaves the record out.)
MoorDyn has no call that sets a free body's state, so the cabin is displaced in its serialised
state with the cables' nodes left where they were: the release jolts the end segments and starts
the cables' own string modes, which the workflow's model cannot start (its initial conditions are
the cabin modes', with the cables in their quasi-static shape). Measured: the library's lumped
integrator from that same state (nodes at rest) reproduces MoorDyn's record to 0.017 mm RMS on x
over 20 s; the workflow reports MoorDyn's record as a discrepancy that no candidate explains
(the open search does not close it either), never as a wrong name.

The two effects the registry lacks are added to the record in NumPy, here:

- ``missing_vibration``: a vibration the model has no mode for (a forcing, a mode of the feed
  itself): 3 mm · sin(2π t / P + φ) on x, P uniform in 2.5–6 s and φ in 0–2π per seed;
- ``tracker_drift``: the tracker's reading of one position coordinate (x, y or z, drawn per seed)
  drifts linearly, 0.3–0.6 mm/s, either sign.

Outcomes per run (as ``benchmarks/discrepancy_session.py``'s): ``named`` (the hidden effect named;
for ``none``: nothing detected), ``discovered`` (nothing named, and the open search's first term
has the right factor and form — time, periodic, period within 5 %, on x or every coordinate;
time, polynomial, on the drifting coordinate or every one — and closes the gap), ``unexplained``
(detected; nothing named and nothing right discovered), ``wrong`` (a wrong effect named, or a
wrong term closing the gap), ``missed`` (not detected), ``false_alarm`` (detected in the null case).

    python benchmarks/fast_cabin_discovery.py --seeds 20 --noise 1,3   # ~15 min on 2 cores
    python benchmarks/fast_cabin_discovery.py --quick                  # 2 seeds, default noise
    python benchmarks/fast_cabin_discovery.py --report                 # tabulate the runs logged so far

Writes ``benchmarks/results/fast_cabin_discovery[_quick].{json,md}``; each case's runs are
appended to ``….runs.jsonl`` as they finish and are not run again (an interrupted run resumes).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # NumPy's threads fight XLA's on small machines

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _common import RESULTS, write_results  # noqa: E402

import stewart_jax  # noqa: E402,F401
from stewart_jax.cable_robot import (  # noqa: E402
    cabin_modal_model,
    lumped_free_decay,
    paper_fast_params,
    quasi_static_free_decay,
)
from stewart_jax.cable_robot._cabin_modal import scaled_params  # noqa: E402  (the EA and mass scaling)
from stewart_jax.discrepancy import cabin_record_model  # noqa: E402
from stewart_jax.discrepancy._cabin_record import record_data  # noqa: E402
from stewart_jax.discrepancy._driver import diagnose_many, select_effects, split_rows  # noqa: E402  (batched)

POS = (0.0, 0.0, 140.0)
N = 3
T_S, RATE_HZ, DT_S = 20.0, 5.0, 5e-3
Q0 = np.array([0.02, 0.01, 0.005, *np.deg2rad([0.01, 0.01, 0.02])])
ZETA = 0.005
SIGMA_MM, SIGMA_DEG = 1.0, 0.01
REGISTERED = ("cable_inertia", "cable_stiffness", "cabin_mass", "damping")
MOORDYN = "cable_inertia_moordyn"
MOORDYN_N = 4
UNREGISTERED = ("missing_vibration", "tracker_drift")
OUTCOMES = ("named", "discovered", "unexplained", "wrong", "missed", "false_alarm")


def decays(params, moordyn=True):
    """One time-integrated record per case (the tests' settings)."""
    def qs(p=params, q0=Q0, change=(0.0, 0.0, 0.0)):
        return quasi_static_free_decay(p, POS, T_S, DT_S, displacement=q0, damping_ratio=ZETA, damping_change=change)

    plain = qs()
    return {
        "none": plain,
        "cable_inertia": lumped_free_decay(params, POS, N, T_S, DT_S, displacement=Q0, damping_ratio=ZETA),
        "cable_stiffness": qs(scaled_params(params, 0.85, 1.0)),
        "cabin_mass": qs(scaled_params(params, 1.0, 1.1)),
        "damping": qs(q0=Q0 * np.array([1.0, 1.0, 4.0, 1.0, 1.0, 1.0]), change=(0.0, 0.03, 0.01)),
        "missing_vibration": plain,
        "tracker_drift": plain,
    } | ({MOORDYN: moordyn_record(params)} if moordyn else {})


class Recorded:
    """A noiseless record (``time`` s, ``position_mm``, ``rotation_deg``, as ``CabinRecord``) with
    ``sample`` adding the tracker's white noise, like a simulated decay's."""

    def __init__(self, time_s, position_mm, rotation_deg):
        self.time, self.position_mm, self.rotation_deg = time_s, position_mm, rotation_deg

    def sample(self, rate_hz, *, sigma_mm, sigma_deg, seed):
        from stewart_jax.cable_robot._free_decay import CabinRecord

        rng = np.random.default_rng(seed)
        m = self.time.size
        return CabinRecord(self.time, self.position_mm + sigma_mm * rng.standard_normal((m, 3)),
                           self.rotation_deg + sigma_deg * rng.standard_normal((m, 3)))


def moordyn_record(params) -> Recorded:
    """The cabin's free decay on MoorDyn's lumped-mass cables (see the module docstring)."""
    import jax
    from fast_moordyn import MoorDynRun, _vee

    from stewart_jax.cable_robot import static_equilibrium

    st = jax.jit(static_equilibrium)(params, np.asarray(POS), np.eye(3))
    md = MoorDynRun(POS, np.eye(3), np.asarray(st.s0), MOORDYN_N, 1e-3, "RK4")
    try:
        p0, r0 = md.cabin()
        md.displace(Q0)
        n = int(round(T_S * RATE_HZ))
        pos, rot = np.empty((n + 1, 3)), np.empty((n + 1, 3))
        for k in range(n + 1):
            if k:
                md.md.Step(md.sys, [], [], md.t, 1.0 / RATE_HZ)
                md.t += 1.0 / RATE_HZ
            p, r = md.cabin()
            pos[k] = 1e3 * (p - p0)
            rot[k] = np.rad2deg(_vee(r @ r0.T))  # small rotations: the rotation vector to 1e-8 relative
    finally:
        md.close()
    return Recorded(np.arange(n + 1) / RATE_HZ, pos, rot)


def hide(case: str, t: np.ndarray, pos_mm: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, dict]:
    """The record's positions with an unregistered effect added, and its truth."""
    pos = pos_mm.copy()
    if case == "missing_vibration":
        period = float(rng.uniform(2.5, 6.0))
        pos[:, 0] += 3.0 * np.sin(2 * np.pi * t / period + rng.uniform(0, 2 * np.pi))
        return pos, {"period_s": period, "output": "x"}
    if case == "tracker_drift":
        j = int(rng.integers(3))
        pos[:, j] += rng.choice([-1.0, 1.0]) * rng.uniform(0.3, 0.6) * t
        return pos, {"output": "xyz"[j]}
    return pos, {}


def right_term(case: str, truth: dict, term: dict) -> bool:
    if term["output"] not in (None, truth.get("output")):
        return False
    if case == "missing_vibration":
        return (term["factor"] == "time" and term["form"] == "periodic"
                and abs(term["period"] / truth["period_s"] - 1) < 0.05)
    if case == "tracker_drift":
        return term["factor"] == "time" and term["form"] == "polynomial"
    return False


def outcome(case: str, truth: dict, rep) -> str:
    if case == "none":
        return "false_alarm" if rep.detected else "named"
    case = "cable_inertia" if case == MOORDYN else case
    if not rep.detected:
        return "missed"
    if rep.named_effect is not None:
        return "named" if case in [rep.named_effect, *rep.indistinguishable_from] else "wrong"
    if rep.explained and rep.discovered:
        return "discovered" if right_term(case, truth, rep.discovered[0]) else "wrong"
    return "unexplained"


def run_case(case, decay, modal, noise, seeds, holdout=0.3):
    """Every seed of one case at one noise level, in one batch (one compiled kernel)."""
    trains, tests, truths, model, effects = [], [], [], None, None
    for s in seeds:
        r = decay.sample(RATE_HZ, sigma_mm=SIGMA_MM * noise, sigma_deg=SIGMA_DEG * noise, seed=s)
        pos, truth = hide(case, np.asarray(r.time), np.asarray(r.position_mm), np.random.default_rng([s, 28]))
        data = record_data(r.time, pos, r.rotation_deg)
        if model is None:
            model = cabin_record_model(data, POS, modal=modal, sigma_um=1e3 * SIGMA_MM * noise,
                                       sigma_arcsec=3600 * SIGMA_DEG * noise)
        n = model.n_rows(data)
        tr, te = split_rows(n, holdout, s)
        trains.append(model.take(data, tr))
        tests.append(model.take(data, te))
        truths.append(truth)
    if effects is None:
        effects, _ = select_effects(model, trains[0], model.n_rows(trains[0]))
    reps = diagnose_many(model, effects, trains, tests)
    rows = []
    for s, truth, rep in zip(seeds, truths, reps, strict=True):
        rows.append({
            "noise": noise, "seed": s, "true": case, "outcome": outcome(case, truth, rep), "truth": truth,
            "detected": rep.detected, "named": rep.named_effect, "explained": rep.explained,
            "indistinguishable_from": rep.indistinguishable_from,
            "partial": [{"effect": p["effect"], "gap_share": p["gap_share"]} for p in rep.partial],
            "discovered": [{k: t[k] for k in ("output", "factor", "form", "period", "period_unit", "degree",
                                              "gap_after")} for t in rep.discovered],
            "gap_before": rep.gap_before, "gap_after": rep.gap_after, "noise_floor": rep.noise_floor,
        })
    return rows


def table(rows) -> dict:
    out = {}
    for noise in sorted({r["noise"] for r in rows}):
        for case in ("none", *REGISTERED, MOORDYN, *UNREGISTERED):
            sub = [r for r in rows if r["noise"] == noise and r["true"] == case]
            if sub:
                out[f"{noise:g}x {case}"] = {o: sum(r["outcome"] == o for r in sub) for o in OUTCOMES} | {
                    "runs": len(sub),
                    "gap_before_over_floor": float(np.median([r["gap_before"] / r["noise_floor"] for r in sub])),
                    "gap_after_over_floor": float(np.median([r["gap_after"] / r["noise_floor"] for r in sub])),
                }
    return out


def to_markdown(tab, seconds) -> str:
    lines = ["# Hidden effects in records of the FAST cabin's free vibration", "",
             "Counts over seeds (see the script's docstring). `none`: *named* = correctly nothing detected. Noise "
             f"1x = σ {SIGMA_MM:g} mm and {SIGMA_DEG:g}° per coordinate. Gap: held-out RMS over the noise floor "
             "(median).", "",
             "| noise | hidden effect | runs | named | discovered | unexplained | **wrong** | missed | false alarm "
             "| gap before | gap after |",
             "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for key, v in tab.items():
        noise, case = key.split(" ")
        lines.append(f"| {noise} | {case} | {v['runs']} | " + " | ".join(str(v[o]) for o in OUTCOMES)
                     + f" | {v['gap_before_over_floor']:.2f} | {v['gap_after_over_floor']:.2f} |")
    wrong = sum(v["wrong"] for v in tab.values())
    lines += ["", f"Wrong names or discoveries in all: **{wrong}**."
              + (f" Wall time {seconds:.0f} s (compile included)." if seconds is not None else "")]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="2 seeds at the default noise")
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--noise", default="1,3", help="multiples of the default tracker noise")
    ap.add_argument("--report", action="store_true", help="tabulate the runs logged so far")
    ap.add_argument("--no-moordyn", action="store_true", help="leave out the MoorDyn record (needs `moordyn`)")
    args = ap.parse_args(argv)
    name = "fast_cabin_discovery_quick" if args.quick else "fast_cabin_discovery"
    log = os.path.join(RESULTS, name + ".runs.jsonl")
    seeds = list(range(2 if args.quick else args.seeds))
    noises = [1.0] if args.quick else [float(v) for v in args.noise.split(",")]
    done = []
    if os.path.exists(log):
        with open(log) as f:
            done = [json.loads(line) for line in f if line.strip()]
    t0 = time.perf_counter()
    if not args.report:
        params = paper_fast_params()
        modal = cabin_modal_model(params, POS, N)
        records = decays(params, moordyn=not args.no_moordyn)
        modal_md = None
        for noise in noises:
            for case in records:
                have = {r["seed"] for r in done if r["noise"] == noise and r["true"] == case}
                todo = [s for s in seeds if s not in have]
                if not todo:
                    continue
                t1 = time.perf_counter()
                if case == MOORDYN and modal_md is None:
                    modal_md = cabin_modal_model(params, POS, MOORDYN_N)
                rows = run_case(case, records[case], modal_md if case == MOORDYN else modal, noise, todo)
                with open(log, "a") as f:
                    f.write("".join(json.dumps(r) + "\n" for r in rows))
                    f.flush()
                    os.fsync(f.fileno())
                done += rows
                counts = {o: sum(r["outcome"] == o for r in rows) for o in OUTCOMES}
                print(f"{noise:g}x {case:18s} {counts} ({time.perf_counter() - t1:.0f} s)", flush=True)
    rows = [r for r in done if r["noise"] in noises and r["seed"] in seeds]
    tab = table(rows)
    md = to_markdown(tab, None if args.report else time.perf_counter() - t0)
    write_results(name, {"settings": {"seeds": len(seeds), "noise": noises, "segments": N, "duration_s": T_S,
                                      "rate_hz": RATE_HZ, "sigma_mm": SIGMA_MM, "sigma_deg": SIGMA_DEG,
                                      "holdout": 0.3, "alpha": 0.05},
                         "table": tab, "runs": rows}, md)
    print(md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
