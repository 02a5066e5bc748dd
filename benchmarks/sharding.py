"""Monte Carlo calibrations sharded over JAX devices: speed-up with 1, 2, 4 devices.

    python benchmarks/sharding.py [--quick]

Each device count runs in its own process (JAX fixes the device count at start-up), with
``--xla_force_host_platform_device_count=N`` on the CPU: N host devices share this machine's
cores. Per device count: the seed-000 study (8 poses) with LM and VSA-SMCS over the same
trials, run once to compile and once timed; the per-trial numbers are compared with the
single-device run.
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
import json, sys, time
import jax
import stewart_jax  # noqa: F401
from stewart_jax._study import run_study
nd, trials, budget = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
kw = dict(n_trials=trials, n_devices=nd, keep_trials=True, log=lambda s: None,
          method_options={"vsa-smcs": {"max_evaluations": budget}})
out = {}
for method in ("lm", "vsa-smcs"):
    t0 = time.perf_counter(); run_study((method,), **kw); first = time.perf_counter() - t0
    t0 = time.perf_counter(); r = run_study((method,), **kw); second = time.perf_counter() - t0
    row = [v for k, v in r["rows"].items() if k != "Before calibration"][0]
    out[method] = {"first_s": first, "second_s": second, "per_trial": row["calibration"]["per_trial_max"]}
json.dump(out, sys.stdout)
"""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args(argv)
    trials, budget = (8, 2000) if args.quick else (32, 20000)
    results = {}
    for nd in (1, 2, 4):
        env = dict(os.environ, XLA_FLAGS=f"--xla_force_host_platform_device_count={nd}", JAX_PLATFORMS="cpu")
        proc = subprocess.run([sys.executable, "-c", CHILD, str(nd), str(trials), str(budget)], env=env,
                              capture_output=True, text=True, check=True)
        results[nd] = json.loads(proc.stdout)
        print(nd, {m: round(v["second_s"], 2) for m, v in results[nd].items()}, flush=True)
    lines = [f"## Sharded Monte Carlo: {trials} trials of the 8-pose study, VSA-SMCS budget {budget}", "",
             "| method | devices | first run s (incl. compile) | second run s | speed-up vs 1 device | "
             "max |Δ| vs 1 device (µm, ″) |", "|---|---|---|---|---|---|"]
    import numpy as np

    for method in ("lm", "vsa-smcs"):
        base = results[1][method]
        for nd in (1, 2, 4):
            r = results[nd][method]
            diff = np.max(np.abs(np.asarray(r["per_trial"]) - np.asarray(base["per_trial"])))
            lines.append(f"| {method} | {nd} | {r['first_s']:.1f} | {r['second_s']:.2f} | "
                         f"{base['second_s'] / r['second_s']:.2f}× | {diff:.2g} |")
    lines += ["", f"The host has {os.cpu_count()} CPU cores: N host devices share them, so more devices than "
              "cores cannot speed up further. On a multi-GPU or multi-host setup the same `n_devices` argument "
              "shards the trial axis over real accelerators (multi-host: call `jax.distributed.initialize()` "
              "first, then `run_study(..., n_devices=len(jax.devices()))`)."]
    text = "\n".join(lines)
    print(text)
    write_results("sharding_quick" if args.quick else "sharding",
                  {"trials": trials, "budget": budget, "results": {str(k): v for k, v in results.items()}}, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
