"""Calibration of every mechanism preset, Table 2 style, and IK throughput per family.

    python benchmarks/hexapods.py            # 100 seeds per preset, LM and VSA-SMCS
    python benchmarks/hexapods.py --quick    # 4 seeds, small budget (a smoke run)

Protocol, the same for every preset (the 2018 paper's §4 experiment, scaled to each mechanism):
the 120-pose plan inside the mechanism's reachable travel (``reachable_travel``: its published
travel, scaled down until every corner of the box is reachable), poses measured by a 3-ball laser
tracker on the moving joints' circle (σ = 3 µm per coordinate), the true mechanism the nominal one
with every parameter moved by N(0, 0.5 mm) (fixed per seed, ``stewart-jax study --perturb-mm``),
Ω = nominal ± 5 mm. For the paper's mechanism the true one is its Table 1 "actual" geometry. Columns:
median [90th percentile] over seeds of the max control error at the 120 calibration poses and at 42
validation poses. Then IK throughput of each family (jit, 65 536 poses, best of 5).

Results: ``benchmarks/results/hexapods.{json,md}``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import jax  # noqa: E402
import numpy as np  # noqa: E402
from _common import write_results  # noqa: E402

import stewart_jax as sj  # noqa: E402
from stewart_jax.calibration import perturbed, reachable_travel  # noqa: E402
from stewart_jax.mechanism import preset  # noqa: E402
from stewart_jax.study import format_study_table, run_study  # noqa: E402

PRESETS = ("nominal", "rubin_camera", "rubin_m2", "fast_stewart")


def ik_throughput(name: str, n: int = 65_536, repeats: int = 5) -> dict:
    m = preset(name)
    half = reachable_travel(m)
    poses = sj.calibration.random_poses(jax.random.key(0), n, half=half)
    f = jax.jit(lambda mm, p: mm.solve_inverse_kinematics(p).readings)
    t0 = time.perf_counter()
    jax.block_until_ready(f(m, poses))
    compile_s = time.perf_counter() - t0
    best = min(_timed(f, m, poses) for _ in range(repeats))
    return {"preset": name, "family": m.family, "poses": n, "compile_s": compile_s, "best_s": best,
            "leg_ik_per_s": 6 * n / best}


def _timed(f, *args) -> float:
    t0 = time.perf_counter()
    jax.block_until_ready(f(*args))
    return time.perf_counter() - t0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--trials", type=int, default=None)
    args = ap.parse_args(argv)
    trials = args.trials or (4 if args.quick else 100)
    budget = 5_000 if args.quick else 50_000
    studies, md = {}, []
    for name in PRESETS:
        nominal = preset(name)
        actual = preset("actual") if name == "nominal" else perturbed(
            nominal, jax.random.fold_in(jax.random.key(0), 1_000_003), 0.5)
        print(f"{name}: {trials} trials", file=sys.stderr, flush=True)
        res = run_study(("lm", "vsa-smcs"), trials, 0, "plan120", 3.0, 3.0, True, 5.0,
                        {"vsa-smcs": {"max_evaluations": budget}}, chunk_size=min(trials, 25),
                        nominal=nominal, actual=actual)
        studies[name] = res
        md += [f"## {name} ({nominal.family}, {nominal.n_params} parameters; travel half-widths "
               f"{np.round(reachable_travel(nominal), 5).tolist()} mm, rad)", "",
               "At the 120 calibration poses:", "", format_study_table(res, "calibration"), "",
               "At 42 validation poses:", "", format_study_table(res, "validation"), ""]
    rows = [ik_throughput(n) for n in PRESETS]
    md += ["## IK throughput (jit, one call on 65 536 poses, best of 5)", "",
           "| preset | family | leg IK/s | compile s |", "|---|---|---|---|"]
    md += [f"| {r['preset']} | {r['family']} | {r['leg_ik_per_s']:.3g} | {r['compile_s']:.2f} |" for r in rows]
    summary = {name: {k: v for k, v in s.items() if k in ("rows", "components", "units", "n_trials")}
               for name, s in studies.items()}
    write_results("hexapods" + ("_quick" if args.quick else ""),
                  {"trials": trials, "vsa_smcs_budget": budget, "studies": summary, "ik": rows}, "\n".join(md))
    print("\n".join(md))
    return 0


if __name__ == "__main__":
    sys.exit(main())
