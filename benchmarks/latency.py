"""Latency of the command line as a user meets it: every subcommand as the documentation shows it,
each run cold (an empty compilation cache, ``STEWART_JAX_CACHE_DIR``) and warm (the same cache
again), wall and CPU time (user + sys of the process, so that the machine's load matters less),
beside the script a user would write with SciPy for the same calibration, in the same run.

The SciPy script (written to the work folder, shown in the JSON): the 6-PSS of Wang H., Cao X.
et al., *Improved cuckoo calibration method of space telescope secondary mirror adjusting
mechanism* (Infrared and Laser Engineering 47(5), 2018), eqs. 1, 4, 7–9, as a vectorised NumPy
residual with its analytic Jacobian, the nominal geometry's numbers (Table 1) written into the
script, the measurement CSV read with NumPy, and ``scipy.optimize.least_squares(method="lm")``
(MINPACK's Levenberg–Marquardt, Moré 1978) with its default tolerances. It imports neither JAX nor
stewart_jax.

Targets (the project's): ``calibrate`` of the paper's 8 poses warm at most 2× the SciPy script's
CPU time and cold at most 5× (the acceptance bar: 3× and 10×); ``stewart-jax --help`` at most 2×
a bare ``python -c "import numpy"``.

    python benchmarks/latency.py            # every subcommand (about 15 minutes on 2 cores)
    python benchmarks/latency.py --quick    # --help, --version, export and the SciPy script only
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _common import write_results  # noqa: E402

from stewart_jax._files import write_text_atomic  # noqa: E402

# (label, argv after `stewart-jax`, the SciPy peer's input CSV or None); in order: each command's
# input files are written by an earlier one.
COMMANDS = [
    ("--help", ["--help"], None),
    ("--version", ["--version"], None),
    ("simulate (paper8)", ["simulate", "--out", "p8.csv", "--plan", "paper8", "--seed", "0"], None),
    ("calibrate (8 poses)", ["calibrate", "p8.csv", "--json", "c8.json"], "p8.csv"),
    ("simulate (plan120)", ["simulate", "--out", "p120.csv", "--plan", "plan120", "--seed", "0"], None),
    ("calibrate (120 poses)", ["calibrate", "p120.csv", "--json", "c120.json"], "p120.csv"),
    ("simulate --points", ["simulate", "--points", "--default-targets", "--targets", "T.json", "--out", "pts.csv",
                           "--seed", "0"], None),
    ("calibrate (points)", ["calibrate", "pts.csv", "--targets", "T.json", "--json", "cp.json"], None),
    ("simulate-effect", ["simulate-effect", "--out", "d.csv", "--effect", "backlash", "--magnitude", "3",
                         "--seed", "1"], None),
    ("diagnose", ["diagnose", "d.csv", "--json", "d.json"], None),
    ("fast --modes", ["fast", "--modes", "--json", "f.json"], None),
    ("fast --modes --cables lumped", ["fast", "--modes", "--cables", "lumped", "--json", "fl.json"], None),
    ("export (json)", ["export", "nominal", "--format", "json", "--out", "nominal.json"], None),
    ("study (2 trials)", ["study", "--methods", "lm-batched", "--trials", "2", "--json", "s.json"], None),
]
QUICK = ("--help", "--version", "export (json)")

SCIPY_SCRIPT = '''"""Calibrate the 6-PSS of Wang et al. (2018) from a measurement CSV with SciPy (36 joint centres)."""
import csv
import sys

import numpy as np
from scipy.optimize import least_squares

U0 = np.array({u0})  # nominal Ac_1..Ac_6 then Bc_1..Bc_6 (x, y, z each), mm (Table 1)
V0 = np.array({v0})  # mm

with open(sys.argv[1], newline="") as f:
    rows = list(csv.DictReader(f))
q = np.array([[float(r[f"q{{i}}"]) for i in range(1, 7)] for r in rows])
p = np.array([[float(r[k]) for k in ("x", "y", "z", "rx", "ry", "rz")] for r in rows])
p[:, 3:] = np.deg2rad(p[:, 3:])
f_, t_, s_ = p[:, 3], p[:, 4], p[:, 5]
cf, sf, ct, st, cs, ss = np.cos(f_), np.sin(f_), np.cos(t_), np.sin(t_), np.cos(s_), np.sin(s_)
T = np.stack([np.stack([cs * ct, cs * st * sf - ss * cf, cs * st * cf + ss * sf], -1),
              np.stack([ss * ct, ss * st * sf + cs * cf, ss * st * cf - cs * sf], -1),
              np.stack([-st, ct * sf, ct * cf], -1)], -2)  # Rz(psi) Ry(theta) Rx(phi), (m, 3, 3)
legs = np.arange(6)


def parts(u):
    ac, bc = u[:18].reshape(6, 3), u[18:].reshape(6, 3)
    a = np.einsum("mjk,ik->mij", T, ac) + p[:, None, :3] + V0
    e = ac + V0 - bc
    dx, dy = bc[:, 0] - a[..., 0], bc[:, 1] - a[..., 1]
    h = np.sqrt(np.maximum(np.sum(e**2, -1) - dx**2 - dy**2, 0.0))
    return a, bc, e, dx, dy, h


def residual(u):
    a, bc, _, _, _, h = parts(u)
    return (q - (a[..., 2] - bc[:, 2] - h)).ravel()


def jacobian(u):
    _, _, e, dx, dy, h = parts(u)
    R = T[:, None]
    d_ac = R[..., 2, :] - (e + dx[..., None] * R[..., 0, :] + dy[..., None] * R[..., 1, :]) / h[..., None]
    d_bc = np.stack([(e[:, 0] + dx) / h, (e[:, 1] + dy) / h, e[:, 2] / h - 1.0], -1)
    J = np.zeros((len(q), 6, 36))
    for k in range(3):
        J[:, legs, 3 * legs + k] = -d_ac[..., k]
        J[:, legs, 18 + 3 * legs + k] = -d_bc[..., k]
    return J.reshape(-1, 36)


r = least_squares(residual, U0, jac=jacobian, method="lm")
print(f"S = {{2 * r.cost:.6g}} mm^2 after {{r.nfev}} evaluations, status {{r.status}}")
'''


def cli() -> str:
    return os.path.join(os.path.dirname(sys.executable), "stewart-jax")


def timed(argv: list[str], cwd: str, env: dict[str, str]) -> dict:
    """One process: wall and CPU (user + sys) seconds, exit status, the last line it printed."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    out = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    text = (out.stderr.strip() or out.stdout.strip()).splitlines()
    return {"wall_s": wall, "cpu_s": cpu, "exit": out.returncode, "said": text[-1][:200] if text else ""}


def best(runs: list[dict]) -> dict:
    """The run of least CPU time among repeats (the one the machine's load disturbed least)."""
    return min(runs, key=lambda r: r["cpu_s"])


def scipy_script(work: str) -> str:
    import stewart_jax as sj

    nominal = sj.nominal_geometry()
    path = os.path.join(work, "scipy_calibrate.py")
    with open(path, "w", encoding="utf-8") as f:
        f.write(SCIPY_SCRIPT.format(u0=np.asarray(nominal.params).tolist(), v0=np.asarray(nominal.v0).tolist()))
    return path


def measure(commands, work: str, cache_root: str, warm_repeats: int) -> tuple[list[dict], dict]:
    base_env = {k: v for k, v in os.environ.items() if not k.startswith(("JAX_COMPILATION_CACHE", "STEWART_JAX"))}
    script = scipy_script(work)
    baselines = {
        "import numpy": best([timed([sys.executable, "-c", "import numpy"], work, base_env) for _ in range(3)]),
    }
    rows = []
    for i, (label, argv, peer) in enumerate(commands):
        env = {**base_env, "STEWART_JAX_CACHE_DIR": os.path.join(cache_root, f"cold-{i}")}
        cold = timed([cli(), *argv], work, env)
        warm = best([timed([cli(), *argv], work, env) for _ in range(warm_repeats)])
        row = {"command": label, "argv": ["stewart-jax", *argv], "cold": cold, "warm": warm}
        if peer is not None:
            row["scipy"] = best([timed([sys.executable, script, peer], work, base_env) for _ in range(3)])
            row["scipy"]["script"] = "scipy_calibrate.py " + peer
        rows.append(row)
        print(f"{label:32s} cold {cold['cpu_s']:6.2f} s CPU ({cold['wall_s']:6.2f} wall)  warm {warm['cpu_s']:6.2f} s "
              f"CPU ({warm['wall_s']:6.2f} wall)  exit {cold['exit']}/{warm['exit']}"
              + (f"  SciPy {row['scipy']['cpu_s']:.2f} s CPU" if peer else ""), flush=True)
    return rows, baselines


def verdicts(rows: list[dict], baselines: dict) -> list[dict]:
    by = {r["command"]: r for r in rows}
    out = []

    def add(what, value, goal, bar):
        out.append({"target": what, "ratio": value, "goal": goal, "bar": bar,
                    "verdict": ("met" if value <= goal else "within the bar, goal missed" if value <= bar
                                else "missed")})

    if "calibrate (8 poses)" in by:
        r = by["calibrate (8 poses)"]
        add("calibrate (8 poses) warm / SciPy script, CPU", r["warm"]["cpu_s"] / r["scipy"]["cpu_s"], 2.0, 3.0)
        add("calibrate (8 poses) cold / SciPy script, CPU", r["cold"]["cpu_s"] / r["scipy"]["cpu_s"], 5.0, 10.0)
    if "--help" in by:
        add("--help / import numpy, CPU", by["--help"]["warm"]["cpu_s"] / baselines["import numpy"]["cpu_s"], 2.0, 2.0)
    return out


def markdown(rows: list[dict], baselines: dict, verdict_rows: list[dict], script: str) -> str:
    lines = ["# Command-line latency: cold (empty compilation cache) and warm", "",
             "CPU = user + sys seconds of the process (best of the repeats for warm runs and for the "
             "SciPy script); wall in parentheses. A bare `python -c \"import numpy\"` takes "
             f"{baselines['import numpy']['cpu_s']:.2f} s CPU.", "",
             "| command | cold CPU (wall) s | warm CPU (wall) s | SciPy script CPU s | cold / SciPy | warm / SciPy |",
             "| --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        c, w, s = r["cold"], r["warm"], r.get("scipy")
        peer = (f"{s['cpu_s']:.2f} | {c['cpu_s'] / s['cpu_s']:.1f}× | {w['cpu_s'] / s['cpu_s']:.1f}×" if s
                else "— | — | —")
        lines.append(f"| `{' '.join(r['argv'])}` | {c['cpu_s']:.2f} ({c['wall_s']:.2f}) | {w['cpu_s']:.2f} "
                     f"({w['wall_s']:.2f}) | {peer} |")
    lines += ["", "## Targets", "", "| target | measured | goal | acceptance bar | verdict |",
              "| --- | --- | --- | --- | --- |"]
    lines += [f"| {v['target']} | {v['ratio']:.2f}× | ≤ {v['goal']:g}× | ≤ {v['bar']:g}× | {v['verdict']} |"
              for v in verdict_rows]
    lines += ["", "Where the time goes and where we still lose: "
              "[the speed page](../../docs/benchmarks/speed.md#command-line-latency).",
              "", "## The SciPy script", "", "```python", script.rstrip(), "```"]
    return "\n".join(lines)


def rewrite_markdown(name: str) -> None:
    """``results/NAME.md`` again from ``results/NAME.json`` (the run's own machine line)."""
    from _common import RESULTS

    with open(os.path.join(RESULTS, f"{name}.json"), encoding="utf-8") as f:
        res = json.load(f)
    info = res["machine"]
    header = (f"Command: `{info['command']}`  \nMachine: {info['platform']}, {info['cpu_count']} CPUs "
              f"({info['processor']}), backend {info['backend']}, load average {info['load_average_1min']}; "
              f"python {info['python']}, jax {info['jax']}, numpy {info['numpy']}; {info['date_utc']} UTC\n\n")
    text = markdown(res["rows"], res["baselines"], res["targets"], res["scipy_script"])
    write_text_atomic(os.path.join(RESULTS, f"{name}.md"), header + text.rstrip() + "\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="--help, --version and export only (a smoke test)")
    ap.add_argument("--warm-repeats", type=int, default=2)
    ap.add_argument("--rewrite-markdown", action="store_true",
                    help="write results/NAME.md again from results/NAME.json, running nothing")
    ap.add_argument("--out", default=None,
                    help="result name under benchmarks/results, or a path without extension (default latency)")
    args = ap.parse_args()
    if args.rewrite_markdown:
        rewrite_markdown(args.out or "latency")
        return
    commands = [c for c in COMMANDS if c[0] in QUICK] if args.quick else COMMANDS
    with tempfile.TemporaryDirectory(prefix="stewart-jax-latency-") as work:
        cache_root = os.path.join(work, "caches")
        rows, baselines = measure(commands, work, cache_root, args.warm_repeats)
        with open(os.path.join(work, "scipy_calibrate.py"), encoding="utf-8") as f:
            script = f.read()
        shutil.rmtree(cache_root, ignore_errors=True)
    verdict_rows = verdicts(rows, baselines)
    for v in verdict_rows:
        print(f"{v['target']}: {v['ratio']:.2f}× (goal {v['goal']:g}×, bar {v['bar']:g}×): {v['verdict']}")
    payload = {"rows": rows, "baselines": baselines, "targets": verdict_rows, "scipy_script": script,
               "units": {"cpu_s": "s (user + sys)", "wall_s": "s"}}
    name = args.out or ("latency_quick" if args.quick else "latency")
    write_results(name, payload, markdown(rows, baselines, verdict_rows, script))
    print(json.dumps({v["target"]: v["verdict"] for v in verdict_rows}))


if __name__ == "__main__":
    main()
