"""Figures of the hexapod calibration: per-pose control errors, the tables of maximum error
beside the paper's, optimiser convergence, identifiability (singular values, parameter std)
and stroke residuals.

Wang H., Cao X. et al., "Improved cuckoo calibration method of space telescope secondary
mirror adjusting mechanism", Infrared and Laser Engineering 47(5), 2018: Figs. 2, 3, 6, 7 (pose errors) and Tables 2–4
(maximum control error).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from .._units import report_factor, report_unit
from ._common import COLORS, COMPONENT_LABELS, as_mapping, finish, finish_figure

PAPER_TABLE4: dict[str, list[float]] = {
    "Sampling points before calibration": [19.52, 19.97, 17.25, 115.44, 105.73, 123.84],
    "Sampling points after calibration": [9.68, 7.72, 6.14, 8.86, 8.53, 8.54],
    "Validation points after calibration": [9.85, 8.91, 7.18, 10.03, 10.98, 11.41],
}
"""Wang et al. 2018, Table 4 (experiment on the prototype, laser tracker, Ω = nominal ± 2.5 mm):
max control error, dx/dy/dz in µm, φ/θ/ψ in ″ — the paper's values, for marking on our figures.

NOTE: this is data of the paper, not plotting; it stays importable from
:mod:`stewart_jax.plotting` until the paper tables have a home of their own."""


def plot_pose_errors(
    errors_um_arcsec: Any,
    *,
    paper: Any = None,
    title: str | None = None,
    symlog: bool = False,
) -> Figure:
    """Per-pose control error (Wang et al. 2018, Figs. 2, 3, 6, 7 style).

    ``errors_um_arcsec``: ``(n_poses, 6)`` signed errors (µm, ″), or a mapping label → such an
    array (one row of panels per label, e.g. before / SMCS / VSA-SMCS / LM). ``paper``: the
    paper's maximum |error| per component (6 numbers), or a mapping with the same labels as
    ``errors_um_arcsec``; drawn as dashed ±max lines in each component's colour. Left panels:
    dx, dy, dz (µm); right panels: φ, θ, ψ (″); x axis: pose index.
    """
    series = as_mapping(errors_um_arcsec, "error")
    if isinstance(paper, Mapping):
        paper_map = {str(k): np.asarray(v, dtype=float) for k, v in paper.items()}
    elif paper is not None:
        paper_map = {k: np.asarray(paper, dtype=float) for k in series}
    else:
        paper_map = {}
    for label, e in series.items():
        if e.ndim != 2 or e.shape[1] != 6:
            raise ValueError(f"{label}: expected (n_poses, 6) errors in µm and ″, got shape {e.shape}")
    n = len(series)
    fig, axes = plt.subplots(n, 2, figsize=(11, 2.8 * n + 0.6), squeeze=False, sharex=True)
    for row, (label, e) in enumerate(series.items()):
        idx = np.arange(1, e.shape[0] + 1)
        for side, (lo, unit) in enumerate(((0, "µm"), (3, "″"))):
            ax = axes[row, side]
            width = 0.8 / 3 if e.shape[0] <= 30 else None
            for k in range(3):
                c = lo + k
                color = COLORS[k]
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
    return finish_figure(fig, title)


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
            color = COLORS[g % len(COLORS)]
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
    return finish_figure(fig, title)


def plot_convergence(
    histories: Mapping[str, Mapping[str, Any]],
    *,
    reference: Mapping[str, float] | None = None,
    title: str | None = None,
    cost_unit: str = "mm²",
) -> Figure:
    """Best objective S against objective evaluations, median and 10–90 % band over seeds.

    ``histories``: label → ``{"evaluations_median", "cost_median", "cost_p10", "cost_p90"}``
    (``run_study(...)["rows"][label]["history"]``). ``reference``: label → a final S to draw as
    a dashed horizontal line (e.g. LM's median final S). ``cost_unit``: S's unit (the readings'
    squared: ``mm²``, or ``rad²`` for a rotary family). Log–log axes.
    """
    fig, ax = plt.subplots(figsize=(7.5, 4.6))
    for i, (label, h) in enumerate(histories.items()):
        n = np.asarray(h["evaluations_median"], dtype=float)
        keep = n > 0
        color = COLORS[i % len(COLORS)]
        ax.plot(n[keep], np.asarray(h["cost_median"])[keep], color=color, label=f"{label} (median)")
        if "cost_p10" in h and "cost_p90" in h:
            ax.fill_between(n[keep], np.asarray(h["cost_p10"])[keep], np.asarray(h["cost_p90"])[keep],
                            color=color, alpha=0.2, label=f"{label} (10–90 % over seeds)")
    for j, (label, value) in enumerate((reference or {}).items()):
        ax.axhline(value, color="k", ls=("--", ":", "-.")[j % 3], lw=1, label=label)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("objective evaluations")
    ax.set_ylabel(f"best S ({cost_unit})")
    return finish(fig, ax, title)


def plot_singular_values(
    singular_values: Any,
    *,
    rtol: float | None = 1e-9,
    title: str | None = None,
) -> Figure:
    """Singular values of the (column-scaled) identification Jacobian, descending, for one or
    several pose sets (label → values). ``rtol`` draws the numerical-rank threshold relative to
    each set's largest value."""
    series = as_mapping(singular_values, "singular values")
    fig, ax = plt.subplots(figsize=(7.5, 4.4))
    for i, (label, s) in enumerate(series.items()):
        color = COLORS[i % len(COLORS)]
        s = np.sort(s)[::-1]
        ax.semilogy(np.arange(1, len(s) + 1), np.maximum(s, 1e-300), "o-", ms=3, color=color,
                    label=f"{label} (σ_max/σ_min = {s[0] / s[-1]:.3g})" if s[-1] > 0 else label)
        if rtol is not None:
            ax.axhline(rtol * s[0], color=color, ls=":", lw=1, label=f"{label}: rank threshold {rtol:g}·σ_max")
    ax.set_xlabel("index of singular value")
    ax.set_ylabel("singular value (dimensionless, columns scaled to unit norm)")
    return finish(fig, ax, title)


def plot_parameter_std(
    param_std_mm: Any,
    *,
    actual_error_mm: Any = None,
    names: Sequence[str] | None = None,
    units: Sequence[str] | None = None,
    title: str | None = None,
) -> Figure:
    """Predicted standard deviation of each calibrated parameter (log axis), for one or several
    pose sets (label → n values, each in its parameter's unit), optionally with the actual
    |estimate − truth| of one calibration (label → n values) as markers. ``names``: one label per
    parameter (e.g. a mechanism's ``param_names``; default for 36: the 6-PSS joint centres
    ``A1x … B6z``); ``units``: each parameter's unit (a mechanism's ``param_units``; default mm):
    lengths are drawn in µm, angles in µrad."""
    series = as_mapping(param_std_mm, "predicted std")
    n = len(next(iter(series.values())))
    if names is None:
        names = ([f"{'A' if i < 18 else 'B'}{(i % 18) // 3 + 1}{'xyz'[i % 3]}" for i in range(36)] if n == 36
                 else [str(i) for i in range(n)])
    units = ("mm",) * n if units is None else tuple(units)
    if len(names) != n or len(units) != n:
        raise ValueError(f"{len(names)} names and {len(units)} units for {n} parameters")
    factor = np.array([report_factor(u) for u in units])
    shown = sorted({report_unit(u) for u in units}, key=("µm", "µrad").index)
    fig, ax = plt.subplots(figsize=(max(12, 0.3 * n), 4.2))
    for i, (label, s) in enumerate(series.items()):
        ax.semilogy(np.arange(n), np.maximum(np.asarray(s) * factor, 1e-9), "o-", ms=3, color=COLORS[i % len(COLORS)],
                    label=f"{label}: predicted std")
    if actual_error_mm is not None:
        for i, (label, e) in enumerate(as_mapping(actual_error_mm, "actual error").items()):
            ax.semilogy(np.arange(n), np.maximum(np.abs(np.asarray(e)) * factor, 1e-9), "x", ms=5,
                        color=COLORS[(i + len(series)) % len(COLORS)], label=f"{label}: |estimate − truth|")
    ax.set_xticks(np.arange(n), [f"{m} ({report_unit(u)})" if len(shown) > 1 else m for m, u in zip(names, units,
                                                                                                    strict=True)],
                  rotation=90, fontsize=7)
    ax.set_xlabel("parameter")
    ax.set_ylabel(" / ".join(f"{u} ({'lengths' if u == 'µm' else 'angles'})" for u in shown) if len(shown) > 1
                  else shown[0])
    return finish(fig, ax, title)


def plot_reading_residuals(
    residuals_um: Any, *, sigma_um: float | None = None, title: str | None = None, unit: str = "µm"
) -> Figure:
    """Reading residuals ``q' − IK(P', u)`` per pose and leg (``unit``: µm for strokes, µrad for a
    rotary family's crank angles), for one or several parameter sets (label → ``(m, 6)``), e.g.
    nominal vs calibrated; ``sigma_um`` draws a ±2σ band (same unit)."""
    series = as_mapping(residuals_um, "residual")
    fig, axes = plt.subplots(len(series), 1, figsize=(10, 2.8 * len(series) + 0.5), squeeze=False, sharex=True)
    for ax, (label, r) in zip(axes[:, 0], series.items(), strict=True):
        idx = np.arange(1, r.shape[0] + 1)
        for leg in range(r.shape[1]):
            ax.plot(idx, r[:, leg], "o", ms=3, color=COLORS[leg % len(COLORS)], label=f"leg {leg + 1}")
        if sigma_um is not None:
            ax.axhspan(-2 * sigma_um, 2 * sigma_um, color="0.88", zorder=0, label=f"±2σ = ±{2 * sigma_um:.3g} {unit}")
        ax.axhline(0, color="0.4", lw=0.6)
        rms = float(np.sqrt(np.mean(r**2)))
        ax.set_title(f"{label}: RMS {rms:.3g} {unit}", fontsize=10)
        ax.set_ylabel(f"{'stroke' if unit == 'µm' else 'reading'} residual ({unit})")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, ncol=4)
    axes[-1, 0].set_xlabel("pose index (row of the CSV)")
    return finish_figure(fig, title)
