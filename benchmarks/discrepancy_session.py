"""Hidden-effect benchmark of the model-discrepancy workflow on sessions simulated outside the
library (``tests/_numpy_session.py``: an independent NumPy simulator; poses in random order over
about two hours, approach directions from the moves, a drifting temperature), for the 6-UPS
(the Rubin camera hexapod preset), the 6-PSS (Wang et al. 2018, "Improved cuckoo calibration
method of space telescope secondary mirror adjusting mechanism", Infrared and Laser Engineering
47(5): its "actual" mechanism, diagnosed from the nominal one) and the 6-RUS rotary hexapod
(Eisele 2019, "Inverse Kinematics of a Stewart Platform": the ``rotary_stewart`` preset, its
±10 mm / ±5° travel).

Per family and noise level (the default σ = 0.1 µm / 0.1″ and 3×; the model is told σ), per
seed: every registered effect, three effects the registry lacks (struts: a cyclic screw error of
1 µm at a 1 mm lead, a quadratic reading error of 0.5–1 µm at 5 mm, a temperature-dependent
scale of one strut; cranks: a cyclic error of 20 µrad with a 4° period, a quadratic reading error
of 10–20 µrad at 0.25 rad, a temperature-dependent gain of one crank) and the null case.
Outcomes of each run:

- ``named``: the true effect named (or listed as indistinguishable from the named one);
- ``discovered``: no candidate named, and the open search's first term has the right factor and
  form (period within 5 %, the right strut or all struts) and closes the gap;
- ``absorbed``: not detected, and the workflow reports the effect absorbed by the geometry;
- ``unexplained``: detected, nothing named, nothing (right) discovered (partial explanations at most);
- ``wrong``: a wrong effect named, or a wrong term reported as closing the gap;
- ``missed``: not detected; ``false_alarm``: detected in the null case.

    python benchmarks/discrepancy_session.py            # 20 seeds, the three families (~35 min on 2 cores)
    python benchmarks/discrepancy_session.py --families 6-RUS --resume   # add one family to the runs so far
    python benchmarks/discrepancy_session.py --quick    # 2 seeds
    python benchmarks/discrepancy_session.py --resume   # go on with an interrupted run
    python benchmarks/discrepancy_session.py --report   # tabulate the runs recorded so far

Writes ``benchmarks/results/discrepancy_session[_quick].json`` and ``.md``; the runs of each seed
are appended to ``….runs.jsonl`` as they finish.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests"))
sys.path.insert(0, HERE)

from _common import write_results  # noqa: E402
from _numpy_session import REGISTERED, session, unregistered  # noqa: E402

import stewart_jax as sj  # noqa: E402
from stewart_jax import discrepancy as dc  # noqa: E402
from stewart_jax.calibration import make_calibration_data  # noqa: E402
from stewart_jax.discrepancy._driver import diagnose_many, select_effects, split_rows  # noqa: E402  (the batched engine)

OUTCOMES = ("named", "discovered", "absorbed", "unexplained", "wrong", "missed", "false_alarm")


def setup(family: str):
    """Starting mechanism, true geometry arrays, travel half-widths."""
    if family == "6-UPS":
        mech = sj.mechanism.preset("rubin_camera")
        geo = dict(base=mech.base, platform=mech.platform, v0=mech.v0, lengths0=mech.lengths0)
        return mech, geo, sj.calibration.reachable_travel(mech)
    if family == "6-RUS":
        mech = sj.mechanism.preset("rotary_stewart")
        geo = dict(base=mech.base, platform=mech.platform, v0=mech.v0, crank_lengths=mech.crank_lengths,
                   rod_lengths=mech.rod_lengths, azimuth=mech.azimuth, crank_zero=mech.crank_zero)
        return mech, geo, sj.calibration.reachable_travel(mech)
    mech = sj.nominal_geometry()
    a = sj.actual_geometry()
    return mech, dict(upper=a.upper, lower=a.lower, v0=a.v0), np.array([1.0] * 3 + [np.deg2rad(1.0)] * 3)


def right_term(effect: str, truth: dict, term: dict) -> bool:
    """The discovered term has the hidden effect's factor and form (a period in the unit the
    term reports it in: mm for a screw, degrees for a crank)."""
    if effect in ("cyclic_screw", "cyclic_crank"):
        want = truth["period_mm"] if effect == "cyclic_screw" else truth["period_deg"]
        unit = "mm" if effect == "cyclic_screw" else "deg"
        return (term["factor"] == "reading" and term["form"] == "periodic" and term["period_unit"] == unit
                and abs(term["period"] / want - 1) < 0.05)
    if effect == "quadratic_reading":
        return term["factor"] == "reading" and term["form"] == "polynomial" and term["degree"] == 2
    if effect in ("strut_thermal_scale", "crank_thermal_gain"):
        return (term["factor"] == "reading" and term["times"] == "temperature"
                and term["leg"] in (None, truth["leg"] + 1))
    return False


def outcome(effect, truth, rep) -> str:
    if effect is None:
        return "false_alarm" if rep.detected else "named"
    if not rep.detected:
        return "absorbed" if effect in rep.absorbed_by else "missed"
    if rep.named_effect is not None:
        return "named" if effect in [rep.named_effect, *rep.indistinguishable_from] else "wrong"
    if rep.explained and rep.discovered:
        return "discovered" if right_term(effect, truth, rep.discovered[0]) else "wrong"
    return "unexplained"


def run_seed(family: str, noise: float, s: int, alpha: float, n_poses: int):
    """The rows of one seed: every case of ``family`` at ``noise``, diagnosed in one batch."""
    mech, geo, half = setup(family)
    model = dc.model_for(mech, 0.1 * noise, 0.1 * noise)
    cases = [None, *REGISTERED[family], *unregistered(family)]
    trains, tests, meta = [], [], []
    for c, eff in enumerate(cases):
        rng = np.random.default_rng([s, c, int(noise * 10), len(family)])
        ses = session(family, geo, eff, rng, half=half, n=n_poses, sigma_um=0.1 * noise,
                      sigma_arcsec=0.1 * noise)
        data = make_calibration_data(ses.readings, ses.poses, ses.directions, ses.temperature, ses.time)
        tr, te = split_rows(n_poses, 0.3, s)
        trains.append(data.take(tr))
        tests.append(data.take(te))
        meta.append((s, eff, ses.truth))
    effects, _ = select_effects(model, trains[0], len(trains[0].readings))
    reps = diagnose_many(model, effects, trains, tests, alpha=alpha)  # one batch per seed: one compile
    u = "um" if model.report_unit == "µm" else "urad"  # the gaps' unit: µm for struts, µrad for cranks
    rows = []
    for (s, eff, truth), rep in zip(meta, reps, strict=True):
        rows.append({
            "family": family, "noise": noise, "seed": s, "true": eff or "none",
            "outcome": outcome(eff, truth, rep), "detected": rep.detected, "named": rep.named_effect,
            "indistinguishable_from": rep.indistinguishable_from, "explained": rep.explained,
            "partial": [{"effect": p["effect"], "gap_share": p["gap_share"]} for p in rep.partial],
            "discovered": [{k: t[k] for k in ("leg", "factor", "form", "period", "period_unit", "degree", "times",
                                              "gap_after")}
                           for t in rep.discovered],
            f"gap_before_{u}": rep.gap_before, f"gap_after_{u}": rep.gap_after, f"noise_floor_{u}": rep.noise_floor,
            "truth_leg": truth.get("leg"),
            "truth_period_mm": truth.get("period_mm"),
            "truth_period_deg": truth.get("period_deg"),
            "named_p_heldout": next((c.heldout_p for c in rep.ranking if c.effect == rep.named_effect), None),
            "notes": rep.notes,
        })
    return rows


def run(family: str, noise: float, seeds, alpha: float, n_poses: int, log: str | None = None):
    """Rows of every seed; with ``log`` (a JSON-lines file) each seed's rows are appended as soon
    as they exist and seeds already there are read back, not re-run (an interrupted run resumes)."""
    done: dict[int, list] = {}
    if log and os.path.exists(log):
        with open(log) as f:
            for line in f:
                r = json.loads(line)
                if r["family"] == family and r["noise"] == noise:
                    done.setdefault(r["seed"], []).append(r)
    rows = []
    for s in seeds:
        if s in done:
            rows += done[s]
            continue
        new = run_seed(family, noise, s, alpha, n_poses)
        if log:
            with open(log, "a") as f:
                f.write("".join(json.dumps(r) + "\n" for r in new))
                f.flush()
                os.fsync(f.fileno())
        rows += new
    return rows


def _over_floor(r: dict, which: str) -> float:
    """A row's held-out gap (``which``: ``before``, ``after``) over its noise floor (µm or µrad)."""
    u = "um" if "noise_floor_um" in r else "urad"
    return r[f"gap_{which}_{u}"] / r[f"noise_floor_{u}"]


def table(rows) -> dict:
    out = {}
    for fam in sorted({r["family"] for r in rows}):
        for noise in sorted({r["noise"] for r in rows}):
            for eff in dict.fromkeys(r["true"] for r in rows if r["family"] == fam):
                sub = [r for r in rows if r["family"] == fam and r["noise"] == noise and r["true"] == eff]
                if sub:
                    out[f"{fam} {noise:g}x {eff}"] = {o: sum(r["outcome"] == o for r in sub) for o in OUTCOMES} | {
                        "runs": len(sub),
                        "median_gap_before_over_floor": float(np.median([_over_floor(r, "before") for r in sub])),
                        "median_gap_after_over_floor": float(np.median([_over_floor(r, "after") for r in sub])),
                    }
    return out


def to_markdown(tab: dict, seconds: float | None) -> str:
    lines = ["# Hidden effects in independently simulated sessions", "",
             "Counts over seeds (see the script's docstring for the outcomes). Null case: `named` = "
             "correctly nothing detected. Gap = held-out reading-residual RMS over the noise floor (median).", "",
             "| family | noise | hidden effect | runs | named | discovered | absorbed | unexplained | **wrong** | "
             "missed | false alarm | gap before | gap after |",
             "| --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for key, v in tab.items():
        fam, noise, eff = key.split(" ")
        lines.append(f"| {fam} | {noise} | {eff} | {v['runs']} | " + " | ".join(
            str(v[o]) for o in OUTCOMES) + f" | {v['median_gap_before_over_floor']:.2f} | "
            f"{v['median_gap_after_over_floor']:.2f} |")
    wrong = sum(v["wrong"] for v in tab.values())
    timing = (f"Wall time {seconds:.0f} s (compile included)." if seconds is not None
              else "Tabulated from the runs recorded so far (`--report`; runs per row as listed).")
    lines += ["", f"Wrong namings in all: **{wrong}**. {timing}"]
    return "\n".join(lines) + "\n"


def report(name: str, log: str, args) -> int:
    """The table of the runs recorded in ``log`` (an unfinished run: seeds per row may differ)."""
    families, noises = args.families.split(","), [float(x) for x in args.noise.split(",")]
    with open(log) as f:
        rows = [r for r in map(json.loads, f) if r["family"] in families and r["noise"] in noises]
    seeds = {f"{fam} {noise:g}x": len({r["seed"] for r in rows if r["family"] == fam and r["noise"] == noise})
             for fam in families for noise in noises}
    tab = table(rows)
    payload = {"settings": {"seeds": seeds, "families": args.families, "noise": args.noise, "poses": args.poses,
                            "alpha": args.alpha, "holdout": 0.3}, "seconds": None, "table": tab, "runs": rows}
    md = to_markdown(tab, None)
    write_results(name, payload, md)
    print(md)
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="2 seeds")
    ap.add_argument("--seeds", type=int, help="seeds per case (default 20)")
    ap.add_argument("--families", default="6-UPS,6-PSS,6-RUS")
    ap.add_argument("--noise", default="1,3", help="noise levels, multiples of 0.1 µm / 0.1″")
    ap.add_argument("--poses", type=int, default=180)
    ap.add_argument("--alpha", type=float, default=0.05)
    ap.add_argument("--resume", action="store_true",
                    help="keep the seeds already in results/NAME.runs.jsonl (an interrupted run)")
    ap.add_argument("--report", action="store_true",
                    help="run nothing: tabulate the runs recorded so far in results/NAME.runs.jsonl")
    args = ap.parse_args(argv)
    n = args.seeds or (2 if args.quick else 20)
    name = "discrepancy_session_quick" if args.quick else "discrepancy_session"
    log = os.path.join(HERE, "results", f"{name}.runs.jsonl")
    if args.report:
        return report(name, log, args)
    if not args.resume and os.path.exists(log):
        os.remove(log)
    t0 = time.perf_counter()
    rows = []
    for fam in args.families.split(","):
        for noise in (float(x) for x in args.noise.split(",")):
            g = run(fam, noise, range(n), args.alpha, args.poses, log)
            rows += g
            print(f"{fam} {noise:g}x: " + str({o: sum(r["outcome"] == o for r in g) for o in OUTCOMES})
                  + f" ({time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True)
    tab = table(rows)
    seconds = time.perf_counter() - t0
    payload = {"settings": {"seeds": n, "families": args.families, "noise": args.noise, "poses": args.poses,
                            "alpha": args.alpha, "holdout": 0.3}, "seconds": seconds, "table": tab, "runs": rows}
    md = to_markdown(tab, seconds)
    write_results(name, payload, md)
    print(md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
