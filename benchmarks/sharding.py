"""Monte Carlo calibrations sharded over JAX devices: speed-up with 1, 2, 4 devices.

    python benchmarks/sharding.py [--quick]

Each device count runs in its own process (JAX fixes the device count at start-up), with
``--xla_force_host_platform_device_count=N`` on the CPU: N host devices share this machine's
cores. Per device count: the simulation study of Wang et al. (2018) (8 poses) with LM (many
trials: it is fast) and VSA-SMCS, run once to compile and then timed twice (the best of the two
is reported: the machine may be shared); the per-trial numbers are compared with the
single-device run. The 1-minute load average is recorded before each child.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from _common import write_results  # noqa: E402

CHILD = r"""
import faulthandler, json, sys, time
faulthandler.dump_traceback_later(int(sys.argv[5]), exit=True)  # a hang ends with the stacks on stderr
import jax
import stewart_jax  # noqa: F401
from stewart_jax.study import run_study
nd, lm_trials, trials, budget = (int(a) for a in sys.argv[1:5])
assert len(jax.devices()) == nd, jax.devices()
out = {}
for method, n in (("lm", lm_trials), ("vsa-smcs", trials)):
    kw = dict(n_trials=n, n_devices=nd, keep_trials=True, log=lambda s: None,
              method_options={"vsa-smcs": {"max_evaluations": budget}})
    t0 = time.perf_counter(); run_study((method,), **kw); first = time.perf_counter() - t0
    timed = []
    for _ in range(2):
        t0 = time.perf_counter(); r = run_study((method,), **kw); timed.append(time.perf_counter() - t0)
    row = [v for k, v in r["rows"].items() if k != "Before calibration"][0]
    out[method] = {"trials": n, "first_s": first, "timed_s": timed, "second_s": min(timed),
                   "per_trial": row["calibration"]["per_trial_max"]}
json.dump(out, sys.stdout)
"""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--timeout", type=int, default=600, help="seconds allowed per device count")
    args = ap.parse_args(argv)
    lm_trials, trials, budget = (32, 8, 2000) if args.quick else (400, 32, 20000)
    results, load, hangs = {}, {}, {}
    for nd in (1, 2, 4):
        env = dict(os.environ, XLA_FLAGS=f"--xla_force_host_platform_device_count={nd}", JAX_PLATFORMS="cpu")
        load[nd] = os.getloadavg()[0]
        argv = [str(nd), str(lm_trials), str(trials), str(budget), str(args.timeout)]
        proc = subprocess.run([sys.executable, "-c", CHILD, *argv], env=env, capture_output=True, text=True,
                              timeout=args.timeout + 60)
        if proc.returncode and "Timeout (" in proc.stderr:
            results[nd] = None  # a hang is a result too: reported in the table, not hidden
            hangs[nd] = proc.stderr[-4000:]
            print(nd, f"did not finish in {args.timeout} s; stacks:\n{proc.stderr[-1500:]}", flush=True)
            continue
        if proc.returncode:
            raise SystemExit(f"{nd} device(s): child failed\n{proc.stderr[-3000:]}")
        results[nd] = json.loads(proc.stdout)
        print(nd, {m: round(v["second_s"], 2) for m, v in results[nd].items()}, f"load {load[nd]:.2f}", flush=True)
    lines = [f"## Sharded Monte Carlo: the 8-pose study, LM over {lm_trials} trials, VSA-SMCS over {trials} "
             f"trials with budget {budget}", "",
             "| method | devices | first run s (incl. compile) | best of 2 timed runs s | speed-up vs 1 device | "
             "max \\|Δ\\| vs 1 device (µm, ″) | load average (1 min) at start |", "|---|---|---|---|---|---|---|"]
    import numpy as np

    for method in ("lm", "vsa-smcs"):
        base = results[1][method]
        for nd in (1, 2, 4):
            r = results[nd] and results[nd][method]
            if r is None:
                lines.append(f"| {method} | {nd} | did not finish in {args.timeout} s (stacks: JSON `hang_stacks`) "
                             f"| | | | {load[nd]:.2f} |")
                continue
            diff = np.max(np.abs(np.asarray(r["per_trial"]) - np.asarray(base["per_trial"])))
            lines.append(f"| {method} | {nd} | {r['first_s']:.1f} | {r['second_s']:.2f} | "
                         f"{base['second_s'] / r['second_s']:.2f}× | {diff:.2g} | {load[nd]:.2f} |")
    lines += ["", f"The host has {os.cpu_count()} CPU cores, shared with other work (see the load averages): N host "
              "devices share them, so more devices than cores cannot speed up further. Each device runs its own "
              "block of trials as an independent program (no collective; see `run_study`'s `n_devices`). "
              "On a multi-GPU machine the same `n_devices` argument spreads the trials over the local "
              "accelerators."]
    text = "\n".join(lines)
    print(text)
    write_results("sharding_quick" if args.quick else "sharding",
                  {"lm_trials": lm_trials, "trials": trials, "budget": budget,
                   "load_average_1min_at_start": {str(k): v for k, v in load.items()},
                   "timeout_s": args.timeout, "hang_stacks": {str(k): v for k, v in hangs.items()},
                   "results": {str(k): v for k, v in results.items()}}, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
