"""Time and peak memory of ``stewart-jax calibrate``, ``diagnose`` and ``study`` against size.

    python benchmarks/scale.py                                   # calibrate at 10³, 10⁴, 3·10⁴ poses
    python benchmarks/scale.py --commands calibrate,diagnose --sizes 1000,10000,100000
    python benchmarks/scale.py --commands study --sizes 1000,10000   # trials of lm-batched on paper8

For ``calibrate`` and ``diagnose`` the size ``m`` is the number of poses: a data set drawn
uniformly in the paper's travel (±1 mm, ±1°) is simulated on the 6-PSS (nominal → actual
geometry, pose noise 0.1 µm / 0.1″) and written as the CSV that ``stewart-jax simulate`` writes;
then ``stewart-jax calibrate FILE --json OUT --report OUT.md`` or ``stewart-jax diagnose FILE
--json OUT`` runs. For ``study`` it is the number of trials (``study --methods lm-batched
--trials m --checkpoint CK --json OUT``, the paper's 8 poses). Each command runs in a child of
its own small watcher process, so the peak resident memory recorded
(``getrusage(RUSAGE_CHILDREN).ru_maxrss`` in the watcher) is that run's alone; with its wall
time, exit status and whether the JSON result was written. Memory that grows linearly in ``m``
shows as a constant per-unit slope between sizes; the identification Jacobian alone is
6·m·36·8 bytes (17 MB at 10⁴ poses).

Results: ``benchmarks/results/scale.{json,md}`` (``scale_TAG`` with ``--tag``), rewritten after
every run.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import jax  # noqa: E402
from _common import write_results  # noqa: E402

import stewart_jax as sj  # noqa: E402
from stewart_jax.calibration._csv import write_csv  # noqa: E402
from stewart_jax.calibration._simulation import random_poses  # noqa: E402


def write_data(path: str, m: int, seed: int = 0) -> None:
    """``m`` simulated poses of the 6-PSS, written as ``stewart-jax simulate`` writes them."""
    nominal, actual = sj.mechanism.preset("nominal"), sj.mechanism.preset("actual")
    k_pose, k_noise = jax.random.split(jax.random.key(seed))
    sim = sj.simulate_measurements(k_noise, nominal, actual, random_poses(k_pose, m), 0.1, 0.1)
    write_csv(path, sim.data, reading_unit=nominal.reading_unit)


WATCHER = ("import resource, subprocess, sys; rc = subprocess.run(sys.argv[1:]).returncode; "
           "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, file=sys.stderr); sys.exit(rc)")


def _command(command: str, m: int, folder: str, out: str) -> list[str]:
    exe = os.path.join(os.path.dirname(sys.executable), "stewart-jax")
    if command == "study":
        return [exe, "study", "--methods", "lm-batched", "--trials", str(m), "--chunk", str(min(m, 1000)),
                "--checkpoint", os.path.join(folder, f"study_{m}.ckpt.json"), "--json", out]
    data = os.path.join(folder, f"poses_{m}.csv")
    if not os.path.exists(data):
        write_data(data, m)
    extra = ["--report", os.path.join(folder, f"report_{m}.md")] if command == "calibrate" else []
    return [exe, command, data, "--json", out, *extra]


def run_one(command: str, m: int, folder: str) -> dict:
    out = os.path.join(folder, f"{command}_{m}.json")
    cmd = _command(command, m, folder, out)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", WATCHER, *cmd], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    lines = proc.stderr.rstrip().splitlines()
    result = json.load(open(out)) if os.path.exists(out) else None
    status = None if result is None else {"calibrate": result.get("status"), "study": "—",
                                          "diagnose": f"named: {result.get('named_effect')}"}[command]
    return {
        "command": command,
        "size": m,
        "unit": "trials" if command == "study" else "poses",
        "wall_s": round(wall, 2),
        "peak_rss_mib": round(int(lines[-1]) / 1024, 1),
        "exit_status": proc.returncode,
        "result_written": result is not None,
        "status": status,
        "stderr_tail": "\n".join(lines[:-1])[-600:],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--commands", default="calibrate", help="comma-separated: calibrate, diagnose, study")
    ap.add_argument("--sizes", default="1000,10000,30000", help="comma-separated poses (trials for study)")
    ap.add_argument("--tag", default="", help="results file suffix")
    args = ap.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    commands = args.commands.split(",")
    unknown = sorted(set(commands) - {"calibrate", "diagnose", "study"})
    if unknown:
        ap.error(f"unknown command(s) {unknown}")
    rows = []
    name = "scale" + (f"_{args.tag}" if args.tag else "")
    with tempfile.TemporaryDirectory() as folder:
        for command in commands:
            for m in sizes:
                rows.append(run_one(command, m, folder))
                print(json.dumps({k: v for k, v in rows[-1].items() if k != "stderr_tail"}), flush=True)
                md = ["| command | size | wall (s) | peak RSS (MiB) | exit | result written | status |",
                      "|---|---|---|---|---|---|---|"]
                md += [f"| {r['command']} | {r['size']} {r['unit']} | {r['wall_s']} | {r['peak_rss_mib']} | "
                       f"{r['exit_status']} | {r['result_written']} | {r['status']} |" for r in rows]
                md.append("\nPeak RSS is each run's own high-water mark (its watcher process's children).")
                write_results(name, {"rows": rows}, "\n".join(md))


if __name__ == "__main__":
    main()
