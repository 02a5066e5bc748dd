"""Figures of the model-discrepancy workflow, from a
:class:`~stewart_jax.discrepancy.DiagnosisReport` (duck-typed: any object with its fields):
held-out residuals against a factor before and after the named effect, the ranking of the
candidate effects, and the gap before / after against the noise floor.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Patch

_WHICH = ("before", "after", "both")


def _factor_label(factor: str) -> str:
    if factor == "direction":
        return "approach direction (±1)"
    return (factor.replace("_urad", " (µrad)").replace("_um", " (µm)").replace("_arcsec", " (″)")
            .replace("_C", " (°C)").replace("_s", " (s)"))


def plot_residuals_vs_factor(
    report: Any, factor: str, *, which: str = "both", title: str | None = None
) -> Figure:
    """Held-out residuals of a :class:`~stewart_jax.discrepancy.DiagnosisReport` against one
    factor (e.g. ``"direction"``, ``"temperature_C"``, ``"time_s"``, ``"stroke_um"``), one
    panel per output, before (base model) and/or after (augmented model; ``which`` is
    ``"before"``, ``"after"`` or ``"both"``), with the ±2σ noise band."""
    if which not in _WHICH:
        raise ValueError(f"which must be one of {_WHICH}, got {which!r}")
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
    series = []
    if which in ("before", "both"):
        series.append(("before (base model)", report.residuals_before, "tab:red"))
    added = _added(report)
    if which in ("after", "both") and added:
        series.append((f"after (+ {added})", report.residuals_after, "tab:blue"))
    for j, ax in enumerate(axes.flat):
        if j >= k:
            ax.set_visible(False)
            continue
        for label, res, color in series:
            ax.plot(x[:, j], np.asarray(res)[:, j], "o", ms=3, alpha=0.7, color=color, label=label)
        ax.axhspan(-band, band, color="0.88", zorder=0, label="±2σ noise")
        ax.axhline(0.0, color="0.5", lw=0.8)
        ax.set_title(names[j], fontsize=9)
        ax.set_xlabel(_factor_label(factor))
        if j % cols == 0:
            ax.set_ylabel(f"held-out residual ({model.report_unit})")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=6)
    fig.suptitle(title or f"held-out residuals vs {factor}; named: {report.named_effect}")
    fig.tight_layout()
    return fig


def plot_residuals(
    report: Any, directory: str | os.PathLike[str], *, which: str = "both",
    factors: Sequence[str] | None = None,
) -> list[str]:
    """Write one PNG per factor (default: every factor of the report),
    ``directory/residuals_<factor>.png``, each the figure of :func:`plot_residuals_vs_factor`.
    Returns the paths written."""
    if which not in _WHICH:
        raise ValueError(f"which must be one of {_WHICH}, got {which!r}")
    unknown = sorted(set(factors or ()) - set(report.test_factors))
    if unknown:
        raise ValueError(f"unknown factor(s) {unknown}; the data have {sorted(report.test_factors)}")
    os.makedirs(directory, exist_ok=True)
    paths = []
    for factor in report.test_factors:
        if factors is not None and factor not in factors:
            continue
        fig = plot_residuals_vs_factor(
            report, factor, which=which,
            title=f"{report.model}: residuals vs {factor}; named: {report.named_effect}",
        )
        path = os.path.join(os.fspath(directory), f"residuals_{factor}.png")
        fig.savefig(path, dpi=90)
        plt.close(fig)
        paths.append(path)
    return paths


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


def _added(report: Any) -> str | None:
    """What the augmented model adds: the named effect, or the discovered terms."""
    if report.named_effect not in (None, "none"):
        return report.named_effect
    return "discovered terms" if getattr(report, "discovered", None) else None


def plot_discrepancy_gap(report: Any, *, title: str | None = None) -> Figure:
    """Held-out stroke-residual RMS before and after adding the named effect, against the noise
    floor (the RMS that noise alone leaves)."""
    unit = report.fitted.model.report_unit
    fig, ax = plt.subplots(figsize=(5.5, 4))
    vals = [report.gap_before, report.gap_after]
    labels = ["before (base model)", f"after (+ {_added(report) or 'nothing'})"]
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
