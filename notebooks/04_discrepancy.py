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
# # 4. Model discrepancy: find the effect the 36-parameter model is missing
#
# The 36-parameter joint-centre model of Wang et al. 2018, "Improved cuckoo calibration method of
# space telescope secondary mirror adjusting mechanism" (Infrared and Laser Engineering 47(5)).
#
# A simulated measurement run of a mechanism with a **hidden** effect — here backlash: the
# reading depends on the direction each slider approached from. The 36-parameter model cannot
# represent it; the workflow (`stewart_jax.discrepancy.diagnose`) should
#
# 1. *detect* that the held-out residuals exceed what the noise explains,
# 2. *name* the effect from the library of candidates (ranking by ΔBIC, Bonferroni tests),
# 3. *add* it, and *show* the held-out gap fall to the noise floor.
#
# The residual plots against each factor show the same thing by eye: before the fix, the
# residuals split by approach direction; after, they sit inside the noise band.
# Quick mode (`STEWART_JAX_QUICK=1`) uses fewer random poses beside the 120-pose plan.

# %%
import os
from pathlib import Path

import numpy as np

import stewart_jax as sj
from stewart_jax import discrepancy as dc, plotting

QUICK = os.environ.get("STEWART_JAX_QUICK", "0") not in ("", "0")
N_RANDOM = 20 if QUICK else 60
EFFECT, MAGNITUDE, SEED = "backlash", 5.0, 1
# Published figures go to notebooks/figures (or $STEWART_JAX_FIGURES); quick mode saves none.
FIGURES = None if QUICK else Path(
    os.environ.get("STEWART_JAX_FIGURES", Path(sj.__file__).resolve().parents[1] / "notebooks" / "figures")
)


def figure_path(name):
    return None if FIGURES is None else FIGURES / name


# %% [markdown]
# ## The data: 120-pose plan + random poses, approach directions, temperature, time
#
# The hidden effect's *unabsorbable* signature (what a refit of the geometry cannot remove) is
# scaled to `MAGNITUDE` × the noise.

# %%
sim = dc.simulate_hidden_effect(SEED, EFFECT, MAGNITUDE, n_random=N_RANDOM)
print(f"{sim.data.n_poses} poses; hidden effect {sim.truth.effect!r}, "
      f"parameters {np.round(np.asarray(sim.truth.theta) * 1e3, 3).tolist()} µm")
model = dc.model_for(sj.nominal_geometry(), sigma_um=0.1, sigma_arcsec=0.1)
report = dc.diagnose(sim.data, model, holdout_fraction=0.3, seed=0)
print(f"detected: {report.detected} (p = {report.detect_p_value:.3g}); named: {report.named_effect}; "
      f"indistinguishable from: {report.indistinguishable_from}")
print(f"held-out residual RMS: before {report.gap_before:.3g} µm, after {report.gap_after:.3g} µm, "
      f"noise floor {report.noise_floor:.3g} µm")
print("\n".join(report.summary()))  # the verdict in sentences: named, partial, discovered, absorbed

# %% [markdown]
# ## The residual plots that reveal it
#
# Held-out stroke residuals of the base (36-parameter) fit and of the augmented fit, per leg,
# against the approach direction, the leg's own stroke, temperature and time.

# %%
for factor in ("direction", "stroke_um", "temperature_C", "time_s"):
    if factor in report.test_factors:
        fig = plotting.plot_residuals_vs_factor(report, factor)
        plotting.show(fig, figure_path(f"04_residuals_{factor}.png"))

# %% [markdown]
# ## The ranking

# %%
for c in report.ranking:
    print(f"{c.effect:>22}: score {c.score:10.3g}, Δχ² {c.delta_chi2:10.3g} on {c.dof:2d} dof, "
          f"p {c.p_value:9.3g}, significant {c.significant}, absorbed {c.absorbed_fraction:.2f}")
fig = plotting.plot_discrepancy_ranking(
    report, title=f"candidates for the hidden {EFFECT} (magnitude {MAGNITUDE}× noise)"
)
plotting.show(fig, figure_path("04_ranking.png"))

# %% [markdown]
# ## The gap before and after, and what it means for control
#
# Held-out residual RMS against the noise floor; then the true control error at 42 fresh
# poses (the simulation knows the true mechanism): commanded with the base model vs the
# augmented model, under the same approach directions / temperature / time conditions.

# %%
fig = plotting.plot_discrepancy_gap(report, title=f"held-out gap, hidden {EFFECT}")
plotting.show(fig, figure_path("04_gap.png"))

rng = np.random.default_rng(123)
targets = rng.uniform(-1, 1, (42, 6)) * np.array([1.0] * 3 + [np.deg2rad(1.0)] * 3)
cond = dc.random_conditions(rng, 42)
rows = sj.calibration.make_calibration_data(np.zeros((42, 6)), targets, cond.directions, cond.temperature, cond.time)
ctrl = {}
for label, fitted in (("base model", report.base_fitted), (f"+ {report.named_effect}", report.fitted)):
    err = dc.true_control_error(sim.truth, np.asarray(fitted.commanded(rows)), targets, cond)
    ctrl[label] = sj.calibration.error_in_report_units(err)
    print(f"{label:>16}: RMS control error " + ", ".join(
        f"{c} {v:.3g}" for c, v in zip(("dx", "dy", "dz", "φ", "θ", "ψ"), np.sqrt(np.mean(ctrl[label] ** 2, 0)), strict=True)))
fig = plotting.plot_pose_errors(ctrl, title="true control error at 42 fresh poses (µm, ″)")
plotting.show(fig, figure_path("04_control_error.png"))
