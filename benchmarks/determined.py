"""How many parameter directions the data determine to better than the prior scale (1 mm, 1 mrad;
half of it on the point route), per preset and plan, on the pose route (pose noise σ = 0.1 µm /
0.1″, the command line's default, and 1 µm / 1″) and the point route (the default targets and
tracker, σ = 5 µm + 2.5 µm/m, every target seen): the counts ``stewart-jax calibrate`` reports
as ``determined_directions``, and the largest data std along a held direction (prior scales).

    python benchmarks/determined.py
"""

from __future__ import annotations

import os
import sys

import jax
import jax.numpy as jnp
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _common import write_results  # noqa: E402

from stewart_jax.calibration import plan_poses, reachable_travel  # noqa: E402
from stewart_jax.calibration._assessment import _determination, _whitened_model  # noqa: E402
from stewart_jax.calibration._determined import determine, prior_scale  # noqa: E402
from stewart_jax.calibration._identifiability import kinematic_snapshot  # noqa: E402
from stewart_jax.calibration._points import POINTS_DETERMINED_STD, _jacobian_at, _problem, start_values  # noqa: E402
from stewart_jax.calibration._points_simulation import default_targets, simulate_points  # noqa: E402
from stewart_jax.mechanism import preset, presets  # noqa: E402


def point_route(nominal, poses):
    targets = default_targets(nominal)
    sim = simulate_points(jax.random.key(0), nominal, nominal, targets, poses, visible=1.0)
    data = sim.data
    problem = _problem(data, targets, nominal, 5.0, 2.5, start_values(data, targets, nominal))
    y0 = jnp.concatenate([nominal.params, jnp.zeros(6)])
    n_pad = problem.points.shape[0]
    rows = np.concatenate([np.arange(3 * len(data.points)), 3 * n_pad + np.arange(3 * len(data.references))])
    return determine(np.asarray(_jacobian_at(problem, nominal, y0))[rows], prior_scale(nominal.param_units, 6),
                     POINTS_DETERMINED_STD)


def main():
    rows = []
    for name in presets():
        nominal = preset(name)
        for plan in ("paper8", "plan120"):
            poses = plan_poses(plan, jax.random.key(0), reachable_travel(nominal))
            row = {"preset": name, "family": nominal.family, "plan": plan, "n_params": nominal.n_params}
            for s in (0.1, 1.0):
                det = _determination(_whitened_model(kinematic_snapshot(nominal, np.asarray(poses), s, s),
                                                     nominal.n_params), nominal.param_units)
                row[f"pose_determined_sigma_{s}"] = det.n_determined
                held = det.singular_values[det.n_determined:]
                row[f"pose_worst_held_std_sigma_{s}"] = float(1 / held.min()) if len(held) and held.min() > 0 \
                    else (None if len(held) else 0.0)
            if plan == "plan120":
                det = point_route(nominal, poses)
                row["points_determined"] = det.n_determined
                row["points_unknowns"] = nominal.n_params + 6
            rows.append(row)
            print(row, flush=True)
    lines = ["# Determined directions per preset and plan", "",
             "| preset | family | plan | parameters | pose route, 0.1 µm/0.1″ | pose route, 1 µm/1″ | "
             "points (default targets, 5 µm + 2.5 µm/m), of n + 6 |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        pts = f"{r['points_determined']} of {r['points_unknowns']}" if "points_determined" in r else "—"
        lines.append(f"| {r['preset']} | {r['family']} | {r['plan']} | {r['n_params']} | "
                     f"{r['pose_determined_sigma_0.1']} | {r['pose_determined_sigma_1.0']} | {pts} |")
    write_results("determined", {"rows": rows}, "\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
