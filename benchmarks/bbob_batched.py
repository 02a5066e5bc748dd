"""The batched BBOB suite beside the reference implementations' loops, in one run, with targets.

Hansen, Auger, Ros, Mersmann, Tušar & Brockhoff (2021), "COCO: a platform for comparing
continuous optimizers in a black-box setting", Optimization Methods and Software 36(1):114–144;
Hansen, Finck, Ros & Auger (2009), "Real-parameter black-box optimization benchmarking 2009:
noiseless functions definitions" (INRIA RR-6829).

Ours: every (function, instance) of a dimension in one compiled program, grouped by function
(``bbob.batched``: ``lax.map`` over the functions, each ``vmap``-ing the solver over its
instances), compile time apart. The references: pycma for CMA-ES and SciPy's Nelder–Mead for
ours, each a Python loop over the same problems (``cocoex``'s C implementation, no observer), the
settings and seeds of ``bbob.py``'s COCO runs, stopping at ``f_opt + 1e-8`` or the budget.
Problems solved per second, each side's wall time, in the same process, one after the other.

Targets (the project's): compile at most 10 s per method and dimension; CMA-ES batched at least
100× pycma's loop in problems solved per second; Nelder–Mead batched at least as fast as SciPy's
loop.

    python benchmarks/bbob_batched.py                 # CMA-ES and NM, 2-, 5-, 10-D, 10 instances
    python benchmarks/bbob_batched.py --quick         # f1, f8, f15 in 2-D, 2 instances (a smoke test)
    python benchmarks/bbob_batched.py --dims 2 --instances 1-100 --name bbob_batched_wide
                                                      # 100 instances per function: a wider batch
"""

from __future__ import annotations

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import bbob  # noqa: E402  (sets float64)
from _common import RESULTS, expand, write_results  # noqa: E402

TARGETS = {
    "CMA-ES": ("pycma", 100.0, "CMA-ES batched at least 100× pycma's loop, problems solved per second"),
    "NM": ("scipy-NM", 1.0, "Nelder–Mead batched at least as fast as SciPy's loop, problems solved per second"),
}
COMPILE_TARGET_S = 10.0


def reference_loop(name: str, functions, dim: int, instances, budget_factor: int) -> dict:
    """``name`` (a reference of ``bbob.run_reference``) on every problem, no COCO observer."""
    import cocoex

    suite = cocoex.Suite("bbob", f"instances: {_ranges(instances)}",
                         f"function_indices: {','.join(map(str, functions))} dimensions: {dim}")
    solved = n = 0
    t0 = time.perf_counter()
    for problem in suite:
        f, inst = problem.id_function, problem.id_instance
        bbob.run_reference(name, problem, budget_factor * dim, 1000 * f + 100 * inst + dim)
        solved += bool(problem.final_target_hit)
        n += 1
        problem.free()
    seconds = time.perf_counter() - t0
    return {"method": name, "dim": dim, "problems": n, "solved": solved, "seconds": seconds,
            "solved_per_s": solved / seconds}


def _ranges(numbers) -> str:
    """``1-5,101-105`` for COCO's option string (which refuses a long list of single numbers)."""
    out, numbers = [], sorted(numbers)
    start = prev = numbers[0]
    for n in [*numbers[1:], None]:
        if n is not None and n == prev + 1:
            prev = n
            continue
        out.append(f"{start}-{prev}" if prev > start else f"{start}")
        if n is not None:
            start = prev = n
    return ",".join(out)


def verdicts(ours: list[dict], references: list[dict]) -> list[dict]:
    rows = []
    for b in ours:
        rows.append({"target": f"compile at most {COMPILE_TARGET_S:g} s per method and dimension",
                     "method": b["method"], "dim": b["dim"], "measured": b["compile_s"], "unit": "s",
                     "met": b["compile_s"] <= COMPILE_TARGET_S})
        if b["method"] not in TARGETS:
            continue
        ref_name, factor, text = TARGETS[b["method"]]
        ref = next((r for r in references if r["method"] == ref_name and r["dim"] == b["dim"]), None)
        if ref is None or ref["solved_per_s"] == 0:
            continue
        ratio = b["solved_per_s"] / ref["solved_per_s"]
        rows.append({"target": text, "method": b["method"], "dim": b["dim"], "measured": ratio, "unit": "×",
                     "met": ratio >= factor})
    return rows


def markdown(payload: dict) -> str:
    lines = [
        "# Batched BBOB beside the reference loops, one run",
        "",
        f"Functions {_ranges(payload['functions'])} of COCO's bbob suite, instances {_ranges(payload['instances'])}, "
        f"budget {payload['budget_factor']} × D evaluations, stopping at f_opt + 1e-8. Ours: one program per "
        "method and dimension, grouped by function (compile apart); the references: Python loops over "
        "`cocoex`'s problems, no observer.",
        "",
        "| method | D | problems | solved | run s | compile s | solved/s | reference | reference solved | "
        "reference s | reference solved/s | ratio |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for b in payload["ours"]:
        ref_name = TARGETS.get(b["method"], (None,))[0]
        ref = next((r for r in payload["references"] if r["method"] == ref_name and r["dim"] == b["dim"]), None)
        tail = ("| – | – | – | – | – |" if ref is None else
                f"| {ref['method']} | {ref['solved']}/{ref['problems']} | {ref['seconds']:.1f} | "
                f"{ref['solved_per_s']:.2f} | "
                f"{b['solved_per_s'] / ref['solved_per_s']:.2f}× |" if ref['solved_per_s'] else "| – |")
        lines.append(f"| {b['method']} | {b['dim']} | {b['problems']} | {b['solved']} | {b['run_s']:.2f} | "
                     f"{b['compile_s']:.1f} | {b['solved_per_s']:.2f} " + tail)
    lines += ["", "## Targets", "", "| target | method | D | measured | verdict |", "|---|---|---|---|---|"]
    for v in payload["verdicts"]:
        lines.append(f"| {v['target']} | {v['method']} | {v['dim']} | {v['measured']:.2f} {v['unit']} | "
                     f"{'met' if v['met'] else 'missed'} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="f1, f8, f15 in 2-D, instances 1-2, budget 200 × D")
    ap.add_argument("--methods", default="CMA-ES,NM")
    ap.add_argument("--dims", default="2,5,10")
    ap.add_argument("--instances", default="1-5,101-105")
    ap.add_argument("--budget-factor", type=int, default=1000)
    ap.add_argument("--out", default=RESULTS, help="folder for the results")
    ap.add_argument("--name", default=None, help="results file name (default bbob_batched, or bbob_batched_quick)")
    args = ap.parse_args(argv)

    if args.quick:
        functions, dims, instances, budget_factor = [1, 8, 15], [2], [1, 2], 200
    else:
        functions, dims, instances = list(range(1, 25)), expand(args.dims), expand(args.instances)
        budget_factor = args.budget_factor
    unknown = [m for m in args.methods.split(",") if m not in bbob.OURS]
    if unknown:
        raise SystemExit(f"unknown method(s) {unknown}; choose from {list(bbob.OURS)}")
    t_start = time.perf_counter()
    ours, references = [], []
    for alg in args.methods.split(","):
        for dim in dims:
            b = bbob.batched(alg, functions, dim, instances, budget_factor)
            print(f"batched {alg} {dim}-D: {b['solved']}/{b['problems']} solved in {b['run_s']:.2f} s "
                  f"(compile {b['compile_s']:.1f} s)", flush=True)
            ours.append(b)
            if alg in TARGETS:
                r = reference_loop(TARGETS[alg][0], functions, dim, instances, budget_factor)
                print(f"loop {r['method']} {dim}-D: {r['solved']}/{r['problems']} solved in {r['seconds']:.1f} s",
                      flush=True)
                references.append(r)
    payload = {"functions": functions, "dims": dims, "instances": instances, "budget_factor": budget_factor,
               "ours": ours, "references": references, "verdicts": verdicts(ours, references),
               "wall_s": time.perf_counter() - t_start, "versions": bbob._versions()}
    name = args.name or ("bbob_batched_quick" if args.quick else "bbob_batched")
    write_results(name, payload, markdown(payload), out=args.out)
    print(markdown(payload))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
