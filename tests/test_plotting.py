"""Each helper of ``stewart_jax.plotting`` returns a figure with labelled axes and a legend
(small synthetic inputs; no JAX computation)."""

from __future__ import annotations

import os
import subprocess
import sys
import types

import matplotlib.pyplot as plt
import numpy as np
import pytest

from stewart_jax import plotting


def _check(fig, min_axes=1, shared_y=False):
    axes = [a for a in fig.axes if a.get_visible()]
    assert len(axes) >= min_axes
    for ax in axes:
        # with a shared y axis only the first panel of each row carries the label
        assert ax.get_ylabel() or (shared_y and axes[0].get_ylabel()), "y label with its unit"
        assert ax.get_legend() is not None, "every panel has a legend"
    assert any(ax.get_xlabel() for ax in axes)
    plt.close(fig)


def _run(code, **env):
    env = {**{k: v for k, v in os.environ.items() if k not in ("MPLBACKEND", "DISPLAY", "WAYLAND_DISPLAY")},
           **env}
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                          env=env).stdout


def test_not_imported_by_the_package():
    code = "import sys, stewart_jax; print('matplotlib' in sys.modules, 'stewart_jax.plotting' in sys.modules)"
    assert _run(code).split() == ["False", "False"]


def test_library_chooses_no_backend_and_imports_no_cable_robot():
    # Headless and no MPLBACKEND: importing the plotting package must leave the backend to the
    # caller, and must not import the cable-robot package (its figures are duck-typed).
    code = ("import sys, matplotlib; calls = []; matplotlib.use = lambda *a, **k: calls.append(a); "
            "import stewart_jax.plotting; print(calls, 'stewart_jax.cable_robot' in sys.modules)")
    assert _run(code).split() == ["[]", "False"]


def test_pose_errors_with_paper_lines():
    rng = np.random.default_rng(0)
    e = {"Before calibration": rng.normal(0, 100, (8, 6)), "LM": rng.normal(0, 0.2, (8, 6))}
    fig = plotting.plot_pose_errors(e, paper={"Before calibration": [532, 189, 174, 250, 374, 355]})
    ax = fig.axes[0]
    assert "µm" in ax.get_ylabel() and "″" in fig.axes[1].get_ylabel()
    assert any("paper" in t.get_text() for t in ax.get_legend().get_texts())
    _check(fig, 4)
    _check(plotting.plot_pose_errors(rng.normal(size=(120, 6))), 2)  # many poses: markers
    with pytest.raises(ValueError):
        plotting.plot_pose_errors(np.zeros((8, 5)))


def test_table_comparison_monte_carlo_and_paper():
    rows = {"SMCS": {"median": np.ones(6), "p90": 2 * np.ones(6)}, "LM": np.full(6, 0.3)}
    fig = plotting.plot_table_comparison(rows, paper={"SMCS": np.full(6, 3.0), "Before calibration": np.full(6, 100.0)},
                                         per_trial={"SMCS": np.ones((5, 6))})
    texts = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert any("paper" in t for t in texts)
    _check(fig, 2)


def test_convergence():
    n = np.array([0, 10, 100, 1000])
    h = {"evaluations_median": n, "cost_median": [1, 0.1, 0.01, 0.001], "cost_p10": [1, 0.05, 0.005, 5e-4],
         "cost_p90": [1, 0.2, 0.02, 0.002]}
    fig = plotting.plot_convergence({"VSA-SMCS": h}, reference={"LM": 1e-4})
    assert "mm²" in fig.axes[0].get_ylabel()
    _check(fig)


def test_singular_values_and_parameter_std():
    s = np.logspace(0, -2, 36)
    _check(plotting.plot_singular_values({"plan 120": s, "8 poses": s / 3}))
    _check(plotting.plot_parameter_std({"plan": np.full(36, 1e-3)}, actual_error_mm={"run": np.full(36, 2e-3)}))
    # a mixed set (the 6-RUS: lengths in mm, crank zeros in rad) is labelled per parameter: 1e-3 mm is
    # drawn at 1 µm, 1e-6 rad at 1 µrad
    fig = plotting.plot_parameter_std({"plan": np.array([1e-3] * 48 + [1e-6] * 6)}, units=("mm",) * 48 + ("rad",) * 6)
    ax = fig.axes[0]
    assert "µm" in ax.get_ylabel() and "µrad" in ax.get_ylabel()
    ticks = [t.get_text() for t in ax.get_xticklabels()]
    assert ticks[-1].endswith("(µrad)") and ticks[0].endswith("(µm)")
    np.testing.assert_allclose(ax.lines[0].get_ydata(), 1.0)
    _check(fig)


def test_stroke_residuals():
    _check(plotting.plot_reading_residuals({"nominal": np.ones((10, 6)), "calibrated": np.zeros((10, 6))},
                                          sigma_um=0.1), 2)
    fig = plotting.plot_reading_residuals({"crank angles": np.ones((10, 6))}, unit="µrad")
    assert fig.axes[0].get_ylabel() == "reading residual (µrad)" and "µm" not in fig.axes[0].get_title()
    _check(fig)


def test_fast_figures():
    t = np.linspace(0, 0.2, 11)
    z = np.zeros((11, 3))
    res = types.SimpleNamespace(time=t, planned=z, actual=z, extra_error=z, cabin_displacement=z, cabin_angle=z)
    _check(plotting.plot_fast_time_series(res), 4)
    pos = (0.0, 0.0, 140.0)
    ours = {pos: {"std": [1e-4, 1e-6, 1e-7], "amplitude": [1e-3, 1e-6, 1e-6], "peak_to_peak": [2e-3, 2e-6, 2e-6]}}
    paper = {pos: {"x": (3e-4, 2.4e-3), "y": (1e-5, 7e-5), "z": (2e-6, 3e-5)}}
    _check(plotting.plot_fast_table2(ours, paper=paper), 2)


def _fake_report():
    cand = [types.SimpleNamespace(effect=n, score=s, significant=s > 10) for n, s in
            (("backlash", 1e4), ("drift", 50.0), ("thermal_expansion", -3.0))]
    rng = np.random.default_rng(1)
    model = types.SimpleNamespace(output_names=tuple(f"leg{i}" for i in range(1, 7)), report_unit="µm")
    return types.SimpleNamespace(
        model="6-pss", ranking=cand, named_effect="backlash", indistinguishable_from=[], gap_before=0.3, gap_after=0.12,
        noise_floor=0.11, fitted=types.SimpleNamespace(model=model), residuals_before=rng.normal(size=(20, 6)),
        residuals_after=0.1 * rng.normal(size=(20, 6)),
        test_factors={"direction": rng.choice([-1.0, 1.0], (20, 6)), "time_s": rng.uniform(0, 100, (20, 6))},
    )


def test_discrepancy_figures():
    rep = _fake_report()
    _check(plotting.plot_discrepancy_ranking(rep))
    _check(plotting.plot_discrepancy_gap(rep))
    fig = plotting.plot_residuals_vs_factor(rep, "time_s")
    assert fig.axes[0].get_xlabel() == "time (s)" and "µm" in fig.axes[0].get_ylabel()
    _check(fig, 6, shared_y=True)
    with pytest.raises(ValueError):
        plotting.plot_residuals_vs_factor(rep, "nope")
    _check(plotting.plot_residuals_vs_factor(rep, "direction", which="before"), 6, shared_y=True)


def test_residual_files(tmp_path):
    rep = _fake_report()
    paths = plotting.plot_residuals(rep, tmp_path / "res", factors=["time_s"])
    assert [os.path.basename(p) for p in paths] == ["residuals_time_s.png"]
    assert os.path.getsize(paths[0]) > 1000 and plt.get_fignums() == []
    with pytest.raises(ValueError, match="unknown factor"):
        plotting.plot_residuals(rep, tmp_path, factors=["humidity"])
    with pytest.raises(ValueError, match="which"):
        plotting.plot_residuals(rep, tmp_path, which="neither")


def test_show_saves_and_closes(tmp_path):
    fig = plotting.plot_singular_values(np.ones(3))
    plotting.show(fig, tmp_path / "sub" / "sv.png")
    assert (tmp_path / "sub" / "sv.png").stat().st_size > 0
    assert not plt.fignum_exists(fig.number)
