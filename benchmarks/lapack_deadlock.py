"""The CPU deadlock of batched LAPACK calls in jaxlib 0.10.x, and the project's workaround.

jaxlib 0.10's CPU LAPACK kernels split a batch costing more than 2·10⁵ flops into chunks, schedule
them on XLA's intra-op thread pool and block the pool thread they run on until the chunks are
done; when XLA runs as many such calls at once as the pool has threads, every pool thread waits
for chunks no thread is free to run (see the NOTE of ``stewart_jax/_linalg.py``). This script
runs, each in a fresh process with a time limit, either

- ``--arm lapack``: the minimal reproducer, a jitted loop of two data-independent batched 6 × 6
  solves (``jnp.linalg.solve``, 1000 matrices each) run ``--reps`` times;
- ``--arm elementwise``: the same loop with ``stewart_jax._linalg.solve`` (no LAPACK call);
- ``--arm session --checkout DIR``: the discrepancy workflow on the hidden-effect sessions of
  ``tests/test_discrepancy_session.py`` (one family, 10 data sets of 180 poses, one
  ``diagnose_many``) with the library of checkout ``DIR`` (e.g. one before the workaround);

and records per run whether it finished or stalled (its CPU time stopped growing for
``--stall-s`` seconds: a deadlock, not slowness) with the load average, into
``benchmarks/results/lapack_deadlock.json`` (appended run by run) and ``.md``.

    python benchmarks/lapack_deadlock.py --arm lapack --runs 10
    python benchmarks/lapack_deadlock.py --arm elementwise --runs 10
    python benchmarks/lapack_deadlock.py --arm session --checkout . --runs 6

The deadlock is a race: it needs two such calls to overlap, which load on the machine makes
likelier (the runs record the 1-minute load average).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)

from _common import RESULTS, machine_info  # noqa: E402

MINI = r"""
import sys, jax, jax.numpy as jnp
jax.config.update("jax_enable_x64", True)
arm, reps = sys.argv[1], int(sys.argv[2])
if arm == "elementwise":
    from stewart_jax._linalg import solve
else:
    def solve(a, b):
        return jnp.linalg.solve(a, b[..., None])[..., 0]

@jax.jit
def f(a, b, c):
    def body(i, x):  # two data-independent batched solves: XLA may run them at once
        return x + solve(a + i * 1e-3, b).sum() + solve(c - i * 1e-3, b).sum()
    return jax.lax.fori_loop(0, 10, body, 0.0)

k = jax.random.split(jax.random.key(0), 3)
a = jax.random.normal(k[0], (1000, 6, 6)) + 6 * jnp.eye(6)
c = jax.random.normal(k[1], (1000, 6, 6)) + 6 * jnp.eye(6)
b = jax.random.normal(k[2], (1000, 6))
for _ in range(reps):
    f(a, b, c).block_until_ready()
print("finished")
"""

SESSION = r"""
import sys
sys.path.insert(0, sys.argv[2] + "/tests")
import numpy as np
from _numpy_session import REGISTERED, UNREGISTERED, session
import stewart_jax as sj
from stewart_jax import discrepancy as dc
family, seed = sys.argv[1], int(sys.argv[3])
if family == "6-UPS":
    mech = sj.mechanism.preset("rubin_camera")
    geo = dict(base=mech.base, platform=mech.platform, v0=mech.v0, lengths0=mech.lengths0)
    half = sj.calibration.reachable_travel(mech)
else:
    a = sj.actual_geometry()
    mech, geo = sj.nominal_geometry(), dict(upper=a.upper, lower=a.lower, v0=a.v0)
    half = np.array([1.0] * 3 + [0.01745] * 3)
model = dc.model_for(mech)
trains, tests = [], []
for c, eff in enumerate([None, *REGISTERED[family], *UNREGISTERED]):
    ses = session(family, geo, eff, np.random.default_rng([seed, c, 77]), half=half, n=180)
    data = sj.calibration.make_calibration_data(ses.readings, ses.poses, ses.directions, ses.temperature, ses.time)
    tr, te = dc.split_rows(180, 0.3, seed)
    trains.append(data.take(tr))
    tests.append(data.take(te))
effects, _ = dc.select_effects(model, trains[0], len(tr))
dc.diagnose_many(model, effects, trains, tests)
print("finished", sj.__file__)
"""


def cpu_seconds(pid: int) -> float:
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def run_once(cmd: list[str], env: dict, stall_s: float, limit_s: float) -> dict:
    """Run ``cmd``; ``stalled`` when its CPU time did not grow for ``stall_s`` seconds."""
    t0 = time.monotonic()
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    last, since = -1.0, time.monotonic()
    outcome = None
    while proc.poll() is None:
        time.sleep(2.0)
        try:
            cpu = cpu_seconds(proc.pid)
        except (FileNotFoundError, ProcessLookupError):
            break
        now = time.monotonic()
        if cpu != last:
            last, since = cpu, now
        elif now - since >= stall_s:
            outcome = "stalled"
        if now - t0 >= limit_s:
            outcome = outcome or "time_limit"
        if outcome:
            proc.kill()
            break
    out = proc.communicate()[0]
    if outcome is None:
        outcome = "finished" if proc.returncode == 0 and "finished" in out else f"failed (rc {proc.returncode})"
    return {"outcome": outcome, "wall_s": round(time.monotonic() - t0, 1), "load_average_1min": os.getloadavg()[0],
            "tail": out[-300:] if outcome.startswith("failed") else ""}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--arm", choices=("lapack", "elementwise", "session"), required=True)
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--reps", type=int, default=1500, help="loop calls per run (minimal arms)")
    ap.add_argument("--checkout", default=ROOT, help="library checkout of the session arm")
    ap.add_argument("--family", default="6-UPS", choices=("6-UPS", "6-PSS"))
    ap.add_argument("--stall-s", type=float, default=30.0, help="CPU-idle seconds that count as a deadlock")
    ap.add_argument("--limit-s", type=float, default=1800.0)
    args = ap.parse_args(argv)
    env = dict(os.environ, OPENBLAS_NUM_THREADS=os.environ.get("OPENBLAS_NUM_THREADS", "1"))
    if args.arm == "session":
        checkout = os.path.abspath(args.checkout)
        env["PYTHONPATH"] = checkout
        label = f"session {args.family} ({checkout})"
    else:
        env["PYTHONPATH"] = ROOT
        label = f"{args.arm} (2 × 1000 6×6 solves, {args.reps} calls)"
    path = os.path.join(RESULTS, "lapack_deadlock.json")
    record = json.load(open(path)) if os.path.exists(path) else {"machine": machine_info(), "runs": []}
    for i in range(args.runs):
        if args.arm == "session":
            cmd = [sys.executable, "-c", SESSION, args.family, checkout, str(i % 2)]
        else:
            cmd = [sys.executable, "-c", MINI, args.arm, str(args.reps)]
        r = {"arm": label, "xla_flags": os.environ.get("XLA_FLAGS", ""),
             **run_once(cmd, env, args.stall_s, args.limit_s)}
        record["runs"].append(r)
        print(f"{label} run {i}: {r['outcome']} in {r['wall_s']} s at load {r['load_average_1min']:.1f}", flush=True)
        tmp = path + ".tmp"
        with open(tmp, "w") as f:
            json.dump(record, f, indent=1)
        os.replace(tmp, path)  # after every run: an interruption loses at most one
    write_markdown(record)
    return 0


def write_markdown(record: dict) -> None:
    rows: dict[tuple[str, str], list[dict]] = {}
    for r in record["runs"]:
        rows.setdefault((r["arm"], r["xla_flags"]), []).append(r)
    m = record["machine"]
    lines = ["# Batched LAPACK calls and XLA's CPU thread pool (jaxlib " + m["jaxlib"] + ")", "",
             f"Machine: {m['platform']}, {m['cpu_count']} CPUs; jax {m['jax']}. Each run in a fresh process; "
             "*stalled* = its CPU time stopped growing for the stall limit (a deadlock). Command: "
             "`python benchmarks/lapack_deadlock.py --arm ARM --runs N`.", "",
             "| arm | XLA_FLAGS | runs | finished | stalled | load average (1 min) | wall per finished run (s) |",
             "| --- | --- | ---: | ---: | ---: | --- | --- |"]
    for (arm, flags), rs in rows.items():
        fin = [r["wall_s"] for r in rs if r["outcome"] == "finished"]
        loads = [r["load_average_1min"] for r in rs]
        lines.append(f"| {arm} | `{flags}` | {len(rs)} | {len(fin)} | {sum(r['outcome'] == 'stalled' for r in rs)} | "
                     f"{min(loads):.1f}–{max(loads):.1f} | "
                     f"{(f'{min(fin):.0f}–{max(fin):.0f}' if fin else '—')} |")
    with open(os.path.join(RESULTS, "lapack_deadlock.md"), "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    sys.exit(main())
