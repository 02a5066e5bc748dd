"""SMCS vs VSA-SMCS with their unstated settings explored, paired statistics, and the baselines.

    python benchmarks/comparison.py            # the full comparison (< 1 h on 2 cores)
    python benchmarks/comparison.py --quick    # small sizes, a few minutes (labelled "quick")

The claim under test: Wang H., Cao X. et al., "Improved cuckoo calibration method of space
telescope secondary mirror adjusting mechanism", Infrared and Laser Engineering 47(5), 2018,
Table 2 — VSA-SMCS (§2.2–2.3) calibrates better than SMCS (§2.1). The paper never states d, sp₁,
p, lu (eqs. 11–12), nor SMCS's simplex settings, so:

1. **Sensitivity.** VSA-SMCS over a Latin hypercube of (d, sp₁, p, lu) (fixed seed; d ∈ [0.1, 4]
   and p ∈ [1, 30] — the paper's range — log-uniform, sp₁ ∈ [0, 1], lu ∈ [0, 0.5]) plus the
   library default, × the tuning seeds, vmapped over settings and seeds in one compiled call per
   problem; SMCS over a Latin hypercube of (pa, α, the four Nelder–Mead coefficients) for a few
   numbers of worst nests (one compiled call each). Final S and validation control error per
   setting and seed.
2. **Tuned vs default on fresh seeds.** The tuned setting of each method (lowest median final S
   on the tuning seeds) and the default are run on held-out seeds (trials 1000 …) beside the
   baselines — CS, CMA-ES (Hansen 2016), DE/rand/1/bin (Storn & Price 1997), PSO (Kennedy &
   Eberhart 1995; Shi & Eberhart 1998), bounded Nelder–Mead, VSA-SMCS restarted 4 × (budget/4),
   LM (optimistix) and the batched LM — at one evaluation budget per problem.
   **Common random numbers:** for a seed, every method sees the same simulated data and the same
   optimiser key, so every population method starts from the same 37 points uniform in Ω.
3. **Paired statistics** for each pair of methods: Wilcoxon signed-rank p-value and the bootstrap
   95 % interval of the median ratio of final S (and of validation error), over held-out seeds
   (``stewart_jax.study.paired_comparison``).
4. **Budget curves** (paper8): best S within each budget from the histories, and the validation
   error of runs at each budget of a grid; 10–90 % bands over seeds.
5. **Moré–Wild data profiles** over the problem set (plans, noise levels, a hidden-effect data
   set, a strut-hexapod family) × held-out seeds, τ = 10⁻¹ and 10⁻³, f(x₀) = S at the nominal
   parameters. LM's evaluations count ``(steps + 1)·(n + 1)`` — the cost of a forward-difference
   Jacobian per step — so that it sits on the same axis.

Problems: ``paper8`` (the paper's 8 random poses, σ = 0.1 µm / 0.1″, Ω = nominal ± 10 mm),
``plan120`` (the 120-pose plan), ``noise10`` (8 poses, σ = 1 µm / 1″), ``hidden`` (24 random poses
with a hidden backlash 5 × the noise, ``stewart_jax.discrepancy.simulate_hidden_effect``; its
validation error is against the geometric truth) and ``rubin_m2`` (the Rubin M2 strut hexapod,
42 parameters, true geometry the nominal one moved by N(0, 0.5 mm), 8 random poses, Ω = ± 5 mm).

Results: ``benchmarks/results/comparison.{json,md}`` (``comparison_quick.*`` with ``--quick``)
and ``comparison_*.png``.
"""

from __future__ import annotations

import argparse
import itertools
import math
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from _common import RESULTS, write_results  # noqa: E402

import stewart_jax as sj  # noqa: E402
from stewart_jax import discrepancy as dc  # noqa: E402
from stewart_jax.calibration import METHOD_REGISTRY, calibrate_batch, perturbed, reachable_travel  # noqa: E402
from stewart_jax.mechanism import preset  # noqa: E402
from stewart_jax.optimise import SMCS, VSASMCS, SimplexCoefficients, minimise  # noqa: E402
from stewart_jax.optimise._result import status_code  # noqa: E402  (private: statuses as integers for the arrays)
from stewart_jax.study import (  # noqa: E402
    best_within_budgets,
    data_profiles,
    paired_comparison,
    simulate_trials,
    trial_keys,
)

UM_PER_MM, ARCSEC_PER_RAD = 1e3, 180.0 / math.pi * 3600.0
HELDOUT_FIRST = 1000
VSA_RANGES = {"d": (0.1, 4.0, "log"), "sp_1": (0.0, 1.0, "lin"), "p": (1.0, 30.0, "log"), "lu": (0.0, 0.5, "lin")}
VSA_DEFAULT = {"d": 1.0, "sp_1": 0.1, "p": 10.0, "lu": 0.25}
SMCS_RANGES = {"pa": (0.05, 0.5, "lin"), "alpha": (1e-3, 0.1, "log"), "reflection": (0.5, 1.5, "lin"),
               "expansion": (1.5, 3.0, "lin"), "contraction": (0.25, 0.75, "lin"), "shrink": (0.25, 0.75, "lin")}
SMCS_DEFAULT = {"pa": 0.25, "alpha": 0.01, "reflection": 1.0, "expansion": 2.0, "contraction": 0.5, "shrink": 0.5}
BOX_BASELINES = ("cs", "cma-es", "de", "pso", "nelder-mead")
LM_METHODS = ("lm", "lm-batched")


# ------------------------------------------------------------------------------ problems

class Problem:
    """A batch of simulated calibrations (one per seed) with a validation-error function."""

    def __init__(self, name, description, problems, opt_keys, val_fn, n_params):
        self.name, self.description = name, description
        self.problems, self.opt_keys, self.val_fn, self.n_params = problems, opt_keys, val_fn, n_params
        self.f0 = np.asarray(jax.vmap(lambda p: p.cost(p.initial))(problems))


def _validation(nominal, actual, validation):
    """params (T, n) → (max |dx, dy, dz| in µm, max |φ, θ, ψ| in ″) at the validation poses."""

    @jax.jit
    def fn(params):
        def one(u, v):
            e = sj.control_error(nominal.with_params(u), actual, v)
            err = jnp.where(jnp.all(e.converged), jnp.abs(e.errors), jnp.inf)
            return jnp.max(err[:, :3]) * UM_PER_MM, jnp.max(err[:, 3:]) * ARCSEC_PER_RAD

        return jax.vmap(one)(params, validation)

    return lambda params: tuple(np.asarray(x) for x in fn(jnp.asarray(params)))


def make_problem(name: str, n_seeds: int, first: int) -> Problem:
    keys = trial_keys(0, n_seeds, first)
    if name in ("paper8", "plan120", "noise10"):
        nominal, actual = sj.nominal_geometry(), sj.actual_geometry()
        plan = "plan120" if name == "plan120" else "paper8"
        sigma = 1.0 if name == "noise10" else 0.1
        probs, _, val, opt_keys = simulate_trials(keys, nominal, actual, plan, sigma, sigma)
        desc = {"paper8": "6-PSS (Table 1), 8 random poses, σ = 0.1 µm / 0.1″, Ω = ±10 mm",
                "plan120": "6-PSS (Table 1), the 120-pose plan, σ = 0.1 µm / 0.1″, Ω = ±10 mm",
                "noise10": "6-PSS (Table 1), 8 random poses, σ = 1 µm / 1″ (10× noise), Ω = ±10 mm"}[name]
        return Problem(name, desc, probs, opt_keys, _validation(nominal, actual, val), 36)
    if name == "rubin_m2":
        nominal = preset("rubin_m2")
        actual = perturbed(nominal, jax.random.key(2018), 0.5)
        probs, _, val, opt_keys = simulate_trials(keys, nominal, actual, "paper8", 0.1, 0.1, half_width=5.0)
        return Problem(name, "Rubin M2 strut hexapod (6-UPS, 42 parameters), true = nominal + N(0, 0.5 mm), "
                       "8 random poses, σ = 0.1 µm / 0.1″, Ω = ±5 mm", probs, opt_keys,
                       _validation(nominal, actual, val), nominal.params.shape[0])
    if name == "hidden":
        nominal, actual = sj.nominal_geometry(), sj.actual_geometry()
        seeds = range(first, first + n_seeds)
        data = [dc.simulate_hidden_effect(s, "backlash", 5.0, n_random=24, plan=False).data for s in seeds]
        stacked = jax.tree.map(lambda *a: jnp.stack([jnp.asarray(x) for x in a]), *data)
        probs = jax.vmap(lambda d: sj.calibration_problem(d, nominal, 10.0))(stacked)
        val = jax.vmap(lambda k: sj.calibration.random_poses(k, 42, half=tuple(float(h) for h in reachable_travel(
            nominal))))(jax.random.split(jax.random.key(7), n_seeds))
        opt_keys = jax.vmap(lambda k: jax.random.split(k, 4)[3])(keys)
        return Problem(name, "6-PSS, 24 random poses with a hidden backlash 5× the noise (σ = 0.1 µm / 0.1″); "
                       "validation error against the geometric truth", probs, opt_keys,
                       _validation(nominal, actual, val), 36)
    raise ValueError(f"unknown problem {name!r}")


# ------------------------------------------------------------------------------ designs

def design(ranges: dict, n: int, seed: int) -> list[dict]:
    """``n`` settings of a Latin hypercube over ``ranges`` (fixed seed; log-uniform where marked)."""
    from scipy.stats import qmc

    if n <= 0:
        return []
    u = qmc.LatinHypercube(d=len(ranges), seed=seed).random(n)
    out = []
    for row in u:
        s = {}
        for (k, (lo, hi, scale)), v in zip(ranges.items(), row, strict=True):
            s[k] = float(math.exp(math.log(lo) + v * (math.log(hi) - math.log(lo))) if scale == "log"
                         else lo + v * (hi - lo))
        out.append(s)
    return out


def _cost(u, problem):
    return problem.cost(u)


def _stack(settings: list[dict], keys) -> dict:
    return {k: jnp.asarray([s[k] for s in settings], jnp.float64) for k in keys}


_SWEEPS: dict = {}


def chunked(sweep, prob: Problem, settings: list[dict], *rest):
    """``sweep`` over ``settings`` in chunks of equal size (the last padded by repeating its last
    setting, so that one compilation serves every chunk): bounds the memory of the 120-pose
    objective, whose vmapped intermediates grow with settings × seeds × nests × poses."""
    n_poses = prob.problems.data.poses.shape[-2]
    size = len(settings) if n_poses <= 24 else max(1, 24 * 30 // len(prob.f0))
    outs = []
    for i in range(0, len(settings), size):
        part = settings[i:i + size]
        pad = size - len(part) if len(settings) > size else 0
        out = sweep(prob, part + [part[-1]] * pad, *rest)
        outs.append([np.asarray(x)[:len(part)] for x in out[:4]])
    return [np.concatenate([o[j] for o in outs]) for j in range(4)]


def vsa_sweep(prob: Problem, settings: list[dict], budget: int):
    """VSA-SMCS at every setting × seed: one compiled call. Returns (params, cost, hist_cost, hist_n,
    status) with leading axes (settings, seeds)."""
    key = ("vsa", len(settings), budget)
    if key not in _SWEEPS:
        def one(s, p, k):
            solver = VSASMCS(d=s["d"], sp_1=s["sp_1"], p=s["p"], lu=s["lu"])
            r = minimise(_cost, solver, p.lower, p.upper, k, max_evaluations=budget, args=p)
            return r.params, r.cost, r.history_cost, r.history_evaluations, r.status

        _SWEEPS[key] = jax.jit(jax.vmap(jax.vmap(one, (None, 0, 0)), (0, None, None)))
    return _SWEEPS[key](_stack(settings, VSA_RANGES), prob.problems, prob.opt_keys)


def smcs_sweep(prob: Problem, settings: list[dict], n_worst: int, budget: int):
    """SMCS at every setting × seed for one ``n_worst`` (a static size): one compiled call."""
    key = ("smcs", len(settings), n_worst, budget)
    if key not in _SWEEPS:
        def one(s, p, k):
            coef = SimplexCoefficients(s["reflection"], s["expansion"], s["contraction"], s["shrink"])
            solver = SMCS(n_worst=n_worst, pa=s["pa"], alpha=s["alpha"], coefficients=coef)
            r = minimise(_cost, solver, p.lower, p.upper, k, max_evaluations=budget, args=p)
            return r.params, r.cost, r.history_cost, r.history_evaluations, r.status

        _SWEEPS[key] = jax.jit(jax.vmap(jax.vmap(one, (None, 0, 0)), (0, None, None)))
    return _SWEEPS[key](_stack(settings, SMCS_RANGES), prob.problems, prob.opt_keys)


def restarts(prob: Problem, budget: int, n_restarts: int = 4):
    """VSA-SMCS (default settings) run ``n_restarts`` times with budget/n_restarts each; best kept.
    The restart's history is the running best over the runs laid end to end."""
    r = calibrate_batch_keys(prob, "vsa-smcs", budget // n_restarts, n_restarts)
    cost = np.asarray(r.cost)  # (restarts, seeds)
    best = np.argmin(cost, axis=0)
    idx = np.arange(cost.shape[1])
    hc, hn = np.asarray(r.history_cost), np.asarray(r.history_evaluations)
    offs = (np.arange(n_restarts) * (budget // n_restarts))[:, None, None]
    hist_n = np.concatenate(list(hn + offs), axis=-1)
    hist_c = np.minimum.accumulate(np.concatenate(list(hc), axis=-1), axis=-1)
    return (np.asarray(r.params)[best, idx], cost[best, idx], hist_c, hist_n,
            np.asarray(r.n_evaluations).sum(0), status_code(r.status)[best, idx])


def calibrate_batch_keys(prob: Problem, method: str, budget: int, n_runs: int):
    """``n_runs`` independent runs per seed (keys folded from the seed's optimiser key)."""
    keys = jax.vmap(lambda i: jax.vmap(lambda k: jax.random.fold_in(k, i))(prob.opt_keys))(jnp.arange(n_runs))
    return jax.vmap(lambda k: calibrate_batch(prob.problems, method, k, max_evaluations=budget))(keys)


# ------------------------------------------------------------------------------ runs

def run_method(prob: Problem, label: str, budget: int, tuned: dict) -> dict:
    """One method on every held-out seed → per-seed numbers (JSON-ready)."""
    t0 = time.perf_counter()
    n = prob.n_params
    if label in ("vsa-smcs", "vsa-smcs (tuned)"):
        s = VSA_DEFAULT if label == "vsa-smcs" else tuned["vsa-smcs"]
        params, cost, hc, hn, st = vsa_sweep(prob, [s], budget)
        params, cost, hc, hn, st = (np.asarray(x)[0] for x in (params, cost, hc, hn, status_code(st)))
        ne = hn[:, -1]
    elif label in ("smcs", "smcs (tuned)"):
        s = {**SMCS_DEFAULT, "n_worst": 12} if label == "smcs" else tuned["smcs"]
        params, cost, hc, hn, st = smcs_sweep(prob, [s], int(s["n_worst"]), budget)
        params, cost, hc, hn, st = (np.asarray(x)[0] for x in (params, cost, hc, hn, status_code(st)))
        ne = hn[:, -1]
    elif label == "vsa-smcs ×4 restarts":
        params, cost, hc, hn, ne, st = restarts(prob, budget)
    elif label in LM_METHODS:
        r = calibrate_batch(prob.problems, label, prob.opt_keys)
        params, cost = np.asarray(r.params), np.asarray(r.cost)
        ne = np.asarray(r.n_evaluations) * (n + 1)
        hc, hn = cost[:, None], ne[:, None]
        st = status_code(r.status)
    else:
        r = calibrate_batch(prob.problems, label, prob.opt_keys, max_evaluations=budget)
        params, cost = np.asarray(r.params), np.asarray(r.cost)
        hc, hn, ne, st = (np.asarray(r.history_cost), np.asarray(r.history_evaluations),
                          np.asarray(r.n_evaluations), status_code(r.status))
    val_um, val_as = prob.val_fn(params)
    return {"cost": np.asarray(cost).tolist(), "validation_um": val_um.tolist(), "validation_arcsec": val_as.tolist(),
            "n_evaluations": np.asarray(ne).tolist(), "status": np.asarray(st).tolist(),
            "history_cost": np.asarray(hc), "history_evaluations": np.asarray(hn),
            "seconds_including_compile": time.perf_counter() - t0}


def summarise(values) -> dict:
    v = np.asarray(values, dtype=np.float64)
    return {"median": float(np.median(v)), "p10": float(np.percentile(v, 10)), "p90": float(np.percentile(v, 90))}


def sensitivity(prob: Problem, args, budget: int, tuning: Problem) -> dict:
    """The VSA-SMCS and SMCS sweeps on the tuning seeds; the tuned settings."""
    out = {}
    vsa_settings = [dict(VSA_DEFAULT)] + design(VSA_RANGES, args.settings - 1, seed=15)
    t0 = time.perf_counter()
    params, cost, _, _ = chunked(vsa_sweep, tuning, vsa_settings, budget)
    cost = np.asarray(cost)
    val = np.stack([tuning.val_fn(p)[0] for p in np.asarray(params)])
    sec = time.perf_counter() - t0
    print(f"  [{prob.name}] VSA-SMCS sweep: {len(vsa_settings)} settings × {cost.shape[1]} seeds × {budget} "
          f"evaluations in {sec:.0f} s", flush=True)
    out["vsa-smcs"] = {"settings": vsa_settings, "default_index": 0, "cost": cost.tolist(),
                       "validation_um": val.tolist(), "seconds_including_compile": sec}
    rows, costs, vals = [], [], []
    t0 = time.perf_counter()
    for n_worst in (12,) if prob.name == "plan120" else args.n_worst:
        # the default (n_worst = 12) and smcs_settings − 1 design points for each n_worst
        settings = design(SMCS_RANGES, args.smcs_settings - 1, seed=16 + n_worst)
        if n_worst == 12:
            settings = [dict(SMCS_DEFAULT)] + settings
        if not settings:
            continue
        params, cost, _, _ = chunked(smcs_sweep, tuning, settings, n_worst, budget)
        rows += [{**s, "n_worst": n_worst} for s in settings]
        costs.append(np.asarray(cost))
        vals.append(np.stack([tuning.val_fn(p)[0] for p in np.asarray(params)]))
    sec = time.perf_counter() - t0
    cost, val = np.concatenate(costs), np.concatenate(vals)
    print(f"  [{prob.name}] SMCS sweep: {len(rows)} settings × {cost.shape[1]} seeds in {sec:.0f} s", flush=True)
    out["smcs"] = {"settings": rows, "default_index": next(i for i, r in enumerate(rows) if r["n_worst"] == 12),
                   "cost": cost.tolist(), "validation_um": val.tolist(), "seconds_including_compile": sec}
    for m in ("vsa-smcs", "smcs"):
        c = np.asarray(out[m]["cost"])
        med = np.median(c, axis=1)
        i = int(np.argmin(med))
        out[m]["tuned_index"] = i
        out[m]["tuned"] = out[m]["settings"][i]
        out[m]["median_cost"] = med.tolist()
        out[m]["median_validation_um"] = np.median(np.asarray(out[m]["validation_um"]), axis=1).tolist()
    # where VSA-SMCS beats SMCS: each VSA setting's median against SMCS default's and tuned's
    smcs_def = float(np.median(np.asarray(out["smcs"]["cost"])[out["smcs"]["default_index"]]))
    smcs_best = float(np.min(out["smcs"]["median_cost"]))
    vmed = np.asarray(out["vsa-smcs"]["median_cost"])
    out["vsa_settings_beating_smcs_default"] = int(np.sum(vmed < smcs_def))
    out["vsa_settings_beating_smcs_tuned"] = int(np.sum(vmed < smcs_best))
    return out


def pairs_table(results: dict, labels: list[str], metric: str) -> dict:
    out = {}
    for a, b in itertools.combinations(labels, 2):
        x, y = np.asarray(results[a][metric]), np.asarray(results[b][metric])
        ok = np.isfinite(x) & np.isfinite(y) & (y > 0)
        if ok.sum() < 3:
            continue
        out[f"{a} vs {b}"] = paired_comparison(x[ok], y[ok], n_resamples=5000)
    return out


# ------------------------------------------------------------------------------ figures

def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def figure_sensitivity(name: str, sens: dict, path: str) -> None:
    plt = _plt()
    v = sens["vsa-smcs"]
    fig, axes = plt.subplots(2, 4, figsize=(15, 7), constrained_layout=True)
    med = np.asarray(v["median_cost"])
    medv = np.asarray(v["median_validation_um"])
    smcs_def = np.median(np.asarray(sens["smcs"]["cost"])[sens["smcs"]["default_index"]])
    smcs_tuned = np.min(sens["smcs"]["median_cost"])
    for j, k in enumerate(VSA_RANGES):
        x = np.array([s[k] for s in v["settings"]])
        for row, (y, lab) in enumerate(((med, "median final S (mm²)"), (medv, "median validation error (µm)"))):
            ax = axes[row, j]
            sc = ax.scatter(x, y, c=np.log10(med), s=14, cmap="viridis")
            ax.scatter([x[0]], [y[0]], marker="*", s=150, c="red", label="default")
            ax.scatter([x[v["tuned_index"]]], [y[v["tuned_index"]]], marker="D", s=60, facecolor="none",
                       edgecolor="k", label="tuned")
            if row == 0:
                ax.axhline(smcs_def, color="C3", ls="--", label="SMCS default")
                ax.axhline(smcs_tuned, color="C1", ls=":", label="SMCS tuned")
            ax.set_yscale("log")
            if VSA_RANGES[k][2] == "log":
                ax.set_xscale("log")
            ax.set_xlabel(k)
            ax.set_ylabel(lab)
    axes[0, 0].legend(fontsize=7)
    fig.colorbar(sc, ax=axes[:, -1], label="log₁₀ median S")
    fig.suptitle(f"VSA-SMCS sensitivity on {name}: {len(med)} settings × {np.asarray(v['cost']).shape[1]} "
                 "tuning seeds (each point one setting)")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def figure_budget(curves: dict, path: str) -> None:
    plt = _plt()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(13, 5), constrained_layout=True)
    for i, (label, c) in enumerate(curves["cost"].items()):
        g = np.asarray(curves["grid"])
        a1.plot(g, c["median"], label=label, color=f"C{i}")
        a1.fill_between(g, c["p10"], c["p90"], alpha=0.15, color=f"C{i}")
    a1.set_xscale("log")
    a1.set_yscale("log")
    a1.set_xlabel("objective evaluations")
    a1.set_ylabel("best S (mm²)")
    a1.legend(fontsize=7)
    for i, (label, c) in enumerate(curves["validation"].items()):
        b = np.asarray(c["budgets"])
        a2.plot(b, c["median"], marker="o", label=label, color=f"C{i}")
        a2.fill_between(b, c["p10"], c["p90"], alpha=0.15, color=f"C{i}")
    a2.set_xscale("log")
    a2.set_yscale("log")
    a2.set_xlabel("evaluation budget of the run")
    a2.set_ylabel("max validation error (µm)")
    a2.legend(fontsize=7)
    fig.suptitle(f"Budget curves on {curves['problem']} (held-out seeds; median and 10–90 % band)")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def figure_profiles(profiles: dict, path: str) -> None:
    plt = _plt()
    taus = list(profiles["profiles"])
    fig, axes = plt.subplots(1, len(taus), figsize=(6 * len(taus), 4.5), constrained_layout=True)
    axes = np.atleast_1d(axes)
    alphas = np.asarray(profiles["alphas"])
    for ax, tau in zip(axes, taus, strict=True):
        for i, (label, d) in enumerate(profiles["profiles"][tau].items()):
            ax.step(alphas, d, where="post", label=label, color=f"C{i % 10}", ls="-" if i < 10 else "--")
        ax.set_xscale("log")
        ax.set_ylim(0, 1.02)
        ax.set_xlabel("budget α (simplex gradients, n + 1 evaluations each)")
        ax.set_ylabel("fraction of problems solved")
        ax.set_title(f"τ = {tau}")
    axes[0].legend(fontsize=7)
    fig.suptitle(f"Moré–Wild data profiles: {profiles['n_problems']} problems (problem set × held-out seeds)")
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ------------------------------------------------------------------------------ main

def _fmt_pair(p: dict) -> str:
    return (f"{p['median_ratio']:.3g} [{p['ratio_ci_low']:.3g}, {p['ratio_ci_high']:.3g}] | {p['wilcoxon_p']:.2g} | "
            f"{p['a_better_fraction']:.0%}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small sizes (a few minutes); writes comparison_quick.*")
    ap.add_argument("--problems", default=None, help="comma-separated from paper8,plan120,noise10,hidden,rubin_m2")
    ap.add_argument("--sensitivity-problems", default=None, help="problems with the settings sweeps")
    ap.add_argument("--methods", default=None, help="held-out methods (default: all)")
    ap.add_argument("--seeds", type=int, default=None, help="tuning seeds = held-out seeds")
    ap.add_argument("--settings", type=int, default=None, help="VSA-SMCS settings (incl. the default)")
    ap.add_argument("--smcs-settings", type=int, default=None, help="SMCS settings per n_worst")
    ap.add_argument("--no-curves", action="store_true", help="skip the validation-vs-budget runs")
    ap.add_argument("--out", default=RESULTS, help="directory of the results (default benchmarks/results)")
    args = ap.parse_args(argv)
    q = args.quick
    problems = (args.problems or ("paper8,noise10" if q else "paper8,plan120,noise10,hidden,rubin_m2")).split(",")
    sens_problems = (args.sensitivity_problems or ("paper8" if q else "paper8,plan120,rubin_m2")).split(",")
    args.seeds = args.seeds or (4 if q else 30)
    args.settings = args.settings or (12 if q else 101)
    args.smcs_settings = args.smcs_settings or (5 if q else 16)
    args.n_worst = (12,) if q else (4, 12, 24)
    budgets = {"paper8": 3000 if q else 20_000, "noise10": 3000 if q else 20_000, "hidden": 3000 if q else 20_000,
               "rubin_m2": 3000 if q else 10_000, "plan120": 2000 if q else 4_000}
    curve_budgets = [1000, 3000] if q else [2000, 5000, 20_000, 50_000]
    labels = (args.methods.split(",") if args.methods else
              ["vsa-smcs", "vsa-smcs (tuned)", "smcs", "smcs (tuned)", "cs", "cma-es", "de", "pso", "nelder-mead",
               "vsa-smcs ×4 restarts", "lm", "lm-batched"])
    name = "comparison_quick" if q else "comparison"
    os.makedirs(args.out, exist_ok=True)
    t_start = time.perf_counter()
    report: dict = {"config": {
        "quick": q, "problems": problems, "sensitivity_problems": sens_problems, "seeds": args.seeds,
        "tuning_trials": f"0..{args.seeds - 1}", "heldout_trials": f"{HELDOUT_FIRST}..{HELDOUT_FIRST + args.seeds - 1}",
        "budgets": {p: budgets[p] for p in problems}, "vsa_ranges": VSA_RANGES, "vsa_default": VSA_DEFAULT,
        "smcs_ranges": SMCS_RANGES, "smcs_default": {**SMCS_DEFAULT, "n_worst": 12}, "smcs_n_worst": args.n_worst,
        "design": "scipy.stats.qmc.LatinHypercube (seed 15 for VSA-SMCS, 16 + n_worst for SMCS) + the default",
        "tuning_criterion": "lowest median final S over the tuning seeds",
        "lm_evaluations": "(steps + 1)·(n + 1): a forward-difference Jacobian per step",
        "methods": labels,
    }, "problems": {}}
    tuned_by_problem = {}
    all_histories: dict = {}
    for pname in problems:
        budget = budgets[pname]
        print(f"\n== {pname}: budget {budget}, {args.seeds} seeds ==", flush=True)
        held = make_problem(pname, args.seeds, HELDOUT_FIRST)
        entry: dict = {"description": held.description, "n_params": held.n_params, "budget": budget,
                       "f0_heldout": held.f0.tolist()}
        if pname in sens_problems:
            tuning = make_problem(pname, args.seeds, 0)
            sens = sensitivity(held, args, budget, tuning)
            entry["sensitivity"] = sens
            tuned = {"vsa-smcs": sens["vsa-smcs"]["tuned"], "smcs": sens["smcs"]["tuned"]}
            figure_sensitivity(pname, sens, os.path.join(args.out, f"{name}_sensitivity_{pname}.png"))
        else:
            tuned = tuned_by_problem.get("paper8", {"vsa-smcs": VSA_DEFAULT, "smcs": {**SMCS_DEFAULT, "n_worst": 12}})
        tuned_by_problem[pname] = tuned
        entry["tuned_settings_used"] = tuned
        results = {}
        for label in labels:
            if label.startswith("lm") and label not in METHOD_REGISTRY:
                continue
            results[label] = run_method(held, label, budget, tuned)
            r = results[label]
            print(f"  {label:22s} median S {np.median(r['cost']):.3g}  validation "
                  f"{np.median(r['validation_um']):.3g} µm  ({r['seconds_including_compile']:.0f} s)", flush=True)
        all_histories[pname] = (held, results)
        entry["heldout"] = {
            label: {**{k: v for k, v in r.items() if not k.startswith("history")},
                    "summary": {"cost": summarise(r["cost"]), "validation_um": summarise(r["validation_um"]),
                                "validation_arcsec": summarise(r["validation_arcsec"])}}
            for label, r in results.items()}
        ls = list(results)
        entry["paired"] = {"cost": pairs_table(results, ls, "cost"),
                           "validation_um": pairs_table(results, ls, "validation_um")}
        report["problems"][pname] = entry

    # budget curves on the first problem
    p0 = problems[0]
    held, results = all_histories[p0]
    grid = np.unique(np.geomspace(100, budgets[p0], 40).astype(int))
    curves = {"problem": p0, "grid": grid.tolist(), "cost": {}, "validation": {}}
    for label, r in results.items():
        if label in LM_METHODS:
            continue
        b = best_within_budgets(r["history_cost"], r["history_evaluations"], grid)
        curves["cost"][label] = {k: np.percentile(b, q_, axis=0).tolist() for k, q_ in
                                 (("median", 50), ("p10", 10), ("p90", 90))}
    if not args.no_curves:
        for label in ("vsa-smcs", "smcs", "cma-es"):
            if label not in results:
                continue
            meds = {"budgets": curve_budgets, "median": [], "p10": [], "p90": []}
            for b in curve_budgets:
                r = results[label] if b == budgets[p0] else run_method(held, label, b, tuned_by_problem[p0])
                v = np.asarray(r["validation_um"])
                meds["median"].append(float(np.median(v)))
                meds["p10"].append(float(np.percentile(v, 10)))
                meds["p90"].append(float(np.percentile(v, 90)))
            curves["validation"][label] = meds
            print(f"  budget curve {label}: {meds['median']}", flush=True)
    report["budget_curves"] = curves
    figure_budget(curves, os.path.join(args.out, f"{name}_budget_{p0}.png"))

    # data profiles over problems × seeds
    labels_all = [lab for lab in all_histories[problems[0]][1]]
    alphas = np.geomspace(1, max(budgets[p] for p in problems) / 37, 60)
    prof = {"alphas": alphas.tolist(), "taus": [1e-1, 1e-3], "profiles": {},
            "n_problems": sum(len(h.f0) for h, _ in all_histories.values())}
    f0 = np.concatenate([h.f0 for h, _ in all_histories.values()])
    n_dim = np.concatenate([np.full(len(h.f0), h.n_params) for h, _ in all_histories.values()])

    def padded(label):
        cs, ns = [], []
        width = max(np.asarray(r[label]["history_cost"]).shape[-1] for _, r in all_histories.values())
        for _, r in all_histories.values():
            c, n = np.asarray(r[label]["history_cost"]), np.asarray(r[label]["history_evaluations"])
            pad = width - c.shape[-1]
            cs.append(np.pad(c, ((0, 0), (0, pad)), mode="edge"))
            ns.append(np.pad(n, ((0, 0), (0, pad)), mode="edge"))
        return np.concatenate(cs), np.concatenate(ns)

    hist = [padded(lab) for lab in labels_all]
    for tau in prof["taus"]:
        d, _ = data_profiles(hist, f0, n_dim, alphas, tau=tau)
        prof["profiles"][str(tau)] = {lab: d[i].tolist() for i, lab in enumerate(labels_all)}
    report["data_profiles"] = prof
    figure_profiles(prof, os.path.join(args.out, f"{name}_data_profiles.png"))
    report["total_seconds"] = time.perf_counter() - t_start
    report["verdict"] = verdict(report)
    md = markdown(report)
    print("\n" + md)
    if args.out == RESULTS:
        write_results(name, report, md)
    else:
        import json

        with open(os.path.join(args.out, f"{name}.json"), "w") as f:
            json.dump(report, f)
        with open(os.path.join(args.out, f"{name}.md"), "w") as f:
            f.write(md)
    return 0


def _pair(entry, a, b, metric="cost"):
    return entry["paired"][metric].get(f"{a} vs {b}") or _flip(entry["paired"][metric].get(f"{b} vs {a}"))


def _flip(p):
    if p is None:
        return None
    return {**p, "median_ratio": 1 / p["median_ratio"], "ratio_ci_low": 1 / p["ratio_ci_high"],
            "ratio_ci_high": 1 / p["ratio_ci_low"], "a_better_fraction": float("nan")}


def verdict(report: dict) -> list[str]:
    """Plain-language statements read off the numbers (no number is typed in by hand)."""
    out = []
    for pname, e in report["problems"].items():
        h = e["heldout"]
        for a, b in (("vsa-smcs", "smcs"), ("vsa-smcs (tuned)", "smcs (tuned)")):
            p = _pair(e, a, b)
            if p is None:
                continue
            sig = p["wilcoxon_p"] < 0.05
            who = ("VSA-SMCS" if p["median_ratio"] < 1 else "SMCS") if sig else "neither (not significant)"
            out.append(f"{pname}, {'tuned' if 'tuned' in a else 'default'} settings, {e['budget']} evaluations: "
                       f"median S ratio VSA-SMCS/SMCS = {p['median_ratio']:.3g} "
                       f"[{p['ratio_ci_low']:.3g}, {p['ratio_ci_high']:.3g}], Wilcoxon p = {p['wilcoxon_p']:.2g} → "
                       f"better: {who}.")
        for a, b in (("vsa-smcs", "cma-es"), ("smcs", "cma-es"), ("vsa-smcs", "lm-batched"), ("smcs", "nelder-mead")):
            p = _pair(e, a, b)
            if p is not None:
                word = "lower" if p["median_ratio"] < 1 else "higher"
                sig = "significant" if p["wilcoxon_p"] < 0.05 else "not significant"
                out.append(f"{pname}: {a} vs {b}: median S ratio {p['median_ratio']:.3g} "
                           f"[{p['ratio_ci_low']:.3g}, {p['ratio_ci_high']:.3g}] ({a} {word}; Wilcoxon p = "
                           f"{p['wilcoxon_p']:.2g}, {sig}).")
        ranked = sorted(h, key=lambda m: h[m]["summary"]["cost"]["median"])
        out.append(f"{pname}: ranking by median final S on held-out seeds: " + ", ".join(
            f"{m} ({h[m]['summary']['cost']['median']:.2g})" for m in ranked) + ".")
        if "sensitivity" in e:
            s = e["sensitivity"]
            out.append(f"{pname}: {s['vsa_settings_beating_smcs_default']} of {len(s['vsa-smcs']['settings'])} "
                       f"VSA-SMCS settings have a lower median S than default SMCS on the tuning seeds, "
                       f"{s['vsa_settings_beating_smcs_tuned']} lower than the best SMCS setting.")
    return out


def markdown(report: dict) -> str:
    c = report["config"]
    quick = " (QUICK RUN: small sizes, not the published result)" if c["quick"] else ""
    lines = [f"# SMCS vs VSA-SMCS and the baselines{quick}",
             "", f"Seeds: tuning trials {c['tuning_trials']}, held-out trials {c['heldout_trials']} "
             f"(common random numbers: per seed, the same data and optimiser key for every method). "
             f"Total {report['total_seconds'] / 60:.1f} min.", "", "## Verdict", ""]
    lines += [f"- {v}" for v in report["verdict"]]
    for pname, e in report["problems"].items():
        lines += ["", f"## {pname}: {e['description']}; budget {e['budget']} evaluations", ""]
        if "sensitivity" in e:
            s = e["sensitivity"]
            v, m = s["vsa-smcs"], s["smcs"]
            lines += [f"Sensitivity (tuning seeds): VSA-SMCS {len(v['settings'])} settings, median final S from "
                      f"{min(v['median_cost']):.3g} to {max(v['median_cost']):.3g} mm² (default "
                      f"{v['median_cost'][0]:.3g}); tuned {_setting(v['tuned'])}. SMCS {len(m['settings'])} settings, "
                      f"{min(m['median_cost']):.3g} to {max(m['median_cost']):.3g} (default "
                      f"{m['median_cost'][m['default_index']]:.3g}); tuned {_setting(m['tuned'])}.", ""]
        lines += ["Held-out seeds: median [10 %, 90 %] of final S and of the max validation error:", "",
                  "| method | final S (mm²) | validation (µm) | validation (″) | evaluations (median) |",
                  "|---|---|---|---|---|"]
        for label, r in e["heldout"].items():
            sm = r["summary"]
            lines.append(f"| {label} | {_q(sm['cost'])} | {_q(sm['validation_um'])} | {_q(sm['validation_arcsec'])} | "
                         f"{np.median(r['n_evaluations']):.0f} |")
        lines += ["", "Paired, final S: median ratio A/B [95 % bootstrap CI] | Wilcoxon p | A better on:", "",
                  "| A vs B | ratio [CI] | p | A better |", "|---|---|---|---|"]
        keys = [k for k in e["paired"]["cost"] if any(s in k for s in ("vsa-smcs", "smcs"))]
        for k in keys:
            lines.append(f"| {k} | {_fmt_pair(e['paired']['cost'][k])} |")
    bc = report["budget_curves"]
    lines += ["", f"## Budget curves ({bc['problem']}): median validation error (µm) of runs at each budget", "",
              "| method | " + " | ".join(str(b) for b in next(iter(bc["validation"].values()), {}).get("budgets", []))
              + " |", "|---|" + "---|" * len(next(iter(bc["validation"].values()), {}).get("budgets", []))]
    for label, v in bc["validation"].items():
        lines.append(f"| {label} | " + " | ".join(f"{x:.3g}" for x in v["median"]) + " |")
    dp = report["data_profiles"]
    lines += ["", f"## Data profiles ({dp['n_problems']} problems): fraction solved at the largest budget "
              f"(α = {dp['alphas'][-1]:.0f} simplex gradients) and at α = 100", "",
              "| method | " + " | ".join(f"τ = {t}: all | τ = {t}: α ≤ 100" for t in dp["profiles"]) + " |",
              "|---|" + "---|---|" * len(dp["profiles"])]
    i100 = int(np.searchsorted(dp["alphas"], 100.0, side="right") - 1)
    for label in next(iter(dp["profiles"].values())):
        cells = [f"{dp['profiles'][t][label][-1]:.2f} | {dp['profiles'][t][label][max(i100, 0)]:.2f}"
                 for t in dp["profiles"]]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _q(s: dict) -> str:
    return f"{s['median']:.3g} [{s['p10']:.3g}, {s['p90']:.3g}]"


def _setting(s: dict) -> str:
    return ", ".join(f"{k} = {v:.3g}" if isinstance(v, float) else f"{k} = {v}" for k, v in s.items())


if __name__ == "__main__":
    sys.exit(main())
