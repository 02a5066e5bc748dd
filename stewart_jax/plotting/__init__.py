"""Figures for the notebooks and the command line (matplotlib).

Import explicitly, ``from stewart_jax import plotting``; the package's ``__init__`` does not
import this module, so the core library never imports matplotlib. Where no display is
available (no ``DISPLAY``/``WAYLAND_DISPLAY``, no ``MPLBACKEND``, not inside IPython) the Agg
backend is selected before ``pyplot`` is imported.

Every function returns a :class:`matplotlib.figure.Figure` and draws nothing on the screen;
:func:`show` displays a figure in a notebook (once) and optionally saves it. Conventions: pose
errors in µm (dx, dy, dz) and arc-seconds (φ, θ, ψ), as the papers' tables; every axis has its
unit and every panel a legend; values from a paper are drawn as black markers or dashed lines
labelled "paper".
"""

from __future__ import annotations

import os
import sys
from collections.abc import Mapping, Sequence
from typing import Any

import matplotlib
import numpy as np

if not (
    os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY") or os.environ.get("MPLBACKEND")
    or "IPython" in sys.modules
):
    matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

__all__ = [
    "COMPONENT_LABELS",
    "PAPER_TABLE4",
    "plot_convergence",
    "plot_discrepancy_gap",
    "plot_discrepancy_ranking",
    "plot_fast_table2",
    "plot_fast_time_series",
    "plot_parameter_std",
    "plot_pose_errors",
    "plot_residuals_vs_factor",
    "plot_singular_values",
    "plot_stroke_residuals",
    "plot_table_comparison",
    "show",
]

COMPONENT_LABELS = ("dx", "dy", "dz", "φ", "θ", "ψ")
"""Pose components in report order: the first three in µm, the last three in ″."""

PAPER_TABLE4: dict[str, list[float]] = {
    "Sampling points before calibration": [19.52, 19.97, 17.25, 115.44, 105.73, 123.84],
    "Sampling points after calibration": [9.68, 7.72, 6.14, 8.86, 8.53, 8.54],
    "Validation points after calibration": [9.85, 8.91, 7.18, 10.03, 10.98, 11.41],
}
"""Seed 000, Table 4 (experiment on the prototype, laser tracker, Ω = nominal ± 2.5 mm): max
control error, dx/dy/dz in µm, φ/θ/ψ in ″ — the paper's values, for marking on our figures."""

_COLORS = plt.rcParams["axes.prop_cycle"].by_key()["color"]


def _as_mapping(x: Any, default_label: str) -> dict[str, np.ndarray]:
    if isinstance(x, Mapping):
        return {str(k): np.asarray(v, dtype=float) for k, v in x.items()}
    return {default_label: np.asarray(x, dtype=float)}


def show(fig: Figure, path: str | os.PathLike[str] | None = None, *, dpi: int = 120) -> Figure:
    """Save ``fig`` to ``path`` (if given), display it once when running inside IPython, and
    close it (so that scripts running many figures do not accumulate them)."""
    if path is not None:
        os.makedirs(os.path.dirname(os.fspath(path)) or ".", exist_ok=True)
        fig.savefig(path, dpi=dpi, bbox_inches="tight")
    ipython = sys.modules.get("IPython")
    if ipython is not None and getattr(ipython, "get_ipython", lambda: None)() is not None:
        from IPython.display import display

        display(fig)
    plt.close(fig)
    return fig


def _finish(fig: Figure, ax, title: str | None) -> Figure:
    """Grid, legend, optional title, tight layout: the common end of the single-axes plots."""
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    if title:
        ax.set_title(title, fontsize=10)
    fig.tight_layout()
    return fig


# ------------------------------------------------------------------------- pose errors


def plot_pose_errors(
    errors_um_arcsec: Any,
    *,
    paper: Any = None,
    title: str | None = None,
    symlog: bool = False,
) -> Figure:
    """Per-pose control error (seed 000 Figs. 2, 3, 6, 7 style).

    ``errors_um_arcsec``: ``(n_poses, 6)`` signed errors (µm, ″), or a mapping label → such an
    array (one row of panels per label, e.g. before / SMCS / VSA-SMCS / LM). ``paper``: the
    paper's maximum |error| per component (6 numbers), or a mapping with the same labels as
    ``errors_um_arcsec``; drawn as dashed ±max lines in each component's colour. Left panels:
    dx, dy, dz (µm); right panels: φ, θ, ψ (″); x axis: pose index.
    """
    series = _as_mapping(errors_um_arcsec, "error")
    if isinstance(paper, Mapping):
        paper_map = {str(k): np.asarray(v, dtype=float) for k, v in paper.items()}
    elif paper is not None:
        paper_map = {k: np.asarray(paper, dtype=float) for k in series}
    else:
        paper_map = {}
    n = len(series)
    fig, axes = plt.subplots(n, 2, figsize=(11, 2.8 * n + 0.6), squeeze=False, sharex=True)
    for row, (label, e) in enumerate(series.items()):
        if e.ndim != 2 or e.shape[1] != 6:
            raise ValueError(f"{label}: expected (n_poses, 6) errors in µm and ″, got shape {e.shape}")
        idx = np.arange(1, e.shape[0] + 1)
        for side, (lo, unit) in enumerate(((0, "µm"), (3, "″"))):
            ax = axes[row, side]
            width = 0.8 / 3 if e.shape[0] <= 30 else None
            for k in range(3):
                c = lo + k
                color = _COLORS[k]
                if width is not None:
                    ax.bar(idx + (k - 1) * width, e[:, c], width, color=color, label=COMPONENT_LABELS[c])
                else:
                    ax.plot(idx, e[:, c], "o", ms=3, color=color, label=COMPONENT_LABELS[c])
                if label in paper_map:
                    v = paper_map[label][c]
                    ax.axhline(v, color=color, ls="--", lw=1,
                               label=f"paper max |{COMPONENT_LABELS[c]}| = {v:g} {unit}")
                    ax.axhline(-v, color=color, ls="--", lw=1)
            ax.axhline(0, color="0.4", lw=0.6)
            if symlog:
                ax.set_yscale("symlog", linthresh=max(1e-3, float(np.percentile(np.abs(e[:, lo:lo + 3]), 50))))
            ax.set_ylabel(f"error ({unit})")
            ax.set_title(f"{label}: {'translation' if side == 0 else 'rotation'}", fontsize=10)
            ax.grid(True, alpha=0.3)
            ax.legend(fontsize=7, ncol=2 if label in paper_map else 3, loc="best")
    for ax in axes[-1]:
        ax.set_xlabel("pose index")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_table_comparison(
    rows: Mapping[str, Any],
    *,
    paper: Mapping[str, Sequence[float]] | None = None,
    title: str | None = None,
    per_trial: Mapping[str, Any] | None = None,
) -> Figure:
    """Grouped bars of the max control error per component, ours beside the paper's.

    ``rows``: label → either 6 numbers (one run's max error, µm and ″) or a dict with
    ``"median"`` and optionally ``"p90"`` (Monte Carlo: bar = median, whisker = 90th
    percentile), as ``run_study(...)["rows"][label]["calibration"]``. ``per_trial``: label →
    ``(n_trials, 6)`` to overlay each trial as a dot. ``paper``: label → the paper's 6 values,
    drawn as black diamonds on the bar of the same label (labels without an own row get their
    own hatched bar). Log y axis; left µm, right ″.
    """
    labels = list(rows)
    paper = dict(paper or {})
    extra = [k for k in paper if k not in rows]
    groups = labels + [f"paper: {k}" for k in extra]
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6))
    width = 0.8 / max(len(groups), 1)
    for side, (lo, unit) in enumerate(((0, "µm"), (3, "″"))):
        ax = axes[side]
        x = np.arange(3)
        marked = False
        for g, name in enumerate(groups):
            off = (g - (len(groups) - 1) / 2) * width
            color = _COLORS[g % len(_COLORS)]
            if name in rows:
                r = rows[name]
                med = np.asarray(r["median"] if isinstance(r, Mapping) else r, dtype=float)[lo:lo + 3]
                p90 = np.asarray(r["p90"], dtype=float)[lo:lo + 3] if isinstance(r, Mapping) and "p90" in r else None
                yerr = None if p90 is None else np.vstack([np.zeros(3), np.maximum(p90 - med, 0)])
                lab = f"{name} (median, whisker p90)" if p90 is not None else name
                ax.bar(x + off, med, width, yerr=yerr, capsize=2, color=color, label=lab)
                if per_trial is not None and name in per_trial:
                    pt = np.asarray(per_trial[name], dtype=float)[:, lo:lo + 3]
                    for k in range(3):
                        ax.plot(np.full(len(pt), x[k] + off), pt[:, k], ".", ms=2, color="0.25", alpha=0.5)
                if name in paper:
                    ax.plot(x + off, np.asarray(paper[name], dtype=float)[lo:lo + 3], "kD", ms=6,
                            mfc="none", mew=1.5, label=None if marked else "paper (one run)")
                    marked = True
            else:
                vals = np.asarray(paper[name[len("paper: "):]], dtype=float)[lo:lo + 3]
                ax.bar(x + off, vals, width, color="white", edgecolor=color, hatch="//", label=name)
        ax.set_xticks(x, COMPONENT_LABELS[lo:lo + 3])
        ax.set_xlabel(f"pose component ({unit})")
        ax.set_yscale("log")
        ax.set_ylabel(f"max |control error| ({unit})")
        ax.grid(True, axis="y", which="both", alpha=0.3)
        ax.legend(fontsize=7)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


# ------------------------------------------------------------------------- optimisers


def plot_convergence(
    histories: Mapping[str, Mapping[str, Any]],
    *,
    reference: Mapping[str, float] | None = None,
    title: str | None = None,
) -> Figure:
    """Best objective S against objective evaluations, median and 10–90 % band over seeds.

    ``histories``: label → ``{"evaluations_median", "cost_median", "cost_p10", "cost_p90"}``
    (``run_study(...)["rows"][label]["history"]``). ``reference``: label → a final S to draw as
    a dashed horizontal line (e.g. LM's median final S). Log–log axes.
    """
    fig, ax = plt.subplots(figsize=(7.5, 4.6))
    for i, (label, h) in enumerate(histories.items()):
        n = np.asarray(h["evaluations_median"], dtype=float)
        keep = n > 0
        color = _COLORS[i % len(_COLORS)]
        ax.plot(n[keep], np.asarray(h["cost_median"])[keep], color=color, label=f"{label} (median)")
        if "cost_p10" in h and "cost_p90" in h:
            ax.fill_between(n[keep], np.asarray(h["cost_p10"])[keep], np.asarray(h["cost_p90"])[keep],
                            color=color, alpha=0.2, label=f"{label} (10–90 % over seeds)")
    for j, (label, value) in enumerate((reference or {}).items()):
        ax.axhline(value, color="k", ls=("--", ":", "-.")[j % 3], lw=1, label=label)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("objective evaluations")
    ax.set_ylabel("best S (mm²)")
    return _finish(fig, ax, title)


# ------------------------------------------------------------------------- identifiability


def plot_singular_values(
    singular_values: Any,
    *,
    rtol: float | None = 1e-9,
    title: str | None = None,
) -> Figure:
    """Singular values of the (column-scaled) identification Jacobian, descending, for one or
    several pose sets (label → values). ``rtol`` draws the numerical-rank threshold relative to
    each set's largest value."""
    series = _as_mapping(singular_values, "singular values")
    fig, ax = plt.subplots(figsize=(7.5, 4.4))
    for i, (label, s) in enumerate(series.items()):
        color = _COLORS[i % len(_COLORS)]
        s = np.sort(s)[::-1]
        ax.semilogy(np.arange(1, len(s) + 1), np.maximum(s, 1e-300), "o-", ms=3, color=color,
                    label=f"{label} (σ_max/σ_min = {s[0] / s[-1]:.3g})" if s[-1] > 0 else label)
        if rtol is not None:
            ax.axhline(rtol * s[0], color=color, ls=":", lw=1, label=f"{label}: rank threshold {rtol:g}·σ_max")
    ax.set_xlabel("index of singular value")
    ax.set_ylabel("singular value (dimensionless, columns scaled to unit norm)")
    return _finish(fig, ax, title)


def plot_parameter_std(
    param_std_mm: Any,
    *,
    actual_error_mm: Any = None,
    title: str | None = None,
) -> Figure:
    """Predicted standard deviation of each of the 36 calibrated parameters (µm, log axis),
    for one or several pose sets (label → 36 values, mm), optionally with the actual
    |estimate − truth| of one calibration (label → 36 values, mm) as markers."""
    series = _as_mapping(param_std_mm, "predicted std")
    names = [f"{'A' if i < 18 else 'B'}{(i % 18) // 3 + 1}{'xyz'[i % 3]}" for i in range(36)]
    fig, ax = plt.subplots(figsize=(12, 4.2))
    for i, (label, s) in enumerate(series.items()):
        ax.semilogy(np.arange(36), np.maximum(s, 1e-12) * 1e3, "o-", ms=3, color=_COLORS[i % len(_COLORS)],
                    label=f"{label}: predicted std")
    if actual_error_mm is not None:
        for i, (label, e) in enumerate(_as_mapping(actual_error_mm, "actual error").items()):
            ax.semilogy(np.arange(36), np.maximum(np.abs(e), 1e-12) * 1e3, "x", ms=5,
                        color=_COLORS[(i + len(series)) % len(_COLORS)], label=f"{label}: |estimate − truth|")
    ax.set_xticks(np.arange(36), names, rotation=90, fontsize=7)
    ax.set_xlabel("parameter (Ac_i then Bc_i, x/y/z)")
    ax.set_ylabel("µm")
    return _finish(fig, ax, title)


def plot_stroke_residuals(residuals_um: Any, *, sigma_um: float | None = None, title: str | None = None) -> Figure:
    """Stroke residuals ``q' − IK(P', u)`` per pose and leg (µm), for one or several parameter
    sets (label → ``(m, 6)``), e.g. nominal vs calibrated; ``sigma_um`` draws a ±2σ band."""
    series = _as_mapping(residuals_um, "residual")
    fig, axes = plt.subplots(len(series), 1, figsize=(10, 2.8 * len(series) + 0.5), squeeze=False, sharex=True)
    for ax, (label, r) in zip(axes[:, 0], series.items(), strict=True):
        idx = np.arange(1, r.shape[0] + 1)
        for leg in range(r.shape[1]):
            ax.plot(idx, r[:, leg], "o", ms=3, color=_COLORS[leg % len(_COLORS)], label=f"leg {leg + 1}")
        if sigma_um is not None:
            ax.axhspan(-2 * sigma_um, 2 * sigma_um, color="0.88", zorder=0, label=f"±2σ = ±{2 * sigma_um:.3g} µm")
        ax.axhline(0, color="0.4", lw=0.6)
        rms = float(np.sqrt(np.mean(r**2)))
        ax.set_title(f"{label}: RMS {rms:.3g} µm", fontsize=10)
        ax.set_ylabel("stroke residual (µm)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, ncol=4)
    axes[-1, 0].set_xlabel("pose index (row of the CSV)")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


# ------------------------------------------------------------------------- FAST (seed 002)


def plot_fast_time_series(result: Any, *, title: str | None = None) -> Figure:
    """Seed 002 Figs. 6–9 from a :class:`stewart_jax.fast.ScenarioResult`: planned and actual
    lower-platform x (mm), extra error (mm), cabin vibration displacement (mm) and angle (µrad)
    against time (s)."""
    t = np.asarray(result.time)
    fig, axs = plt.subplots(4, 1, figsize=(8, 10), sharex=True)
    axs[0].plot(t, np.asarray(result.planned)[:, 0] * 1e3, label="planned x (eq. 62)")
    axs[0].plot(t, np.asarray(result.actual)[:, 0] * 1e3, "--", label="actual x (eq. 65)")
    axs[0].set_ylabel("lower platform x (mm)")
    axs[0].set_title("Fig. 6: lower-platform displacement", fontsize=9)
    for k, name in enumerate("xyz"):
        axs[1].plot(t, np.asarray(result.extra_error)[:, k] * 1e3, label=name)
        axs[2].plot(t, np.asarray(result.cabin_displacement)[:, k] * 1e3, label=name)
        axs[3].plot(t, np.asarray(result.cabin_angle)[:, k] * 1e6, label=name)
    axs[1].set_ylabel("extra error (mm)")
    axs[1].set_title("Fig. 7: extra error of the lower platform (eq. 66)", fontsize=9)
    axs[2].set_ylabel("cabin displacement (mm)")
    axs[2].set_title("Fig. 8: cabin vibration displacement", fontsize=9)
    axs[3].set_ylabel("cabin angle (µrad)")
    axs[3].set_title("Fig. 9: cabin vibration angle (rotation vector)", fontsize=9)
    axs[3].set_xlabel("time (s)")
    for a in axs:
        a.grid(True, alpha=0.3)
        a.legend(loc="upper right", fontsize=8)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_fast_table2(
    ours: Mapping[Any, Mapping[str, Any]],
    *,
    paper: Mapping[Any, Mapping[str, Sequence[float]]] | None = None,
    title: str | None = None,
) -> Figure:
    """Seed 002 Table 2 per cabin position and axis: std of (extra error − cabin displacement)
    and amplitude of the extra error (m, log axis), ours as bars, the paper's as black markers.

    ``ours``: position → ``{"std": 3 values, "amplitude": 3 values}`` (and optionally
    ``"peak_to_peak"``, drawn as open circles). ``paper``: position → axis → (std, amplitude),
    as :data:`stewart_jax.fast.PAPER_TABLE2`.
    """
    positions = list(ours)
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6))
    width = 0.8 / max(len(positions), 1)
    for side, (key, pidx, name) in enumerate((("std", 0, "std of (extra error − cabin displacement)"),
                                              ("amplitude", 1, "amplitude of the extra error"))):
        ax = axes[side]
        x = np.arange(3)
        marked = pp_marked = False
        for i, pos in enumerate(positions):
            off = (i - (len(positions) - 1) / 2) * width
            color = _COLORS[i % len(_COLORS)]
            vals = np.asarray(ours[pos][key], dtype=float)
            ax.bar(x + off, vals, width, color=color, label=f"ours at {list(pos)} m")
            if key == "amplitude" and "peak_to_peak" in ours[pos]:
                ax.plot(x + off, np.asarray(ours[pos]["peak_to_peak"], dtype=float), "o", mfc="none",
                        color="0.2", ms=6, label=None if pp_marked else "ours, peak-to-peak")
                pp_marked = True
            if paper is not None and tuple(pos) in paper:
                pv = [paper[tuple(pos)][a][pidx] for a in "xyz"]
                ax.plot(x + off, pv, "kD", ms=6, mfc="none", mew=1.5, label=None if marked else "paper")
                marked = True
        ax.set_xticks(x, ["x", "y", "z"])
        ax.set_xlabel("axis of the ground frame G")
        ax.set_yscale("log")
        ax.set_ylabel(f"{name} (m)")
        ax.grid(True, axis="y", which="both", alpha=0.3)
        ax.legend(fontsize=7)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


# ------------------------------------------------------------------------- discrepancy


def plot_residuals_vs_factor(report: Any, factor: str, *, title: str | None = None) -> Figure:
    """Held-out residuals of a :class:`~stewart_jax.discrepancy.DiagnosisReport` against one
    factor (e.g. ``"direction"``, ``"temperature_C"``, ``"time_s"``, ``"stroke_um"``), per
    output, before (base model) and after (augmented model), with the ±2σ noise band."""
    if factor not in report.test_factors:
        raise ValueError(f"unknown factor {factor!r}; the report has {sorted(report.test_factors)}")
    x = np.asarray(report.test_factors[factor])
    model = report.fitted.model
    names = model.output_names
    k = len(names)
    cols = 3 if k > 3 else k
    rows = int(np.ceil(k / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(4 * cols, 2.9 * rows), sharey=True, squeeze=False)
    band = 2.0 * report.noise_floor
    series = [("before (base model)", report.residuals_before, "tab:red")]
    if report.named_effect != "none":
        series.append((f"after (+ {report.named_effect})", report.residuals_after, "tab:blue"))
    for j, ax in enumerate(axes.flat):
        if j >= k:
            ax.set_visible(False)
            continue
        for label, res, color in series:
            ax.plot(x[:, j], np.asarray(res)[:, j], "o", ms=3, alpha=0.7, color=color, label=label)
        ax.axhspan(-band, band, color="0.88", zorder=0, label="±2σ noise")
        ax.axhline(0.0, color="0.5", lw=0.8)
        ax.set_title(names[j], fontsize=9)
        ax.set_xlabel(factor.replace("_um", " (µm)").replace("_arcsec", " (″)").replace("_C", " (°C)")
                      .replace("_s", " (s)") if factor != "direction" else "approach direction (±1)")
        if j % cols == 0:
            ax.set_ylabel(f"held-out residual ({model.report_unit})")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=6)
    fig.suptitle(title or f"held-out residuals vs {factor}; named: {report.named_effect}")
    fig.tight_layout()
    return fig


def plot_discrepancy_ranking(report: Any, *, title: str | None = None) -> Figure:
    """Candidate effects ranked by score (ΔBIC against the base model, higher is better), with
    the Bonferroni-significant ones filled and the named effect highlighted."""
    cands = list(report.ranking)
    names = [c.effect for c in cands]
    scores = np.array([c.score for c in cands], dtype=float)
    fig, ax = plt.subplots(figsize=(7.5, 0.45 * len(cands) + 1.6))
    y = np.arange(len(cands))[::-1]
    for yi, c, s in zip(y, cands, scores, strict=True):
        named = c.effect == report.named_effect
        color = "tab:green" if named else ("tab:blue" if c.significant else "0.7")
        ax.barh(yi, s, color=color if c.significant else "white", edgecolor=color,
                hatch=None if c.significant else "//")
    ax.set_yticks(y, names)
    ax.set_ylabel("candidate effect")
    ax.axvline(0.0, color="k", lw=0.8)
    from matplotlib.patches import Patch

    handles = [Patch(color="tab:green", label=f"named: {report.named_effect}"),
               Patch(color="tab:blue", label="significant (Bonferroni)"),
               Patch(facecolor="white", edgecolor="0.7", hatch="//", label="not significant")]
    if report.indistinguishable_from:
        handles.append(Patch(color="white", label="indistinguishable: " + ", ".join(report.indistinguishable_from)))
    ax.legend(handles=handles, fontsize=7, loc="lower right")
    ax.set_xlabel("score = ΔBIC against the base model (dimensionless, higher = better)")
    ax.set_xscale("symlog", linthresh=10.0)
    ax.grid(True, axis="x", alpha=0.3)
    ax.set_title(title or "candidate effects", fontsize=10)
    fig.tight_layout()
    return fig


def plot_discrepancy_gap(report: Any, *, title: str | None = None) -> Figure:
    """Held-out stroke-residual RMS before and after adding the named effect, against the noise
    floor (the RMS that noise alone leaves)."""
    unit = report.fitted.model.report_unit
    fig, ax = plt.subplots(figsize=(5.5, 4))
    vals = [report.gap_before, report.gap_after]
    labels = ["before (base model)", f"after (+ {report.named_effect})"]
    ax.bar(labels, vals, color=["tab:red", "tab:blue"], label="held-out residual RMS")
    ax.axhline(report.noise_floor, color="k", ls="--", lw=1, label=f"noise floor {report.noise_floor:.3g} {unit}")
    for i, v in enumerate(vals):
        ax.text(i, v, f"{v:.3g}", ha="center", va="bottom", fontsize=8)
    ax.set_ylabel(f"held-out residual RMS ({unit})")
    ax.set_xlabel("model fitted to the training poses")
    ax.legend(fontsize=8)
    ax.grid(True, axis="y", alpha=0.3)
    ax.set_title(title or "gap before / after", fontsize=10)
    fig.tight_layout()
    return fig
