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
# - `STEWART_JAX_GEOMETRY`: the nominal geometry — a preset (`nominal`, `actual`, `rubin_camera`,
#   `rubin_m2`, `fast_stewart`) or a JSON/TOML geometry file of any family, a strut hexapod
#   (`"mechanism": "6-UPS"`: base and platform joints, `v0`) or a 6-PSS (`docs/conventions.md`;
#   `stewart_jax.save_mechanism` writes one);
# - `STEWART_JAX_CSV`: the measured data, columns as in `docs/conventions.md`: `q1..q6` (mm),
#   `x, y, z` (mm), `rx, ry, rz` (degrees), optional `dir1..dir6`, `temperature` (°C), `time` (s);
# - `STEWART_JAX_SIGMA_UM`, `STEWART_JAX_SIGMA_ARCSEC`: the pose-measurement noise (σ);
# - `STEWART_JAX_OUT`: where to write the calibrated geometry (default: a temporary directory).
#
# Without them the notebook writes a demonstration pair first: a **strut hexapod** — the Rubin
# Observatory's M2 hexapod (`rubin_m2`, three axial and three lateral struts) — as the nominal
# geometry, and a simulated run of a "true" M2 whose 42 parameters differ from the nominal ones by
# 0.5 mm (σ), measured at the 120-pose plan scaled to its travel plus random poses (σ = 0.1 µm /
# 0.1″, no hidden effect) — the same files `stewart-jax simulate --geometry rubin_m2` would give you.
# Everything below works unchanged for the paper's 6-PSS (`STEWART_JAX_GEOMETRY=nominal`).

# %%
import os
import tempfile
from pathlib import Path

import jax
import numpy as np

import stewart_jax as sj
from stewart_jax import discrepancy as dc, plotting
from stewart_jax.calibration import identifiability_report, perturbed

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
    demo_nominal = sj.mechanism.preset("rubin_m2")
    sj.save_mechanism(demo_nominal, geometry_file)
    demo_true = perturbed(demo_nominal, jax.random.key(7), 0.5)
    csv_file = str(OUT / "measured.csv")
    demo = dc.simulate_hidden_effect(7, None, 0.0, n_random=20 if QUICK else 60, geometry=demo_true,
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
print(f"{nominal.family} mechanism, {nominal.n_params} calibration parameters")
legs = nominal.rod_lengths if nominal.family == "6-PSS" else nominal.strut_lengths(np.zeros(6))
print("leg lengths at the zero pose (mm):", np.round(np.asarray(legs), 3).tolist())

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
moved = np.asarray(result.params) - np.asarray(nominal.params)
print("largest parameter corrections:",
      ", ".join(f"{nominal.param_names[k]} {moved[k]:+.3f}" for k in np.argsort(-np.abs(moved))[:5]))

# %%
res_before = np.asarray(problem.residuals(nominal.params)).reshape(-1, 6) * 1e3
res_after = np.asarray(problem.residuals(result.params)).reshape(-1, 6) * 1e3
fig = plotting.plot_reading_residuals({"nominal geometry": res_before, "calibrated": res_after},
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
print(f"rank {rep.rank}/{nominal.n_params}, condition number {rep.condition_number:.3g}; "
      f"median predicted std {np.median(rep.param_std) * 1e3:.3g} µm, max {rep.param_std.max() * 1e3:.3g} µm")
fig = plotting.plot_parameter_std({"your poses": rep.param_std}, names=nominal.param_names,
                                  title="predicted parameter std")
plotting.show(fig, figure_path("05_parameter_std.png"))

# %% [markdown]
# ## What the data support
#
# The goodness of fit against the noise you gave (a χ² test), the identification rank and which
# parameters the data identify on their own, repeated poses — what `stewart-jax calibrate --report`
# writes into the calibration report.

# %%
assessment = sj.calibration.assess_calibration(calibrated, data, SIGMA_UM, SIGMA_ARCSEC)
print(f"data status {assessment.status}: χ² = {assessment.chi2:.4g} on {assessment.dof} degrees of freedom "
      f"(p = {assessment.p_value:.3g}, residuals {assessment.rms_ratio:.3g}× the noise); rank {assessment.rank}; "
      f"{int(assessment.identifiable.sum())} of {assessment.n_params} parameters identifiable alone")
for w in assessment.warnings:
    print("WARNING:", w)

# %% [markdown]
# ## Diagnose: is anything missing from the model?
#
# The model-discrepancy workflow of `docs/discrepancy.md` (30 % of the poses held out).
# `None` means nothing explains the gap (or there is none: see `report.summary()`); otherwise it
# names the effect that closes the held-out gap to the noise floor.

# %%
model = dc.model_for(nominal, sigma_um=SIGMA_UM, sigma_arcsec=SIGMA_ARCSEC)  # the model of its family
report = dc.diagnose(data, model, holdout_fraction=0.3, seed=0)
print(f"detected: {report.detected} (p = {report.detect_p_value:.3g}); named: {report.named_effect}; "
      f"indistinguishable from: {report.indistinguishable_from}; skipped: {[s['effect'] for s in report.skipped]}")
print("\n".join(report.summary()))
fig = plotting.plot_discrepancy_ranking(report)
plotting.show(fig, figure_path("05_ranking.png"))
fig = plotting.plot_residuals_vs_factor(report, "stroke_um")
plotting.show(fig, figure_path("05_residuals_stroke.png"))

# %% [markdown]
# ## Workspace and export
#
# The reachable translation envelope of the calibrated mechanism (every leg's stroke and joint
# limits), the calibrated geometry as JSON (read back by `sj.load_mechanism`, `stewart-jax calibrate
# --geometry`, …), for a strut hexapod the LinuxCNC `genhexkins` settings a controller loads, and with
# a named effect the augmented model (`dc.load_fitted_model`).

# %%
envelope = sj.mechanism.translation_envelope(calibrated, 64 if QUICK else 400)
fig = plotting.plot_workspace(envelope, title=f"{nominal.family}: reachable translations (calibrated)")
plotting.show(fig, figure_path("05_workspace.png"))

# %%
out_geometry = OUT / "calibrated.json"
sj.save_mechanism(calibrated, out_geometry)
back = sj.load_mechanism(out_geometry)
assert np.array_equal(np.asarray(back.params), np.asarray(calibrated.params))
print(f"calibrated geometry written to {out_geometry}")
if nominal.family == "6-UPS":
    (OUT / "calibrated.hal").write_text(sj.mechanism.to_genhexkins(calibrated))
    print(f"genhexkins settings written to {OUT / 'calibrated.hal'}:")
    print("\n".join((OUT / "calibrated.hal").read_text().splitlines()[:6]) + "\n…")
if report.named_effect is not None:
    dc.save_fitted_model(report.fitted, OUT / "augmented_model.json")
    print(f"augmented model written to {OUT / 'augmented_model.json'}")
