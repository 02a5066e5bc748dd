"""FAST feed support beyond Yin J., Jiang P., Chen M., Yao R., *Dynamic modeling of a
cable-driven parallel robot with a Stewart platform for use in FAST*: Table 2 at the paper's
four positions with the cabin attitude stated, the cabin's natural frequencies and mode shapes
there (cross-checked against the FFT of a released cabin in the coupled simulation), the cables'
own string frequencies, maps of the tension-feasible workspace and of the first frequency over
the focal surface, and the time per position of stiffness + modes batched over a map.

Usage: ``.venv/bin/python benchmarks/fast_modes.py [--quick]``. Writes
``benchmarks/results/fast_modes.{json,md}`` and figures ``fast_modes_*.png`` there.
"""

from __future__ import annotations

import argparse
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
    cable_string_modes,
    focal_surface_point,
    modes_map,
    paper_fast_params,
    run_scenario,
    smallest_feasible_tilt,
    solve_attitude,
    static_equilibrium,
    workspace_map,
)

# Private building blocks: the attitude names, the cables' own inertia and the eigen-solve (the
# mass-matrix variant), and the coupled integrator with its state (the released cabin's FFT).
from stewart_jax.cable_robot._attitude import ATTITUDES  # noqa: E402
from stewart_jax.cable_robot._coupled import CabinState, matrix_to_quat, simulate  # noqa: E402
from stewart_jax.cable_robot._modes import cable_inertia_matrix, modes_from_matrices  # noqa: E402
from stewart_jax.cable_robot._scenario import rotation_vector  # noqa: E402
from stewart_jax.cable_robot._system import static_lower_motion  # noqa: E402

static_equilibrium_jit, cabin_modes_jit = jax.jit(static_equilibrium), jax.jit(cabin_modes)
run_scenario_jit = jax.jit(run_scenario, static_argnames=("duration", "dt", "start", "method"))

PARAMS = paper_fast_params()
FREE_DT, FREE_STEPS = 0.02, 3000  # 60 s of free response


@jax.jit
def _free_response(state, s0, force):
    return simulate(PARAMS, s0, state, force, lambda t: static_lower_motion(PARAMS.h), FREE_DT,
                    FREE_STEPS)


def fft_lowest(modes, position, R):
    """Lowest frequency from the FFT of the cabin released 5 mm along its first mode."""
    phi = np.asarray(modes.shapes[:, 0])
    q0 = phi * 5e-3 / np.abs(phi[:3]).max()
    R0 = np.asarray(jax.scipy.linalg.expm(jnp.asarray(_skew(q0[3:])))) @ np.asarray(R)
    state = CabinState(jnp.asarray(position + q0[:3]), matrix_to_quat(jnp.asarray(R0)), jnp.zeros(3),
                       jnp.zeros(3))
    traj = _free_response(state, modes.static.s0, modes.static.force)
    rel = np.einsum("nij,kj->nik", np.asarray(traj.R), np.asarray(R))
    q = np.concatenate([np.asarray(traj.pos) - position, np.asarray(rotation_vector(rel))], 1)
    y = q @ np.asarray(modes.mass) @ phi
    y = (y - y.mean()) * np.hanning(len(y))
    n = 1 << 18
    spec = np.abs(np.fft.rfft(y, n))
    f = np.fft.rfftfreq(n, FREE_DT)
    k = int(np.argmax(spec))
    a, b, c = np.log(spec[k - 1:k + 2])
    return float(f[k] + 0.5 * (a - c) / (a - 2 * b + c) * (f[1] - f[0])), int(traj.n_failed)


def _skew(v):
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def table2_and_modes(duration, dt):
    rows, modes_rows = [], []
    for pos in PAPER_POSITIONS:
        p = np.asarray(pos)
        for kind in ATTITUDES:
            sol = solve_attitude(PARAMS, p, kind)
            st = sol.statics
            row = {"position_m": list(pos), "attitude": kind,
                   "rotation_vector_rad": np.asarray(sol.rotation_vector).tolist(),
                   "tilt_deg": float(np.rad2deg(sol.tilt_rad)), "feasible": bool(st.feasible),
                   "tensions_kn": (np.asarray(st.tension_n) / 1e3).tolist(),
                   "min_tension_kn": float(np.min(st.min_tension_n)) / 1e3}
            if not bool(st.feasible):
                rows.append(row)
                continue
            res = run_scenario_jit(PARAMS, jnp.asarray(p), duration=duration, dt=dt,
                                   attitude=jnp.asarray(sol.R))
            e = np.asarray(res.extra_error)
            row.update({"correlation": np.asarray(res.correlation).tolist(),
                        "std_m": np.asarray(res.std).tolist(),
                        "amplitude_m": np.asarray(res.amplitude).tolist(),
                        "peak_to_peak_m": np.ptp(e, axis=0).tolist(),
                        "failed_cable_solves": int(res.n_failed)})
            rows.append(row)
            m = cabin_modes_jit(PARAMS, jnp.asarray(p), jnp.asarray(sol.R), st.static)
            f_fft, nf = fft_lowest(m, p, sol.R)
            cs = cable_string_modes(PARAMS, jnp.asarray(p), st.static, sol.R)
            Mc = cable_inertia_matrix(PARAMS, st.static, sol.R)
            f_ci, _, _ = modes_from_matrices(m.stiffness, m.mass + Mc)
            shapes = np.asarray(m.shapes)
            modes_rows.append({
                "position_m": list(pos), "attitude": kind,
                "frequencies_hz": np.asarray(m.frequencies_hz).tolist(),
                "shapes": [{"translation_m": shapes[:3, k].tolist(), "rotation_rad": shapes[3:, k].tolist(),
                            "dominant": _describe(shapes[:, k], np.asarray(m.mass))} for k in range(6)],
                "stiffness_asymmetry": float(m.asymmetry), "stable": bool(m.stable),
                "fft_lowest_hz": f_fft, "fft_failed_cable_solves": nf,
                "fft_relative_error": abs(f_fft - float(m.frequencies_hz[0])) / float(m.frequencies_hz[0]),
                "cable_string_hz": np.asarray(cs.taut_string_hz).tolist(),
                "irvine_lambda2": np.asarray(cs.irvine_lambda2).tolist(),
                "with_cable_inertia_hz": np.asarray(f_ci).tolist(),
            })
    return rows, modes_rows


def _describe(phi, M):
    # Share of the mode's kinetic energy in translation x, y, z and rotation about x, y, z
    # (diagonal blocks of M; the coupling block is split evenly).
    e = phi * (M @ phi)
    names = ["x", "y", "z", "rx", "ry", "rz"]
    k = int(np.argmax(np.abs(e)))
    return f"{names[k]} ({abs(e[k]) / np.abs(e).sum() * 100:.0f} %)"


def score(rows):
    """Per attitude: mean |log10(ours/paper)| over y and z, std and amplitude, at the three
    off-centre positions where the attitude is feasible (max |·| and peak-to-peak readings)."""
    out = {}
    for kind in ATTITUDES:
        for amp_key in ("amplitude_m", "peak_to_peak_m"):
            errs = []
            for r in rows:
                if r["attitude"] != kind or "std_m" not in r or r["position_m"][0] == 0.0:
                    continue
                paper = PAPER_TABLE2[tuple(r["position_m"])]
                for k, ax in ((1, "y"), (2, "z")):
                    errs.append(abs(np.log10(r["std_m"][k] / paper[ax][0])))
                    errs.append(abs(np.log10(r[amp_key][k] / paper[ax][1])))
            out[f"{kind} / {amp_key}"] = {"mean_abs_log10": float(np.mean(errs)) if errs else None,
                                          "n": len(errs)}
    return out


def focal_maps(n_zenith, n_azimuth, max_zenith_deg):
    zen = np.deg2rad(np.linspace(0.0, max_zenith_deg, n_zenith))
    az = np.linspace(0.0, 2 * np.pi, n_azimuth, endpoint=False)
    pts = [(0.0, 0.0)] + [(z, a) for z in zen[1:] for a in az]
    pos = np.asarray(focal_surface_point(np.array([p[0] for p in pts]), np.array([p[1] for p in pts])))
    workspace_map(PARAMS, pos[:2])  # compile
    t0 = time.perf_counter()
    level = workspace_map(PARAMS, pos)
    t_level = (time.perf_counter() - t0) / len(pos)
    feas_level = np.asarray(level.feasible)
    Rs = np.broadcast_to(np.eye(3), (len(pos), 3, 3)).copy()
    tilt = np.zeros(len(pos))
    feas_any = feas_level.copy()
    t0 = time.perf_counter()
    n_search = 0
    for i in np.flatnonzero(~feas_level):
        sol = smallest_feasible_tilt(PARAMS, pos[i], n_axes=12, n_fan=4, tol=1e-4)
        n_search += 1
        if sol.found:
            feas_any[i], Rs[i], tilt[i] = True, np.asarray(sol.R), sol.tilt_rad
        else:
            tilt[i] = np.nan
    t_tilt = (time.perf_counter() - t0) / max(n_search, 1)
    att = workspace_map(PARAMS, pos, Rs)
    # modes at the attitude used (level where feasible, else the smallest tilt), batched
    ok = np.flatnonzero(feas_any)
    statics = jax.tree.map(lambda a: a[ok], att.static)
    t0 = time.perf_counter()
    m = modes_map(PARAMS, pos[ok], Rs[ok], statics)
    jax.block_until_ready(m)
    compile_plus_run = time.perf_counter() - t0
    runs = []
    for _ in range(3):
        t0 = time.perf_counter()
        jax.block_until_ready(modes_map(PARAMS, pos[ok], Rs[ok], statics))
        runs.append(time.perf_counter() - t0)
    f1 = np.full(len(pos), np.nan)
    f1[ok] = np.asarray(m.frequencies_hz[:, 0])
    # the largest zenith angle with a feasible attitude, per azimuth (grid resolution)
    zen_pts = np.array([p[0] for p in pts])
    az_pts = np.array([p[1] for p in pts])
    max_level, max_any = [], []
    for a in az:
        sel = np.isclose(az_pts, a) | (zen_pts == 0.0)
        zs = zen_pts[sel]
        max_level.append(float(np.rad2deg(_largest_prefix(zs, feas_level[sel]))))
        max_any.append(float(np.rad2deg(_largest_prefix(zs, feas_any[sel]))))
    return {
        "positions_m": pos.tolist(), "zenith_deg": np.rad2deg(zen_pts).tolist(),
        "azimuth_deg": np.rad2deg(az_pts).tolist(),
        "feasible_level": feas_level.tolist(), "feasible_some_tilt": feas_any.tolist(),
        "status_level": np.asarray(level.status).tolist(),
        "min_tension_level_kn": np.where(feas_level, np.min(np.asarray(level.min_tension_n), 1) / 1e3,
                                         np.nan).tolist(),
        "smallest_tilt_deg": np.rad2deg(tilt).tolist(),
        "min_tension_used_kn": np.where(feas_any, np.min(np.asarray(att.min_tension_n), 1) / 1e3,
                                        np.nan).tolist(),
        "first_frequency_hz": f1.tolist(),
        "max_zenith_level_deg_per_azimuth": max_level, "max_zenith_some_tilt_deg_per_azimuth": max_any,
        "azimuths_deg": np.rad2deg(az).tolist(),
        "timing": {"statics_per_position_ms": t_level * 1e3,
                   "smallest_tilt_search_per_position_s": t_tilt,
                   "modes_batch_positions": int(len(ok)),
                   "modes_batch_compile_plus_first_run_s": compile_plus_run,
                   "modes_batch_run_best_s": min(runs),
                   "modes_per_position_ms": min(runs) / len(ok) * 1e3},
    }


def _largest_prefix(z, ok):
    # largest zenith on the grid up to which every grid point along the meridian is feasible
    order = np.argsort(z)
    z, ok = z[order], ok[order]
    bad = np.flatnonzero(~ok)
    return z[-1] if bad.size == 0 else (z[bad[0] - 1] if bad[0] > 0 else np.nan)


def markdown(rows, modes_rows, scores, maps, settings):
    L = ["# FAST feed support beyond the paper: attitude, Table 2, modes and workspace", "",
         f"Scenario: {settings['duration']} s at dt {settings['dt'] * 1e3:g} ms, velocity Verlet, "
         "momentum start (as `stewart-jax fast`). Attitudes: level (`G R_C = I`, the paper's), "
         "towards-centre (feed axis along the focal-surface normal), smallest-tilt (least tilt "
         "about a horizontal axis that is feasible), max-min-tension (rotation maximising the least "
         "cable tension).", "",
         "## Table 2 at the four positions, with the attitude stated", "",
         "| position (m) | attitude | tilt (°) | min tension (kN) | axis | corr | std (m) ours / paper "
         "| max\\|·\\| (m) | p-p (m) | amplitude paper (m) |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        head = f"| {r['position_m']} | {r['attitude']} | {r['tilt_deg']:.2f} | "
        if not r["feasible"]:
            L.append(head + "— | — | infeasible | — | — | — | — |")
            continue
        paper = PAPER_TABLE2[tuple(r["position_m"])]
        for k, ax in enumerate("xyz"):
            L.append((head if k == 0 else "| | | | ") + (f"{r['min_tension_kn']:.1f} | " if k == 0 else "| ")
                     + f"{ax} | {r['correlation'][k]:.4f} | {r['std_m'][k]:.3e} / {paper[ax][0]:.3e} | "
                     f"{r['amplitude_m'][k]:.3e} | {r['peak_to_peak_m'][k]:.3e} | {paper[ax][1]:.3e} |")
    L += ["", "Distance of y and z from the paper (mean |log10(ours/paper)| over std and amplitude, "
          "y and z, the three off-centre positions where the attitude is feasible; 1.0 = a factor 10):", "",
          "| attitude / amplitude reading | mean \\|log10\\| | values |", "|---|---|---|"]
    for k, v in scores.items():
        L.append(f"| {k} | {v['mean_abs_log10']:.3f} | {v['n']} |" if v["mean_abs_log10"] is not None
                 else f"| {k} | — | 0 |")
    L += ["", "## Natural frequencies and mode shapes", "",
          "Frequencies of the cabin on its six elastic catenaries (s0 fixed), cabin + upper platform + "
          "legs + lower platform rigid; the lowest checked against the FFT of the cabin released 5 mm "
          "along its first mode in the coupled simulation (60 s, dt 20 ms); the cables' first string "
          "frequencies; the frequencies with the cables' own inertia added by Rayleigh–Ritz (linear "
          "quasi-static shape, valid only well below the string frequencies).", "",
          "| position (m) | attitude | frequencies (Hz) | dominant motion per mode | FFT lowest (Hz), rel. err "
          "| cable f1 (Hz) min–max | with cable inertia (Hz) |", "|---|---|---|---|---|---|---|"]
    for m in modes_rows:
        L.append(f"| {m['position_m']} | {m['attitude']} | {', '.join(f'{f:.4f}' for f in m['frequencies_hz'])} | "
                 f"{', '.join(s['dominant'] for s in m['shapes'])} | {m['fft_lowest_hz']:.4f}, "
                 f"{m['fft_relative_error']:.1e} | {min(m['cable_string_hz']):.3f}–{max(m['cable_string_hz']):.3f} | "
                 f"{', '.join(f'{f:.3f}' for f in m['with_cable_inertia_hz'])} |")
    t = maps["timing"]
    ml, ma = np.array(maps["max_zenith_level_deg_per_azimuth"]), np.array(maps["max_zenith_some_tilt_deg_per_azimuth"])
    L += ["", "## Maps over the focal surface", "",
          f"Grid: zenith 0–{settings['max_zenith']}° in {settings['n_zenith']} steps × {settings['n_azimuth']} "
          "azimuths on the sphere of radius 160 m about the centre of curvature (0, 0, 300) m.", "",
          f"- Largest zenith angle with every grid point up to it feasible, over the azimuths: "
          f"level cabin {np.nanmin(ml):.1f}°–{np.nanmax(ml):.1f}°; with the smallest feasible tilt "
          f"(≤ 45°) {np.nanmin(ma):.1f}°–{np.nanmax(ma):.1f}° (the workspace of the tilted cabin is "
          f"{'the whole grid' if np.all(ma >= settings['max_zenith'] - 1e-9) else 'bounded as listed'}).",
          f"- First natural frequency over the feasible map: {np.nanmin(maps['first_frequency_hz']):.3f}–"
          f"{np.nanmax(maps['first_frequency_hz']):.3f} Hz.",
          f"- Smallest tilt needed where the level cabin is infeasible: up to "
          f"{np.nanmax(maps['smallest_tilt_deg']):.1f}°.", "",
          "## Speed", "",
          f"- Static equilibrium + feasibility: {t['statics_per_position_ms']:.2f} ms per position "
          "(loop of jitted solves).",
          f"- Stiffness + mass + modes batched over {t['modes_batch_positions']} positions (vmap, statics "
          f"given): **{t['modes_per_position_ms']:.3f} ms per position** (best of 3; compile + first run "
          f"{t['modes_batch_compile_plus_first_run_s']:.1f} s).",
          f"- Smallest-tilt search: {t['smallest_tilt_search_per_position_s']:.2f} s per position.", ""]
    return "\n".join(L)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="0.4 s scenarios, a coarse map")
    args = ap.parse_args(argv)
    settings = ({"duration": 0.4, "dt": 2e-3, "n_zenith": 4, "n_azimuth": 6, "max_zenith": 60.0}
                if args.quick else
                {"duration": 2.0, "dt": 1e-3, "n_zenith": 15, "n_azimuth": 24, "max_zenith": 70.0})
    t0 = time.perf_counter()
    static_equilibrium_jit(PARAMS, jnp.asarray(PAPER_POSITIONS[0]), jnp.eye(3))
    compile_statics = time.perf_counter() - t0
    rows, modes_rows = table2_and_modes(settings["duration"], settings["dt"])
    scores = score(rows)
    maps = focal_maps(settings["n_zenith"], settings["n_azimuth"], settings["max_zenith"])
    maps["timing"]["statics_compile_s"] = compile_statics
    name = "fast_modes_quick" if args.quick else "fast_modes"
    write_results(name, {"settings": settings, "table2": rows, "scores": scores, "modes": modes_rows,
                         "maps": maps}, markdown(rows, modes_rows, scores, maps, settings))
    pos = np.asarray(maps["positions_m"])
    plotting.show(plotting.plot_fast_focal_map(
        pos, maps["min_tension_used_kn"], feasible=maps["feasible_some_tilt"],
        label="least cable tension (kN)",
        title="Feasible workspace: least tension (level cabin, or the smallest feasible tilt)"),
        Path(RESULTS) / f"{name}_workspace.png")
    plotting.show(plotting.plot_fast_focal_map(
        pos, maps["smallest_tilt_deg"], feasible=maps["feasible_some_tilt"], label="smallest feasible tilt (°)",
        title="Tilt needed (0 where the level cabin is feasible)", cmap="magma"),
        Path(RESULTS) / f"{name}_tilt.png")
    plotting.show(plotting.plot_fast_focal_map(
        pos, maps["first_frequency_hz"], feasible=maps["feasible_some_tilt"], label="first natural frequency (Hz)",
        title="Lowest cabin mode over the focal surface"), Path(RESULTS) / f"{name}_first_frequency.png")
    labels = {f"{m['position_m'][0]:g} m, {m['attitude']}": m for m in modes_rows}
    plotting.show(plotting.plot_fast_frequencies(
        {k: m["frequencies_hz"] for k, m in labels.items()},
        checks={k: m["fft_lowest_hz"] for k, m in labels.items()},
        cable={k: m["cable_string_hz"] for k, m in labels.items()},
        title="Cabin modes vs the cables' own string modes"), Path(RESULTS) / f"{name}_frequencies.png")
    print(markdown(rows, modes_rows, scores, maps, settings))


if __name__ == "__main__":
    main()
