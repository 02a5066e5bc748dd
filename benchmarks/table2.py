"""Wang et al. (2018), Table 2 as a Monte Carlo, and the optimisers' convergence.

    python benchmarks/table2.py            # ≥100 seeds, 8-pose and 120-pose plans
    python benchmarks/table2.py --quick    # a few seeds, small budget (a smoke run)

For each plan: the paper's protocol (σ = 0.1 µm and 0.1″, Ω = nominal ± 10 mm), rows before
calibration, SMCS, VSA-SMCS (same evaluation budget), LM, VSA-SMCS+LM (and CS); columns the
max control error per component, median and 90th percentile over seeds, at the calibration
poses and at 42 fresh validation poses; the paper's row beside ours. Then the convergence
plot: best S against evaluations (median, 10–90 % band over seeds) for CS, SMCS, VSA-SMCS.

Results: ``benchmarks/results/table2_<plan>.{json,md}`` and ``convergence_<plan>.png``.
Runs in chunks with a checkpoint per plan under ``benchmarks/results/`` (``*.partial*`` files,
not committed): interrupt it and start it again to continue.
"""

from __future__ import annotations

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from _common import RESULTS, write_results  # noqa: E402

import stewart_jax  # noqa: E402,F401
from stewart_jax.calibration import METHOD_REGISTRY  # noqa: E402
from stewart_jax.study import format_study_table, run_study  # noqa: E402

CONVERGENCE_METHODS = ("cs", "smcs", "vsa-smcs")


def convergence_plot(result: dict, path: str) -> None:
    from stewart_jax import plotting

    labels = {m: METHOD_REGISTRY[m].label for m in CONVERGENCE_METHODS}
    histories = {labels[m]: result["rows"][labels[m]]["history"] for m in CONVERGENCE_METHODS
                 if labels[m] in result["rows"]}
    reference = {f"{label}: median final S": result["rows"][label]["cost_median"]
                 for label in ("LM (optimistix)", "VSA-SMCS+LM") if label in result["rows"]}
    title = f"Convergence on the Wang et al. 2018 protocol ({result['plan']}, {result['n_trials']} seeds)"
    plotting.show(plotting.plot_convergence(histories, reference=reference, title=title), path)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="4 seeds, budget 5000: a smoke run")
    ap.add_argument("--trials", type=int, default=100)
    ap.add_argument("--budget", type=int, default=100_000, help="evaluations for CS/SMCS/VSA-SMCS")
    ap.add_argument("--plans", default="paper8,plan120")
    ap.add_argument("--methods", default="cs,smcs,vsa-smcs,lm,vsa-smcs+lm")
    ap.add_argument("--chunk", type=int, default=25, help="trials per chunk (progress, checkpoint)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    if args.quick:
        args.trials, args.budget, args.chunk = 4, 5000, 4
    methods = [m for m in args.methods.split(",") if m]
    options = {m: {"max_evaluations": args.budget} for m in methods if not m.startswith("lm")}
    suffix = "_quick" if args.quick else ""
    for plan in args.plans.split(","):
        print(f"\n== plan {plan}: {args.trials} seeds, budget {args.budget} evaluations ==", flush=True)
        checkpoint = os.path.join(RESULTS, f"table2_{plan}{suffix}.partial.json")
        os.makedirs(RESULTS, exist_ok=True)
        result = run_study(methods, args.trials, args.seed, plan, method_options=options,
                           chunk_size=args.chunk, checkpoint=checkpoint)
        md = [
            f"## Seed-000 simulation study, plan `{plan}`: {args.trials} seeds, σ = 0.1 µm / 0.1″, "
            f"Ω = nominal ± 10 mm, metaheuristic budget {args.budget} evaluations",
            "",
            "Max control error at the calibration poses — median [90th percentile] over seeds "
            "(the paper's rows are one run's maximum):",
            "",
            format_study_table(result, "calibration"),
            "",
            "Max control error at 42 fresh validation poses — median [90th percentile] over seeds:",
            "",
            format_study_table(result, "validation"),
            "",
            "Wall time per chunk including compilation (s): "
            + "; ".join(f"{k}: {', '.join(f'{s:.1f}' for s in r['seconds_per_chunk_including_compile'])}"
                        for k, r in result["rows"].items()),
        ]
        text = "\n".join(md)
        print(text)
        write_results(f"table2_{plan}{suffix}", result, text)
        convergence_plot(result, os.path.join(RESULTS, f"convergence_{plan}{suffix}.png"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
