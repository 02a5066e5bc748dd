# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # 6. Which method wins: SMCS vs VSA-SMCS, their settings, and the standard baselines
#
# Wang H., Cao X. et al., *Improved cuckoo calibration method of space telescope secondary mirror
# adjusting mechanism*, Infrared and Laser Engineering 47(5), 2018, claim in Table 2 that VSA-SMCS
# (§2.2–2.3) calibrates better than SMCS (§2.1), without stating VSA-SMCS's d, sp₁, p, lu. This
# notebook is the small-size version of `benchmarks/comparison.py` (whose full results are in
# `benchmarks/results/comparison.md`):
#
# 1. VSA-SMCS over random settings of (d, sp₁, p, lu), vmapped over settings × seeds in one call;
# 2. the tuned setting (lowest median S on tuning seeds) and the default, on **fresh** seeds, beside
#    SMCS, CMA-ES (Hansen 2016), DE (Storn & Price 1997), PSO (Kennedy & Eberhart 1995) and LM —
#    with common random numbers (same data, same initial population per seed);
# 3. paired statistics (Wilcoxon signed-rank, bootstrap interval of the median ratio);
# 4. budget curves and a Moré–Wild data profile.
#
# `STEWART_JAX_QUICK=1`: 3 seeds, 4 settings, 2 000 evaluations (figures not saved).

# %%
import os
from pathlib import Path

import jax
import jax.numpy as jnp
import matplotlib.pyplot as plt
import numpy as np

import stewart_jax as sj
from stewart_jax import plotting
from stewart_jax.calibration import calibrate_batch
from stewart_jax.optimise import VSASMCS, minimise
from stewart_jax.study import best_within_budgets, data_profiles, paired_comparison, simulate_trials, trial_keys

QUICK = os.environ.get("STEWART_JAX_QUICK", "0") not in ("", "0")
N_SEEDS, N_SETTINGS, BUDGET = (3, 4, 2000) if QUICK else (30, 32, 20_000)
FIGURES = None if QUICK else Path(
    os.environ.get("STEWART_JAX_FIGURES", Path(sj.__file__).resolve().parents[1] / "notebooks" / "figures")
)


def figure_path(name):
    return None if FIGURES is None else FIGURES / name


nominal, actual = sj.nominal_geometry(), sj.actual_geometry()


def problems(first):
    """The paper's protocol (8 random poses, σ = 0.1 µm / 0.1″, Ω = ±10 mm), trials first …"""
    probs, _, val, keys = simulate_trials(trial_keys(0, N_SEEDS, first), nominal, actual, "paper8")
    return probs, val, keys


tuning, heldout = problems(0), problems(1000)
print(f"quick={QUICK}: {N_SEEDS} seeds, {N_SETTINGS} VSA-SMCS settings, budget {BUDGET} evaluations")

# %% [markdown]
# ## VSA-SMCS settings, vmapped
#
# The solver's hyper-parameters are array leaves, so one compiled call runs every setting on every
# seed. Ranges: d ∈ [0.1, 4] and p ∈ [1, 30] (the paper's range) log-uniform, sp₁ ∈ [0, 1],
# lu ∈ [0, 0.5]; the first setting is the library default (d = 1, sp₁ = 0.1, p = 10, lu = 0.25).

# %%
rng = np.random.default_rng(6)
u = rng.uniform(size=(N_SETTINGS - 1, 4))
settings = np.vstack([[1.0, 0.1, 10.0, 0.25],
                      np.column_stack([0.1 * 40.0 ** u[:, 0], u[:, 1], 30.0 ** u[:, 2], 0.5 * u[:, 3]])])


@jax.jit
def sweep(settings, probs, keys):
    def one(s, p, k):
        solver = VSASMCS(d=s[0], sp_1=s[1], p=s[2], lu=s[3])
        r = minimise(lambda x, pr: pr.cost(x), solver, p.lower, p.upper, k, max_evaluations=BUDGET, args=p)
        return r.params, r.cost, r.history_cost, r.history_evaluations

    return jax.vmap(jax.vmap(one, (None, 0, 0)), (0, None, None))(settings, probs, keys)


def validation_um(params, val):
    """Max |dx, dy, dz| (µm) at 42 fresh poses, per seed."""
    e = jax.vmap(lambda q, v: sj.control_error(nominal.with_params(q), actual, v).errors)(params, val)
    return 1e3 * np.max(np.abs(np.asarray(e)[..., :3]), axis=(1, 2))


_, cost, _, _ = sweep(jnp.asarray(settings), tuning[0], tuning[2])
median_s = np.median(np.asarray(cost), axis=1)
best = int(np.argmin(median_s))
smcs_tuning = calibrate_batch(tuning[0], "smcs", tuning[2], max_evaluations=BUDGET)
print("tuned (d, sp_1, p, lu) =", settings[best], f"median S {median_s[best]:.3g} (default {median_s[0]:.3g}, "
      f"SMCS default {np.median(np.asarray(smcs_tuning.cost)):.3g})")

fig, axes = plt.subplots(1, 4, figsize=(15, 3.6), constrained_layout=True)
for ax, j, name, log in zip(axes, range(4), ("d", "sp₁", "p", "lu"), (True, False, True, False), strict=True):
    ax.scatter(settings[:, j], median_s, s=16)
    ax.scatter(settings[0, j], median_s[0], marker="*", s=160, c="red", label="default")
    ax.axhline(np.median(np.asarray(smcs_tuning.cost)), ls="--", c="C3", label="SMCS default")
    ax.set_yscale("log")
    ax.set_xscale("log" if log else "linear")
    ax.set_xlabel(name)
axes[0].set_ylabel("median final S (mm²), tuning seeds")
axes[0].legend(fontsize=7)
plotting.show(fig, figure_path("06_sensitivity.png"))

# %% [markdown]
# ## Fresh seeds: default and tuned VSA-SMCS against SMCS and the baselines
#
# Same data and the same optimiser key per seed for every method (common random numbers): every
# population method starts from the same 37 points uniform in Ω.

# %%
probs, val, keys = heldout
runs = {}
params, cost, hc, hn = sweep(jnp.asarray(settings[[0, best]]), probs, keys)
for i, label in enumerate(("VSA-SMCS (default)", "VSA-SMCS (tuned)")):
    runs[label] = (params[i], cost[i], hc[i], hn[i])
for m, label in (("smcs", "SMCS"), ("cma-es", "CMA-ES"), ("de", "DE"), ("pso", "PSO")):
    r = calibrate_batch(probs, m, keys, max_evaluations=BUDGET)
    runs[label] = (r.params, r.cost, r.history_cost, r.history_evaluations)
r = calibrate_batch(probs, "lm-batched", keys)
runs["LM (batched)"] = (r.params, r.cost, r.cost[:, None], (37 * r.n_evaluations)[:, None])  # (steps+1)(n+1)

table = {k: (np.asarray(v[1]), validation_um(v[0], val)) for k, v in runs.items()}
for label, (s, v) in table.items():
    print(f"{label:>20}: median S {np.median(s):.3g} mm², median validation error {np.median(v):.3g} µm")
for a, b in (("VSA-SMCS (default)", "SMCS"), ("VSA-SMCS (tuned)", "SMCS"), ("SMCS", "CMA-ES"),
             ("VSA-SMCS (default)", "LM (batched)")):
    p = paired_comparison(table[a][0], table[b][0], n_resamples=2000)
    print(f"{a} / {b}: median S ratio {p['median_ratio']:.3g} [{p['ratio_ci_low']:.3g}, {p['ratio_ci_high']:.3g}],"
          f" Wilcoxon p = {p['wilcoxon_p']:.2g}")

# %% [markdown]
# ## Budget curves and a data profile
#
# Best S within each budget (median and 10–90 % band over the fresh seeds), and the Moré–Wild data
# profile over these seeds: the fraction of problems on which a method reaches
# `S ≤ S_best + τ·(S_nominal − S_best)` within α simplex gradients (37 evaluations each).

# %%
grid = np.unique(np.geomspace(200, BUDGET, 30).astype(int))  # after the first generation of each
fig, (a1, a2) = plt.subplots(1, 2, figsize=(13, 4.5), constrained_layout=True)
for i, (label, (_, _, hc, hn)) in enumerate(runs.items()):
    if label.startswith("LM"):
        continue
    b = best_within_budgets(np.asarray(hc), np.asarray(hn), grid)
    a1.plot(grid, np.median(b, 0), label=label, color=f"C{i}")
    a1.fill_between(grid, np.percentile(b, 10, 0), np.percentile(b, 90, 0), color=f"C{i}", alpha=0.15)
a1.axhline(np.median(table["LM (batched)"][0]), color="k", ls=":", label="LM: median final S")
a1.set(xscale="log", yscale="log", xlabel="objective evaluations", ylabel="best S (mm²)")
a1.legend(fontsize=7)
f0 = np.asarray(jax.vmap(lambda p: p.cost(p.initial))(probs))
alphas = np.geomspace(1, BUDGET / 37, 40)
prof, _ = data_profiles([(np.asarray(v[2]), np.asarray(v[3])) for v in runs.values()], f0, 36, alphas, tau=1e-3)
for i, label in enumerate(runs):
    a2.step(alphas, prof[i], where="post", label=label, color=f"C{i}")
a2.set(xscale="log", ylim=(0, 1.02), xlabel="α (simplex gradients)", ylabel="fraction solved, τ = 1e-3")
a2.legend(fontsize=7)
plotting.show(fig, figure_path("06_budget_and_profile.png"))
