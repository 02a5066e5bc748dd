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
# # 5. Your own mechanism: load, calibrate, diagnose, export
#
# Point the notebook at your files with environment variables (or edit the cell below):
#
# - `STEWART_JAX_GEOMETRY`: the nominal geometry — a preset (`nominal`, `actual`) or a
#   JSON/TOML file of the 12 joint centres and `v0` in mm (`stewart_jax.save_mechanism` writes one);
# - `STEWART_JAX_CSV`: the measured data, columns as in `docs/conventions.md`: `q1..q6` (mm),
#   `x, y, z` (mm), `rx, ry, rz` (degrees), optional `dir1..dir6`, `temperature` (°C), `time` (s);
# - `STEWART_JAX_SIGMA_UM`, `STEWART_JAX_SIGMA_ARCSEC`: the pose-measurement noise (σ);
# - `STEWART_JAX_OUT`: where to write the calibrated geometry (default: a temporary directory).
#
# Without them the notebook writes a demonstration pair first: Table 1's nominal geometry and a
# simulated run of the "actual" mechanism (120-pose plan + random poses, σ = 0.1 µm / 0.1″, no
# hidden effect) — the same files `stewart-jax simulate` would give you.

# %%
import os
import tempfile
from pathlib import Path

import jax
import numpy as np

import stewart_jax as sj
from stewart_jax import discrepancy as dc, plotting
from stewart_jax.calibration import identifiability_report

QUICK = os.environ.get("STEWART_JAX_QUICK", "0") not in ("", "0")
OUT = Path(os.environ.get("STEWART_JAX_OUT") or tempfile.mkdtemp(prefix="stewart_jax_nb5_"))
SIGMA_UM = float(os.environ.get("STEWART_JAX_SIGMA_UM", 0.1))
SIGMA_ARCSEC = float(os.environ.get("STEWART_JAX_SIGMA_ARCSEC", 0.1))
# Published figures go to notebooks/figures (or $STEWART_JAX_FIGURES); quick mode saves none.
FIGURES = None if QUICK else Path(
    os.environ.get("STEWART_JAX_FIGURES", Path(sj.__file__).resolve().parents[1] / "notebooks" / "figures")
)


def figure_path(name):
    return None if FIGURES is None else FIGURES / name


geometry_file = os.environ.get("STEWART_JAX_GEOMETRY")
csv_file = os.environ.get("STEWART_JAX_CSV")
if csv_file is None:
    OUT.mkdir(parents=True, exist_ok=True)
    geometry_file = str(OUT / "nominal.json")
    sj.save_mechanism(sj.nominal_geometry(), geometry_file)
    csv_file = str(OUT / "measured.csv")
    demo = dc.simulate_hidden_effect(7, None, 0.0, n_random=20 if QUICK else 60,
                                     sigma_um=SIGMA_UM, sigma_arcsec=SIGMA_ARCSEC)
    dc.write_hidden_csv(csv_file, demo)
    print(f"demonstration files written: {geometry_file}, {csv_file}")
geometry_file = geometry_file or "nominal"
print(f"geometry: {geometry_file}\nmeasured data: {csv_file}\noutput: {OUT}")

# %% [markdown]
# ## Load

# %%
nominal = sj.load_mechanism(geometry_file)
data = sj.read_csv(csv_file)
extras = [n for n in ("directions", "temperature", "time") if getattr(data, n) is not None]
print(f"{data.n_poses} poses; optional columns present: {extras or 'none'}")
print("rod lengths (mm):", np.round(np.asarray(sj.mechanism.rod_lengths(nominal)), 3).tolist())

# %% [markdown]
# ## Calibrate (Levenberg–Marquardt from the nominal parameters, Ω = nominal ± 10 mm)
#
# On the simulation problem of Wang et al. (2018) LM reaches the noise floor fastest (README, "Results"); for a
# mechanism far from its nominal geometry use `"vsa-smcs+lm"` (a global search, then LM).

# %%
problem = sj.calibration_problem(data, nominal, half_width=10.0)
result = jax.block_until_ready(sj.calibrate(problem, "lm"))
calibrated = nominal.with_params(result.params)
status = sj.optimise.status_name(result.status)
print(f"status {status}; S = {float(result.cost):.4g} mm² "
      f"(RMS stroke residual {np.sqrt(float(result.cost) / (6 * data.n_poses)) * 1e3:.3g} µm) "
      f"after {int(result.n_evaluations)} LM steps")
moved = (np.asarray(result.params) - np.asarray(nominal.params)).reshape(12, 3)
print("largest joint-centre corrections (mm):",
      ", ".join(f"{'A' if j < 6 else 'B'}{j % 6 + 1} {np.linalg.norm(moved[j]):.3f}"
                for j in np.argsort(-np.linalg.norm(moved, axis=1))[:4]))

# %%
res_before = np.asarray(sj.stroke_residuals(nominal.params, data, nominal)).reshape(-1, 6) * 1e3
res_after = np.asarray(sj.stroke_residuals(result.params, data, nominal)).reshape(-1, 6) * 1e3
fig = plotting.plot_stroke_residuals({"nominal geometry": res_before, "calibrated": res_after},
                                     title="stroke residuals q' − IK(P', u) before and after calibration")
plotting.show(fig, figure_path("05_stroke_residuals.png"))

# %% [markdown]
# ## How well do these poses determine the parameters?
#
# Predicted standard deviation of each parameter from the pose noise you gave (the
# identification Jacobian at the calibrated geometry) — the uncertainty `calibrate --json`
# reports as `param_std`.

# %%
rep = identifiability_report(calibrated, data.poses, SIGMA_UM, SIGMA_ARCSEC)
print(f"rank {rep.rank}/36, condition number {rep.condition_number:.3g}; "
      f"median predicted std {np.median(rep.param_std) * 1e3:.3g} µm, max {rep.param_std.max() * 1e3:.3g} µm")
fig = plotting.plot_parameter_std({"your poses": rep.param_std}, title="predicted parameter std")
plotting.show(fig, figure_path("05_parameter_std.png"))

# %% [markdown]
# ## Diagnose: is anything missing from the 36-parameter model?
#
# The model-discrepancy workflow of `docs/discrepancy.md` (30 % of the poses held out).
# "none" means the held-out residuals are explained by the noise you gave; otherwise it names
# the effect to add.

# %%
model = dc.pss_model(nominal, sigma_um=SIGMA_UM, sigma_arcsec=SIGMA_ARCSEC)
report = dc.diagnose(data, model, holdout_fraction=0.3, seed=0)
print(f"detected: {report.detected} (p = {report.detect_p_value:.3g}); named: {report.named_effect}; "
      f"indistinguishable from: {report.indistinguishable_from}; skipped: {[s['effect'] for s in report.skipped]}")
print(f"held-out RMS {report.gap_before:.3g} → {report.gap_after:.3g} µm (noise floor {report.noise_floor:.3g} µm)")
fig = plotting.plot_discrepancy_ranking(report)
plotting.show(fig, figure_path("05_ranking.png"))
fig = plotting.plot_residuals_vs_factor(report, "stroke_um")
plotting.show(fig, figure_path("05_residuals_stroke.png"))

# %% [markdown]
# ## Export
#
# The calibrated geometry as JSON (read back by `sj.load_mechanism`, `stewart-jax calibrate
# --geometry`, …); with a named effect, also the augmented model (`dc.load_fitted_model`).

# %%
out_geometry = OUT / "calibrated.json"
sj.save_mechanism(calibrated, out_geometry)
back = sj.load_mechanism(out_geometry)
assert np.array_equal(np.asarray(back.params), np.asarray(calibrated.params))
print(f"calibrated geometry written to {out_geometry}")
if report.named_effect != "none":
    dc.save_fitted_model(report.fitted, OUT / "augmented_model.json")
    print(f"augmented model written to {OUT / 'augmented_model.json'}")
