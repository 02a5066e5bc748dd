"""Time and peak memory of ``stewart-jax calibrate`` against the number of poses.

    python benchmarks/scale.py                  # 10³, 10⁴ and 3·10⁴ poses (a few minutes)
    python benchmarks/scale.py --sizes 1000     # one size

For each size ``m`` a data set of ``m`` poses drawn uniformly in the paper's travel (±1 mm, ±1°)
is simulated on the 6-PSS (nominal → actual geometry, pose noise 0.1 µm / 0.1″) and written as
the CSV that ``stewart-jax simulate`` writes; then ``stewart-jax calibrate FILE --json OUT
--report OUT.md`` runs in a child process, and its wall time and peak resident memory
(``getrusage(RUSAGE_CHILDREN).ru_maxrss``, one child per size) are recorded, with its exit
status and whether the JSON result was written. Memory that grows linearly in ``m`` shows as a
constant per-pose slope between sizes; the identification Jacobian alone is 6·m·36·8 bytes
(17 MB at 10⁴ poses).

Results: ``benchmarks/results/scale.{json,md}``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
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


def run_one(m: int, folder: str) -> dict:
    data = os.path.join(folder, f"poses_{m}.csv")
    write_data(data, m)
    out = os.path.join(folder, f"result_{m}.json")
    cmd = [os.path.join(os.path.dirname(sys.executable), "stewart-jax"), "calibrate", data, "--json", out,
           "--report", os.path.join(folder, f"report_{m}.md")]
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    peak_kib = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    result = json.load(open(out)) if os.path.exists(out) else None
    return {
        "poses": m,
        "wall_s": round(wall, 2),
        "peak_rss_mib": round(peak_kib / 1024, 1),
        "peak_rss_is_running_max": peak_kib == before,
        "exit_status": proc.returncode,
        "result_written": result is not None,
        "status": None if result is None else result.get("status"),
        "stderr_tail": proc.stderr[-400:],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1000,10000,30000", help="comma-separated pose counts")
    args = ap.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for m in sizes:
            rows.append(run_one(m, folder))
            print(json.dumps({k: v for k, v in rows[-1].items() if k != "stderr_tail"}), flush=True)
    md = ["| poses | wall (s) | peak RSS (MiB) | exit | result written | status |", "|---|---|---|---|---|---|"]
    md += [f"| {r['poses']} | {r['wall_s']} | {r['peak_rss_mib']} | {r['exit_status']} | {r['result_written']} | "
           f"{r['status']} |" for r in rows]
    md.append("\nPeak RSS is the child's high-water mark; where a smaller run's was higher, the column repeats "
              "it (`peak_rss_is_running_max` in the JSON), so the sizes run smallest first.")
    write_results("scale", {"rows": rows}, "\n".join(md))


if __name__ == "__main__":
    main()
