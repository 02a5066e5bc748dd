"""Benchmark of the FAST coupled simulation (Yin et al., *Dynamic modeling of a cable-driven
parallel robot with a Stewart platform for use in FAST*): real-time factor of one jitted
trajectory and throughput of a vmapped workspace map of Table-2 amplitudes.

Usage: ``.venv/bin/python benchmarks/fast.py [--duration 2] [--map-n 10] [--repeats 5] [--pin-core 0]``
Writes ``benchmarks/results/fast.json`` and ``benchmarks/results/fast.md`` (``fast_pinned.*``
with ``--pin-core``).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time

import jax
import jax.numpy as jnp
import jaxlib
import numpy as np

import stewart_jax  # noqa: F401
from stewart_jax.cable_robot import paper_fast_params, run_scenario, static_equilibrium

# The coupled integrator itself (private, behind run_scenario), timed on its own.
from stewart_jax.cable_robot._coupled import CabinState, matrix_to_quat, simulate
from stewart_jax.cable_robot._scenario import sine_motion

static_equilibrium_jit = jax.jit(static_equilibrium)

RESULTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results")


def _timed(f, repeats):
    t0 = time.perf_counter()
    jax.block_until_ready(f())
    first = time.perf_counter() - t0
    runs = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        jax.block_until_ready(f())
        runs.append(time.perf_counter() - t0)
    return first, min(runs), float(np.median(runs))


def single_trajectory(duration, dt, method, repeats):
    params = paper_fast_params()
    pos = jnp.array([0.0, 0.0, 140.0])
    st = static_equilibrium_jit(params, pos)
    state0 = CabinState(pos, matrix_to_quat(jnp.eye(3)), jnp.zeros(3), jnp.zeros(3))
    n = int(round(duration / dt))
    motion = sine_motion(params.h)
    fn = jax.jit(lambda s0, F0: simulate(params, s0, state0, F0, motion, dt, n, method).pos)
    t0 = time.perf_counter()
    compiled = fn.lower(st.s0, st.force).compile()
    compile_s = time.perf_counter() - t0
    _, best, median = _timed(lambda: compiled(st.s0, st.force), repeats)
    return {"method": method, "dt_s": dt, "duration_s": duration, "steps": n,
            "compile_s": compile_s, "run_s_best": best, "run_s_median": median,
            "realtime_factor_best": duration / best, "realtime_factor_median": duration / median,
            "us_per_step_best": best / n * 1e6}


def workspace_map(n_side, duration, dt, repeats):
    params = paper_fast_params()
    xs = np.linspace(-40.0, 40.0, n_side)
    X, Y = np.meshgrid(xs, xs, indexing="ij")
    R2 = X**2 + Y**2
    Z = 300.0 - np.sqrt(160.0**2 - R2)  # focal surface through Table 2's positions
    pos = jnp.asarray(np.stack([X.ravel(), Y.ravel(), Z.ravel()], -1))

    def one(p):
        r = run_scenario(params, p, duration=duration, dt=dt)
        return r.amplitude, r.correlation, r.static_ok & (r.n_failed == 0)

    fn = jax.jit(jax.vmap(one))
    t0 = time.perf_counter()
    compiled = fn.lower(pos).compile()
    compile_s = time.perf_counter() - t0
    _, best, median = _timed(lambda: compiled(pos), repeats)
    amp, corr, ok = (np.asarray(a) for a in compiled(pos))
    return {"positions": int(pos.shape[0]), "grid": "x, y in [-40, 40] m on the focal surface "
            "z = 300 - sqrt(160^2 - x^2 - y^2)", "duration_s": duration, "dt_s": dt,
            "compile_s": compile_s, "run_s_best": best, "run_s_median": median,
            "positions_per_s": pos.shape[0] / best,
            "amplitude_x_mm": {"min": float(amp[ok, 0].min() * 1e3), "max": float(amp[ok, 0].max() * 1e3)},
            "correlation_x_min": float(corr[ok, 0].min()), "all_ok": bool(ok.all())}


def _cpu_pressure():
    # Linux PSI: share of time runnable tasks waited for a CPU (a busy host shows here even
    # when the load average of this VM is low).
    try:
        with open("/proc/pressure/cpu") as f:
            return f.readline().strip()
    except OSError:
        return None


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--duration", type=float, default=2.0)
    ap.add_argument("--dt", type=float, default=1e-3)
    ap.add_argument("--map-n", type=int, default=10, help="map is map-n x map-n positions")
    ap.add_argument("--map-duration", type=float, default=1.0)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--pin-core", type=int, default=None,
                    help="run the whole process on this one CPU core (as a real-time controller "
                    "thread would); results go to fast_pinned.{json,md}")
    args = ap.parse_args(argv)
    if args.pin_core is not None:
        # before JAX creates its CPU client: its worker threads inherit the affinity
        os.sched_setaffinity(0, {args.pin_core})
    single = [single_trajectory(args.duration, args.dt, m, args.repeats) for m in ("verlet", "rk4")]
    wmap = workspace_map(args.map_n, args.map_duration, args.dt, max(1, args.repeats // 2))
    info = {
        "command": " ".join([os.path.relpath(sys.executable), *sys.argv]),
        "platform": platform.platform(), "processor": platform.processor(),
        "cpu_count": os.cpu_count(), "load_average_1m_at_end": os.getloadavg()[0],
        "python": platform.python_version(), "jax": jax.__version__, "jaxlib": jaxlib.__version__,
        "numpy": np.__version__, "backend": jax.default_backend(),
        "pinned_core": args.pin_core,
        "cpu_pressure_at_end": _cpu_pressure(),
    }
    name = "fast" if args.pin_core is None else "fast_pinned"
    out = {"machine": info, "single_trajectory": single, "workspace_map": wmap}
    os.makedirs(RESULTS, exist_ok=True)
    with open(os.path.join(RESULTS, f"{name}.json"), "w") as f:
        json.dump(out, f, indent=2)
    lines = [
        "# FAST coupled simulation benchmark (Yin et al.)", "",
        f"`{info['command']}` on {info['platform']}, {info['cpu_count']} CPUs "
        f"(1-min load average at the end: {info['load_average_1m_at_end']:.1f}"
        f"{'' if args.pin_core is None else f'; process pinned to core {args.pin_core}'}; "
        f"CPU pressure: {info['cpu_pressure_at_end']}), "
        f"jax {info['jax']}, numpy {info['numpy']}, python {info['python']}.", "",
        "| integrator | dt (ms) | steps | compile (s) | run best / median (s) "
        "| real-time factor best / median | µs/step |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for s in single:
        lines.append(f"| {s['method']} | {s['dt_s'] * 1e3:g} | {s['steps']} | {s['compile_s']:.1f} | "
                     f"{s['run_s_best']:.3f} / {s['run_s_median']:.3f} | "
                     f"{s['realtime_factor_best']:.1f}× / {s['realtime_factor_median']:.1f}× | "
                     f"{s['us_per_step_best']:.1f} |")
    lines += ["", f"Workspace map (vmap, {wmap['positions']} positions, {wmap['grid']}, "
              f"{wmap['duration_s']} s each at dt {wmap['dt_s'] * 1e3:g} ms, statics included): "
              f"compile {wmap['compile_s']:.1f} s, run {wmap['run_s_best']:.2f} s → "
              f"**{wmap['positions_per_s']:.1f} positions/s** "
              f"({wmap['positions_per_s'] * wmap['duration_s']:.1f} simulated s per wall s); "
              f"x amplitude {wmap['amplitude_x_mm']['min']:.3f}–{wmap['amplitude_x_mm']['max']:.3f} mm, "
              f"min x correlation {wmap['correlation_x_min']:.4f}, all converged: {wmap['all_ok']}.", ""]
    with open(os.path.join(RESULTS, f"{name}.md"), "w") as f:
        f.write("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
