"""FAST's cabin on cables with mass: the lumped-mass cables (MoorDyn's discretisation, Hall &
Goupee 2015) against the quasi-static elastic catenaries of Yin J., Jiang P., Chen M., Yao R.,
*Dynamic modeling of a cable-driven parallel robot with a Stewart platform for use in FAST*.

- statics: convergence of the lumped statics to the catenary's with N (cabin sag, anchor
  tensions, nodes), and its observed order;
- modes at the paper's four positions: the cabin-dominant mode of each coordinate on lumped
  cables beside the quasi-static cabin modes, against the lowest cabin–cable mode measured on
  FAST, 0.12–0.2 Hz (Li, Sun, Li, Yao, *Universe* 10(12):450, 2024);
- the focal-surface map of the lowest cabin-dominant frequency with cable inertia (same
  positions and attitudes as ``fast_modes.py``), against that band;
- time: statics + every mode at one position, N = 40, after compilation.

- Yin et al.'s §6 scenario (5 Hz, 10 mm platform motion, 2 s, 1 ms) at the four positions of
  Table 2 with quasi-static and with lumped cables side by side (level cabin where feasible,
  else the smallest feasible tilt, as ``fast_modes.py``).

The comparison with MoorDyn itself (statics, modes from free decays, speed) is ``fast_moordyn.py``.

Usage: ``.venv/bin/python benchmarks/fast_cable_dynamics.py [--quick] [--segments N]`` (the
committed results: ``--segments 10``). Writes
``benchmarks/results/fast_cable_dynamics.{json,md}`` and ``fast_cable_dynamics_map.png`` there.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import matplotlib  # noqa: E402

matplotlib.use("Agg")  # this script only writes files
import numpy as np  # noqa: E402
from _common import RESULTS, write_results  # noqa: E402

import stewart_jax  # noqa: E402, F401
from stewart_jax import plotting  # noqa: E402
from stewart_jax.cable_robot import (  # noqa: E402
    PAPER_POSITIONS,
    PAPER_TABLE2,
    cabin_modes,
    focal_surface_point,
    lumped_low_modes,
    lumped_modes,
    modal_summary,
    paper_fast_params,
    run_scenario,
    smallest_feasible_tilt,
    solve_attitude,
    static_equilibrium,
    workspace_map,
)
from stewart_jax.cable_robot._lumped import catenary_nodes  # noqa: E402
from stewart_jax.cable_robot._lumped_low import _low_prepare_jit  # noqa: E402
from stewart_jax.cable_robot._lumped_scenario import lumped_scenario  # noqa: E402

static_equilibrium_jit, cabin_modes_jit = jax.jit(static_equilibrium), jax.jit(cabin_modes)
run_scenario_jit = jax.jit(run_scenario, static_argnames=("duration", "dt", "start", "method"))

PARAMS = paper_fast_params()
BAND_HZ = (0.12, 0.2)


def convergence(position, segments):
    pos = jnp.asarray(position, jnp.float64)
    st = static_equilibrium_jit(PARAMS, pos, jnp.eye(3))
    F = np.asarray(st.force)
    rows = []
    for n in segments:
        m = lumped_modes(PARAMS, pos, n, static=st)
        s = m.statics
        nodes = np.asarray(catenary_nodes(PARAMS, pos, jnp.eye(3), st, n))
        rows.append({
            "segments": n,
            "cabin_offset_mm": float(np.linalg.norm(np.asarray(s.q[:3])) * 1e3),
            "anchor_force_error_n": float(np.max(np.abs(np.asarray(s.anchor_force_n) + F))),
            "node_error_mm": float(np.max(np.abs(np.asarray(s.nodes[:, 1:-1]) - nodes)) * 1e3),
            "lowest_cabin_dominant_hz": min(v[1] for v in modal_summary(m).dominant.values()),
        })
    for a, b in zip(rows[:-1], rows[1:], strict=True):
        ratio = b["segments"] / a["segments"]
        b["observed_order"] = {k: float(np.log(a[k] / b[k]) / np.log(ratio))
                               for k in ("cabin_offset_mm", "anchor_force_error_n", "node_error_mm")}
    return rows


def four_positions(n):
    rows = []
    for p in PAPER_POSITIONS:
        pos = jnp.asarray(p, jnp.float64)
        st = static_equilibrium_jit(PARAMS, pos, jnp.eye(3))
        qs = cabin_modes_jit(PARAMS, pos, jnp.eye(3), st)
        try:
            m = lumped_low_modes(PARAMS, pos, n, 1.5, static=st)
        except ValueError as err:
            rows.append({"position_m": list(p), "quasi_static_hz": np.asarray(qs.frequencies_hz).tolist(),
                         "lumped": str(err)})
            continue
        s = modal_summary(m, cutoff_hz=1.5)
        rows.append({
            "position_m": list(p),
            "quasi_static_hz": np.asarray(qs.frequencies_hz).tolist(),
            "lumped_dominant": {k: {"frequency_hz": f, "compliance_share": sh} for k, (_, f, sh) in s.dominant.items()},
            "lumped_modes_below_1p5_hz": len(s.frequencies_hz),
            "lumped_string_modes_below_1p5_hz": s.kind.count("string"),
            "lowest_cabin_mode_hz": float(s.frequencies_hz[np.asarray(s.kind) == "cabin"][0]),
        })
    return rows


def table2(n, duration=2.0, dt=1e-3):
    rows = []
    for p in PAPER_POSITIONS:
        sol = solve_attitude(PARAMS, np.asarray(p), "level")
        if not bool(sol.statics.feasible):
            sol = solve_attitude(PARAMS, np.asarray(p), "smallest-tilt")
        R = jnp.asarray(sol.R)
        qs = run_scenario_jit(PARAMS, jnp.asarray(p), duration=duration, dt=dt, attitude=R)
        row = {"position_m": list(p), "attitude": sol.kind, "tilt_deg": float(np.rad2deg(sol.tilt_rad)),
               "paper": PAPER_TABLE2[tuple(p)],
               "quasi_static": {"std_m": np.asarray(qs.std).tolist(), "amplitude_m": np.asarray(qs.amplitude).tolist()}}
        try:
            lm = lumped_scenario(PARAMS, p, n, duration=duration, dt=dt, attitude=R)
            row["lumped"] = {"std_m": np.asarray(lm.std).tolist(), "amplitude_m": np.asarray(lm.amplitude).tolist(),
                             "correlation": np.asarray(lm.correlation).tolist()}
        except ValueError as err:
            row["lumped"] = str(err)
        rows.append(row)
    return rows


def focal_map(n, n_zenith, n_azimuth, max_zenith_deg):
    t_map, c_map, load_start = time.perf_counter(), time.process_time(), os.getloadavg()[0]
    zen = np.deg2rad(np.linspace(0.0, max_zenith_deg, n_zenith))
    az = np.linspace(0.0, 2 * np.pi, n_azimuth, endpoint=False)
    pts = [(0.0, 0.0)] + [(z, a) for z in zen[1:] for a in az]
    pos = np.asarray(focal_surface_point(np.array([p[0] for p in pts]), np.array([p[1] for p in pts])))
    level = workspace_map(PARAMS, pos)
    feas = np.asarray(level.feasible).copy()
    Rs = np.broadcast_to(np.eye(3), (len(pos), 3, 3)).copy()
    for i in np.flatnonzero(~feas):
        sol = smallest_feasible_tilt(PARAMS, pos[i], n_axes=12, n_fan=4, tol=1e-4)
        if sol.found:
            feas[i], Rs[i] = True, np.asarray(sol.R)
    att = workspace_map(PARAMS, pos, Rs)
    attitudes_s, attitudes_cpu_s = time.perf_counter() - t_map, time.process_time() - c_map
    qs1 = np.full(len(pos), np.nan)
    f_dom = np.full(len(pos), np.nan)
    f_cab = np.full(len(pos), np.nan)
    failed = []
    methods = {}
    residual = 0.0
    raised = 0
    idx = np.flatnonzero(feas)
    statics = [jax.tree.map(lambda a, i=i: a[i], att.static) for i in idx]
    for k, i in enumerate(idx):
        qs1[i] = float(cabin_modes_jit(PARAMS, jnp.asarray(pos[i]), jnp.asarray(Rs[i]), statics[k]).frequencies_hz[0])
    # the lumped part: statics + modes below 1.5 Hz + the summary, every feasible position;
    # the first call compiles (timed apart)
    t0, c0 = time.perf_counter(), time.process_time()
    compile_s = None
    for k, i in enumerate(idx):
        try:
            m = lumped_low_modes(PARAMS, pos[i], n, 1.5, jnp.asarray(Rs[i]), statics[k])
        except ValueError as err:
            failed.append({"position_m": pos[i].tolist(), "error": str(err)})
            continue
        finally:
            if compile_s is None:
                compile_s = time.perf_counter() - t0
                t0, c0 = time.perf_counter(), time.process_time()
        methods[m.method] = methods.get(m.method, 0) + 1
        residual = max(residual, float(m.residual))
        raised += m.cutoff_hz > 1.5
        s = modal_summary(m, cutoff_hz=1.5)
        f_dom[i] = min(v[1] for v in s.dominant.values())
        f_cab[i] = float(s.frequencies_hz[np.asarray(s.kind) == "cabin"][0])
    lumped_s, lumped_cpu_s = time.perf_counter() - t0, time.process_time() - c0
    ok = np.isfinite(f_dom)
    lo, hi = BAND_HZ
    return {
        "segments": n, "positions_m": pos.tolist(), "feasible": feas.tolist(),
        "quasi_static_first_hz": qs1.tolist(), "lumped_lowest_dominant_hz": f_dom.tolist(),
        "lumped_lowest_cabin_mode_hz": f_cab.tolist(), "failed": failed,
        "counts": {"positions": len(pos), "feasible": int(feas.sum()), "solved": int(ok.sum()),
                   "dominant_in_band": int(np.sum((f_dom[ok] >= lo) & (f_dom[ok] <= hi))),
                   "dominant_below_band": int(np.sum(f_dom[ok] < lo)),
                   "dominant_above_band": int(np.sum(f_dom[ok] > hi)),
                   "quasi_static_in_band": int(np.sum((qs1[ok] >= lo) & (qs1[ok] <= hi)))},
        "range_hz": {"lumped_dominant": [float(np.nanmin(f_dom)), float(np.nanmax(f_dom))],
                     "quasi_static": [float(np.nanmin(qs1[ok])), float(np.nanmax(qs1[ok]))]},
        "modes_method": methods, "largest_mode_residual": residual, "cutoff_raised_positions": int(raised),
        "timing": {"lumped_compile_plus_first_s": compile_s, "lumped_positions_after_first": int(len(idx) - 1),
                   "lumped_wall_s": lumped_s, "lumped_cpu_s": lumped_cpu_s,
                   "lumped_wall_s_per_position": lumped_s / max(len(idx) - 1, 1),
                   "attitudes_and_catenary_statics_s": attitudes_s,
                   "attitudes_and_catenary_statics_cpu_s": attitudes_cpu_s,
                   "whole_map_s": time.perf_counter() - t_map, "whole_map_cpu_s": time.process_time() - c_map,
                   "load_average_1min_start_end": [load_start, os.getloadavg()[0]]},
    }


def _timed(f, repeats):
    # best and median wall-clock and CPU (process) time of `repeats` calls, in s
    wall, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        jax.block_until_ready(f())
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return {"best_s": min(wall), "median_s": float(np.median(wall)), "cpu_best_s": min(cpu),
            "cpu_median_s": float(np.median(cpu))}


REPEATS = 15


def speed(segments=(10, 20, 40), repeats=REPEATS, dense_repeats=3):
    """Statics + modes at one position (30, 0, 142.8) m: the banded route below 1.5 Hz (with its
    parts) and the dense route (every mode), compile time apart."""
    import scipy.linalg

    pos = jnp.asarray(PAPER_POSITIONS[1], jnp.float64)
    R = jnp.eye(3)
    st = static_equilibrium_jit(PARAMS, pos, R)
    rows = []
    for n in segments:
        row = {"segments": n, "degrees_of_freedom": 6 + 18 * (n - 1), "load_average_1min": os.getloadavg()[0]}
        t0 = time.perf_counter()
        m = lumped_low_modes(PARAMS, pos, n, 1.5, static=st)
        row["banded_compile_plus_first_s"] = time.perf_counter() - t0
        row["banded_modes"] = int(m.frequencies_hz.shape[0])
        row["banded_method"] = m.method
        row["banded"] = _timed(lambda n=n: lumped_low_modes(PARAMS, pos, n, 1.5, static=st).shapes, repeats)
        prep = _low_prepare_jit(PARAMS, pos, R, st, n)
        row["banded_statics_and_blocks"] = _timed(lambda n=n: _low_prepare_jit(PARAMS, pos, R, st, n),
                                                  repeats)
        band = np.asarray(prep.band)
        row["banded_eigenvalues"] = _timed(lambda band=band: scipy.linalg.eigvals_banded(band, lower=False), repeats)
        t0 = time.perf_counter()
        d = lumped_modes(PARAMS, pos, n, static=st)
        row["dense_compile_plus_first_s"] = time.perf_counter() - t0
        row["dense_modes"] = int(d.frequencies_hz.shape[0])
        row["dense"] = _timed(lambda n=n: lumped_modes(PARAMS, pos, n, static=st).shapes, dense_repeats)
        k = row["banded_modes"]
        row["banded_vs_dense_frequency_max_rel"] = float(np.max(np.abs(
            np.asarray(m.frequencies_hz) - np.asarray(d.frequencies_hz[:k])) / np.asarray(d.frequencies_hz[:k])))
        rows.append(row)
        print(f"speed N={n}: banded best {row['banded']['best_s'] * 1e3:.1f} ms (cpu "
              f"{row['banded']['cpu_best_s'] * 1e3:.1f}), dense best {row['dense']['best_s'] * 1e3:.0f} ms", flush=True)
    return rows


def _table2_md(rows, n):
    lines = ["", f"## Yin et al. §6 (Table 2) with quasi-static and with lumped cables (N = {n})", "",
             "Std of (extra error − cabin displacement) and amplitude max |extra error| per axis, mm; "
             "2 s at 1 ms, momentum start, no damping.", "",
             "| position (m) | attitude | axis | paper std | paper amp | quasi-static std | quasi-static amp "
             "| lumped std | lumped amp |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        for k, ax in enumerate("xyz"):
            ps, pa = r["paper"][ax]
            q = r["quasi_static"]
            cells = [f"{ps * 1e3:.4f}", f"{pa * 1e3:.4f}", f"{q['std_m'][k] * 1e3:.4f}",
                     f"{q['amplitude_m'][k] * 1e3:.4f}"]
            if isinstance(r["lumped"], str):
                cells += ["—", "—"]
            else:
                cells += [f"{r['lumped']['std_m'][k] * 1e3:.4f}", f"{r['lumped']['amplitude_m'][k] * 1e3:.4f}"]
            att = f"{r['attitude']} ({r['tilt_deg']:.2f}°)" if k == 0 else ""
            lines.append(f"| {r['position_m'] if k == 0 else ''} | {att} | {ax} | " + " | ".join(cells) + " |")
    return lines


def _verdict(wall_s, cpu_s, limit_s):
    if wall_s < limit_s:
        return "**met**"
    return "**met in CPU time, missed in wall-clock time**" if cpu_s < limit_s else "**missed**"


def _targets_md(fmap, sp):
    # the speed targets of the lumped cables that this benchmark measures (the time domain's
    # against MoorDyn is in fast_moordyn.md)
    out = []
    row = next((r for r in sp or [] if r["segments"] == 40), None)
    if row is not None:
        b = row["banded"]
        out.append(f"- Modes at one position, N = 40, under 50 ms after compilation: "
                   f"{_verdict(b['best_s'], b['cpu_best_s'], 0.05)} (best of {REPEATS}) — `lumped_low_modes` best "
                   f"{b['best_s'] * 1e3:.1f} ms wall (median {b['median_s'] * 1e3:.1f} ms), "
                   f"{b['cpu_best_s'] * 1e3:.1f} ms CPU (median {b['cpu_median_s'] * 1e3:.1f} ms), load "
                   f"{row['load_average_1min']:.1f} on 2 cores; the dense route {row['dense']['best_s'] * 1e3:.0f} ms.")
    if fmap is not None and "whole_map_cpu_s" in fmap["timing"]:
        tm = fmap["timing"]
        out.append(f"- The {fmap['counts']['feasible']}-position map with cable inertia (N = {fmap['segments']}: "
                   "lumped statics, modes below the cut-off and their summary at every feasible position) under "
                   f"a minute on 2 cores, after compilation: {_verdict(tm['lumped_wall_s'], tm['lumped_cpu_s'], 60.0)}"
                   f" — {tm['lumped_wall_s']:.1f} s wall, {tm['lumped_cpu_s']:.1f} s CPU (compilation "
                   f"{tm['lumped_compile_plus_first_s']:.1f} s apart). The whole map from scratch — the "
                   "quasi-static map's attitudes (smallest-tilt searches) and catenary statics, every compilation "
                   f"included — {tm['whole_map_s']:.1f} s wall, {tm['whole_map_cpu_s']:.1f} s CPU; load average "
                   + " → ".join(f"{v:.1f}" for v in tm["load_average_1min_start_end"]) + ".")
    return ["", "## Speed targets", ""] + out if out else []


def markdown(conv, four, fmap, sp, t2=None, n=None):
    lines = ["# FAST cabin on lumped-mass cables"]
    if conv:
        lines += ["", "## Statics: convergence to the elastic catenary (position (30, 0, 142.8) m, level)", "",
                  "| N | cabin offset (mm) | anchor force error (N) | node error (mm) | order (offset, force, "
                  "nodes) | lowest cabin-dominant mode (Hz) |", "|---|---|---|---|---|---|"]
    for r in conv:
        o = r.get("observed_order")
        o = ", ".join(f"{v:.2f}" for v in o.values()) if o else "—"
        lines.append(f"| {r['segments']} | {r['cabin_offset_mm']:.3f} | {r['anchor_force_error_n']:.2f} | "
                     f"{r['node_error_mm']:.3f} | {o} | {r['lowest_cabin_dominant_hz']:.4f} |")
    if four:
        lines += ["", f"## Modes at the paper's four positions (level cabin, N = {n})", "",
                  "Quasi-static: the six cabin modes of Yin et al.'s cables. Lumped: the cabin-dominant mode "
                  "of each coordinate (largest share of its static compliance), Hz (share).", "",
                  "| position (m) | quasi-static (Hz) | swing x | swing y | heave | roll | pitch | yaw "
                  "| lowest cabin mode |",
                  "|---|---|---|---|---|---|---|---|---|"]
    for r in four:
        qs = ", ".join(f"{f:.3f}" for f in r["quasi_static_hz"])
        if isinstance(r["lumped"] if "lumped" in r else None, str):
            lines.append(f"| {r['position_m']} | {qs} | {r['lumped']} |")
            continue
        d = r["lumped_dominant"]
        cells = " | ".join(f"{d[k]['frequency_hz']:.3f} ({d[k]['compliance_share']:.2f})"
                           for k in ("swing_x", "swing_y", "heave", "roll", "pitch", "yaw"))
        lines.append(f"| {r['position_m']} | {qs} | {cells} | {r['lowest_cabin_mode_hz']:.3f} |")
    if t2 is not None:
        lines += _table2_md(t2, n)
    if fmap is not None:
        c, rg, tm = fmap["counts"], fmap["range_hz"], fmap["timing"]
        lines += ["", f"## Focal-surface map (N = {fmap['segments']}) against the measured 0.12–0.2 Hz", "",
                  f"{c['positions']} positions, {c['feasible']} with a feasible attitude, {c['solved']} solved. "
                  f"Lowest cabin-dominant frequency with cable inertia: {rg['lumped_dominant'][0]:.3f}–"
                  f"{rg['lumped_dominant'][1]:.3f} Hz ({c['dominant_in_band']} in the band, "
                  f"{c['dominant_below_band']} below, {c['dominant_above_band']} above); quasi-static cables: "
                  f"{rg['quasi_static'][0]:.3f}–{rg['quasi_static'][1]:.3f} Hz ({c['quasi_static_in_band']} in "
                  "the band).", "",
                  f"Modes below 1.5 Hz by `lumped_low_modes` ({fmap['modes_method']}; largest mode residual "
                  f"{fmap['largest_mode_residual']:.1e}; the cut-off raised at {fmap['cutoff_raised_positions']} "
                  "positions to name every coordinate's dominant mode). Time for the lumped statics + modes + "
                  f"summary of all {c['feasible']} positions: compile + first position "
                  f"{tm['lumped_compile_plus_first_s']:.1f} s, then {tm['lumped_wall_s']:.1f} s wall "
                  f"({tm['lumped_wall_s_per_position'] * 1e3:.1f} ms per position; {tm['lumped_cpu_s']:.1f} s CPU); "
                  f"the attitudes (smallest-tilt searches) and catenary statics before it "
                  f"{tm['attitudes_and_catenary_statics_s']:.1f} s wall" + (
                      f" ({tm['attitudes_and_catenary_statics_cpu_s']:.1f} s CPU)"
                      if "attitudes_and_catenary_statics_cpu_s" in tm else "")
                  + f"; the whole map {tm['whole_map_s']:.1f} s wall" + (
                      f" ({tm['whole_map_cpu_s']:.1f} s CPU), load average "
                      + " → ".join(f"{v:.1f}" for v in tm["load_average_1min_start_end"])
                      if "whole_map_cpu_s" in tm else "") + "."]
    if sp:
        lines += ["", "## Speed: statics + modes at one position (30, 0, 142.8) m, after compilation", "",
                  "Banded: `lumped_low_modes` (every mode below 1.5 Hz, its shares); dense: `lumped_modes` "
                  "(every mode). Best / median wall-clock time of repeated calls, and the best CPU (process) "
                  "time; the machine's load average at the start of each row.", "",
                  "| N | DOF | modes < 1.5 Hz | banded best / median (ms) | banded CPU (ms) | of which statics "
                  "+ blocks / eigenvalues (ms) | banded compile + first (s) | dense best (ms) | dense compile "
                  "+ first (s) | load |", "|---|---|---|---|---|---|---|---|---|---|"]
        for r in sp:
            b = r["banded"]
            lines.append(
                f"| {r['segments']} | {r['degrees_of_freedom']} | {r['banded_modes']} | "
                f"{b['best_s'] * 1e3:.1f} / {b['median_s'] * 1e3:.1f} | {b['cpu_best_s'] * 1e3:.1f} | "
                f"{r['banded_statics_and_blocks']['best_s'] * 1e3:.1f} / {r['banded_eigenvalues']['best_s'] * 1e3:.1f}"
                f" | {r['banded_compile_plus_first_s']:.1f} | {r['dense']['best_s'] * 1e3:.0f} | "
                f"{r['dense_compile_plus_first_s']:.1f} | {r['load_average_1min']:.1f} |")
        lines += ["", "Banded and dense frequencies agree to "
                  f"{max(r['banded_vs_dense_frequency_max_rel'] for r in sp):.1e} (relative, largest)."]
    lines += _targets_md(fmap, sp)
    return "\n".join(lines)


def main(argv=None):
    import scipy

    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="a coarse map and fewer N")
    ap.add_argument("--segments", type=int, default=20, help="N for the four positions and the map")
    ap.add_argument("--only", choices=("speed", "map"), help="run only this part (written to fast_cable_dynamics_"
                    "<part>.{json,md}, leaving the full results alone)")
    args = ap.parse_args(argv)
    segs = (5, 10, 20) if args.quick else (5, 10, 20, 40)
    grid = (4, 6, 60.0) if args.quick else (15, 24, 70.0)
    name = "fast_cable_dynamics_quick" if args.quick else "fast_cable_dynamics"
    if args.only:
        name = f"{name}_{args.only}"
    versions = {"scipy": scipy.__version__}
    res = {"band_hz": BAND_HZ, "versions": versions}
    conv = four = t2 = fmap = sp = None

    def save():   # after every part, so that an interruption loses little
        md = markdown(conv or [], four or [], fmap, sp, t2, args.segments)
        write_results(name, res, md)
        return md

    if args.only in (None, "speed"):
        sp = res["speed"] = speed((10, 20) if args.quick else (10, 20, 40))
        save()
    if args.only is None:
        conv = res["convergence"] = convergence(PAPER_POSITIONS[1], segs)
        four = res["four_positions"] = four_positions(args.segments)
        save()
        t2 = res["table2"] = table2(args.segments, duration=0.4 if args.quick else 2.0)
        save()
    if args.only in (None, "map"):
        fmap = res["map"] = focal_map(args.segments, *grid)
        save()
        pos = np.asarray(fmap["positions_m"])
        f = np.asarray(fmap["lumped_lowest_dominant_hz"], float)
        plotting.show(plotting.plot_fast_focal_map(
            pos, f, feasible=fmap["feasible"], label="lowest cabin-dominant frequency (Hz)",
            title=f"With cable inertia (N = {fmap['segments']}); measured 0.12–0.2 Hz", cmap="coolwarm"),
            Path(RESULTS) / f"{name}_map.png")
        band = np.where(np.isfinite(f), np.where(f < BAND_HZ[0], -1.0, np.where(f > BAND_HZ[1], 1.0, 0.0)), np.nan)
        plotting.show(plotting.plot_fast_focal_map(
            pos, band, feasible=fmap["feasible"], label="−1 below, 0 inside, +1 above 0.12–0.2 Hz",
            title="Lowest cabin-dominant mode against the measured band", cmap="coolwarm"),
            Path(RESULTS) / f"{name}_band.png")
    print(save())


if __name__ == "__main__":
    main()
