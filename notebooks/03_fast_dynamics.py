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
# # 3. FAST feed-support dynamics (Yin et al.: Figs. 6–9, Table 2)
#
# Yin J., Jiang P., Chen M., Yao R., *Dynamic modeling of a cable-driven parallel robot with a
# Stewart platform for use in FAST*; the model is `stewart_jax.cable_robot`.
#
# Six elastic catenary cables hold the feed cabin; inside it a Stewart platform moves its
# lower platform `x(t) = 0.01 sin(10πt)` m along B's x axis. The reaction forces shake the
# cabin; the lower platform's *extra error* (eq. 66) is its actual motion minus the planned one.
# Table 2 correlates the extra error with the cabin's vibration displacement per axis and gives
# the standard deviation of their difference and the amplitude of the extra error, at four
# cabin positions on the focal surface.
#
# Settings the paper does not give (see `docs/cable_robot.md`): duration, time
# step, initial velocity state (`start="momentum"`: zero total momentum). Quick mode
# (`STEWART_JAX_QUICK=1`) simulates 0.2 s at 2 ms; the full mode, 2 s at 1 ms (the CLI default).

# %%
import os
from pathlib import Path

import jax
import numpy as np

import stewart_jax as sj
from stewart_jax import cable_robot, plotting

QUICK = os.environ.get("STEWART_JAX_QUICK", "0") not in ("", "0")
DURATION, DT = (0.2, 2e-3) if QUICK else (2.0, 1e-3)
# Published figures go to notebooks/figures (or $STEWART_JAX_FIGURES); quick mode saves none.
FIGURES = None if QUICK else Path(
    os.environ.get("STEWART_JAX_FIGURES", Path(sj.__file__).resolve().parents[1] / "notebooks" / "figures")
)


def figure_path(name):
    return None if FIGURES is None else FIGURES / name


params = cable_robot.paper_fast_params()
# compiled once, reused at every position (the duration and step are static)
run_scenario = jax.jit(cable_robot.run_scenario, static_argnames=("duration", "dt", "start", "method"))
static_equilibrium = jax.jit(cable_robot.static_equilibrium)
cabin_modes = jax.jit(cable_robot.cabin_modes)
print(f"quick={QUICK}: duration {DURATION} s, dt {DT} s, velocity Verlet, momentum start")

# %% [markdown]
# ## Figs. 6–9 at the centre, [0, 0, 140] m

# %%
runs = {}
for pos in cable_robot.PAPER_POSITIONS:
    res = jax.block_until_ready(run_scenario(params, np.array(pos), duration=DURATION, dt=DT))
    runs[pos] = res
    print(f"{list(pos)} m: static equilibrium converged: {bool(res.static_ok)}; "
          f"failed catenary solves: {int(res.n_failed)}")

centre = runs[cable_robot.PAPER_POSITIONS[0]]
fig = plotting.plot_fast_time_series(
    centre, title=f"Yin et al. Figs. 6–9 at [0, 0, 140] m ({DURATION} s, dt {DT * 1e3:g} ms)"
)
plotting.show(fig, figure_path("03_figs6-9.png"))

# %% [markdown]
# ## Table 2: ours vs the paper
#
# Only positions whose static equilibrium exists (positive unstretched lengths) are compared;
# at [90, 0, 167.7] m cable 5 goes slack with the cabin level (README, FAST section).
# "Amplitude" is `max |extra error|`; the peak-to-peak value is shown too (the paper's x value
# is close to our peak-to-peak).

# %%
ours = {}
for pos, res in runs.items():
    if not bool(res.static_ok) or int(res.n_failed) > 0:
        continue
    e = np.asarray(res.extra_error)
    ours[pos] = {"std": np.asarray(res.std), "amplitude": np.asarray(res.amplitude),
                 "peak_to_peak": e.max(0) - e.min(0), "correlation": np.asarray(res.correlation)}
print(f"{'position (m)':>20} {'axis':>4} {'corr':>8} {'std (m)':>10} {'paper std':>10} "
      f"{'amp (m)':>10} {'p-p (m)':>10} {'paper amp':>10}")
for pos, v in ours.items():
    for k, ax in enumerate("xyz"):
        ps, pa = cable_robot.PAPER_TABLE2[pos][ax]
        print(f"{str(list(pos)):>20} {ax:>4} {v['correlation'][k]:8.4f} {v['std'][k]:10.3e} {ps:10.3e} "
              f"{v['amplitude'][k]:10.3e} {v['peak_to_peak'][k]:10.3e} {pa:10.3e}")
print("paper's correlations at the centre:", cable_robot.PAPER_CORRELATION_CENTRE)
fig = plotting.plot_fast_table2(ours, paper=cable_robot.PAPER_TABLE2,
                                title=f"Yin et al. Table 2: ours ({DURATION} s) vs ◇ paper")
plotting.show(fig, figure_path("03_table2.png"))

# %% [markdown]
# ## Does the result hinge on the time step?
#
# The centre's x statistics at half the time step (same duration). A new time step is a new
# compilation (the step count is static), so quick mode skips this check.

# %%
if QUICK:
    print("quick mode: time-step check skipped")
else:
    half = jax.block_until_ready(run_scenario(params, np.array(cable_robot.PAPER_POSITIONS[0]),
                                                       duration=DURATION, dt=DT / 2))
    for name in ("correlation", "std", "amplitude"):
        a, b = float(getattr(centre, name)[0]), float(getattr(half, name)[0])
        print(f"x {name:>11}: dt {DT * 1e3:g} ms {a:.6g}, dt {DT * 500:g} ms {b:.6g} "
              f"(relative change {abs(a - b) / abs(b):.2e})")

# %% [markdown]
# ## Beyond the paper: feasible workspace, cabin attitude and vibration modes
#
# The feed moves on the focal surface, the sphere of radius 160 m about the reflector's centre
# of curvature (0, 0, 300) m (Table 2's positions lie on it). A pose is *feasible* when the 24×24
# equilibrium exists with every cable in tension, on the short catenary branch, with its sag clear
# of the reflector (`cable_robot.cabin_statics`). With a level cabin the fourth Table 2 position
# has no equilibrium; a small tilt makes it feasible (`cable_robot.smallest_feasible_tilt`). About
# each equilibrium the cabin's 6×6 stiffness (s0 fixed, implicit derivatives of the catenaries)
# and the rigid 14-body mass matrix give the natural frequencies (`cable_robot.cabin_modes`);
# `docs/cable_robot.md` and `benchmarks/results/fast_modes.md` have the full study.

# %%
print(f"{'position (m)':>20} {'attitude':>14} {'tilt (°)':>8} {'tensions at the cabin (kN)':>44} "
      f"{'f1…f6 (Hz)':>10}")
for pos in cable_robot.PAPER_POSITIONS:
    sol = cable_robot.solve_attitude(params, np.array(pos), "level")
    if not bool(sol.statics.feasible):
        sol = cable_robot.smallest_feasible_tilt(params, np.array(pos), n_axes=12, n_fan=4, tol=1e-4)
    m = cabin_modes(params, np.array(pos), np.asarray(sol.R), sol.statics.static)
    print(f"{str(list(pos)):>20} {sol.kind:>14} {np.rad2deg(sol.tilt_rad):8.2f} "
          f"{', '.join(f'{t / 1e3:6.1f}' for t in np.asarray(sol.statics.tension_n)):>44} "
          f"{', '.join(f'{f:.3f}' for f in np.asarray(m.frequencies_hz))}")

# %% [markdown]
# ### Maps over the focal surface (level cabin)
#
# Least cable tension where the level cabin is feasible, and its lowest natural frequency. Quick
# mode uses a coarse map (13 positions); the benchmark maps the whole surface with tilts.

# %%
n_zen, n_az, max_zen = (3, 6, 30.0) if QUICK else (9, 24, 40.0)
zen = np.deg2rad(np.linspace(0.0, max_zen, n_zen))
az = np.linspace(0.0, 2 * np.pi, n_az, endpoint=False)
grid = [(0.0, 0.0)] + [(z, a) for z in zen[1:] for a in az]
positions = np.asarray(cable_robot.focal_surface_point(np.array([g[0] for g in grid]),
                                                       np.array([g[1] for g in grid])))
ws = cable_robot.workspace_map(params, positions)
feasible = np.asarray(ws.feasible)
f1 = np.full(len(positions), np.nan)
for i in np.flatnonzero(feasible):
    f1[i] = float(cabin_modes(params, positions[i], np.eye(3),
                                              jax.tree.map(lambda a, i=i: a[i], ws.static)).frequencies_hz[0])
print(f"{feasible.sum()} of {len(positions)} positions feasible with a level cabin; "
      f"first frequency {np.nanmin(f1):.3f}–{np.nanmax(f1):.3f} Hz")
plotting.show(plotting.plot_fast_focal_map(positions, np.min(np.asarray(ws.min_tension_n), 1) / 1e3,
                                           feasible=feasible, label="least cable tension (kN)",
                                           title="Level cabin on the focal surface"),
              figure_path("03_workspace.png"))
plotting.show(plotting.plot_fast_focal_map(positions, f1, feasible=feasible,
                                           label="first natural frequency (Hz)",
                                           title="Lowest cabin mode (level cabin)"),
              figure_path("03_first_frequency.png"))

# %% [markdown]
# ## Cables with mass: the cabin–cable modes against the measured band
#
# The six cables weigh 27 t against the assembly's 29.5 t, and their own string modes lie below
# the cabin's. With lumped-mass cables (`cable_robot.lumped_modes`, MoorDyn's discretisation: N
# segments per cable, solved together with the cabin) the swing and heave modes move into the
# 0.12–0.2 Hz measured on FAST (Li, Sun, Li, Yao, *Universe* 10(12):450, 2024). Each coordinate's
# cabin-dominant mode is the one with the largest share of its static compliance; the many pure
# string modes (cabin kinetic-energy share < 1 %) are drawn small.

# %%
import matplotlib.pyplot as plt  # noqa: E402

N_SEG = 8 if QUICK else 20
fig, ax = plt.subplots(figsize=(7.0, 4.4))
ax.axhspan(0.12, 0.2, color="0.85", label="measured lowest mode, 0.12–0.2 Hz")
for k, pos in enumerate(cable_robot.PAPER_POSITIONS[:3]):
    st = static_equilibrium(params, np.array(pos), np.eye(3))
    qs = np.asarray(cabin_modes(params, np.array(pos), np.eye(3), st).frequencies_hz)
    lm = cable_robot.lumped_modes(params, np.array(pos), N_SEG, static=st)
    s = cable_robot.modal_summary(lm, cutoff_hz=1.5)
    string = np.asarray(s.kind) == "string"
    ax.plot(np.full(6, k - 0.15), qs, "o", color="C0", label=None if k else "quasi-static cables")
    ax.plot(np.full(string.sum(), k + 0.15), s.frequencies_hz[string], ".", color="0.6", ms=3,
            label=None if k else "lumped: string modes")
    dom = sorted({v[1] for v in s.dominant.values()})
    ax.plot(np.full(len(dom), k + 0.15), dom, "s", color="C3", label=None if k else "lumped: cabin-dominant")
    print(f"{str(list(pos)):>20} quasi-static {', '.join(f'{f:.3f}' for f in qs)} Hz; lumped (N={N_SEG}) "
          + ", ".join(f"{c} {v[1]:.3f}" for c, v in s.dominant.items()))
ax.set_xticks(range(3), [str(list(p)) for p in cable_robot.PAPER_POSITIONS[:3]])
ax.set_yscale("log")
ax.set_ylabel("frequency (Hz)")
ax.set_title(f"Cabin modes with and without cable inertia (N = {N_SEG})")
ax.legend(fontsize=8, loc="upper left")
plotting.show(fig, figure_path("03_cable_inertia.png"))
