"""Residual plots of a :class:`~stewart_jax.discrepancy.DiagnosisReport` (matplotlib, Agg,
imported only when called)."""

from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np


def plot_residuals(
    report, directory: str | os.PathLike[str], *, which: str = "both", factors: Sequence[str] | None = None
) -> list[str]:
    """One PNG per factor (default: every factor of the model): the held-out residuals of each
    output against the factor, before (base model) and/or after (augmented model) the fix, with
    the ±2σ noise band. Returns the paths written."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if which not in ("before", "after", "both"):
        raise ValueError(f"which must be 'before', 'after' or 'both', got {which!r}")
    os.makedirs(directory, exist_ok=True)
    series = []
    if which in ("before", "both"):
        series.append(("before (base model)", report.residuals_before, "tab:red"))
    if which in ("after", "both") and report.named_effect != "none":
        series.append((f"after (+ {report.named_effect})", report.residuals_after, "tab:blue"))
    model = report.fitted.model
    names = model.output_names
    band = 2.0 * report.noise_floor
    paths = []
    unknown = sorted(set(factors or ()) - set(report.test_factors))
    if unknown:
        raise ValueError(f"unknown factor(s) {unknown}; the data have {sorted(report.test_factors)}")
    for factor, x in report.test_factors.items():
        if factors is not None and factor not in factors:
            continue
        k = len(names)
        cols = 3 if k > 3 else k
        rows = int(np.ceil(k / cols))
        fig, axes = plt.subplots(rows, cols, figsize=(4 * cols, 3 * rows), sharey=True, squeeze=False)
        for j, ax in enumerate(axes.flat):
            if j >= k:
                ax.set_visible(False)
                continue
            for label, res, color in series:
                ax.plot(x[:, j], res[:, j], "o", ms=3, alpha=0.7, color=color, label=label)
            ax.axhspan(-band, band, color="0.85", zorder=0, label="±2σ noise")
            ax.axhline(0.0, color="0.5", lw=0.8)
            ax.set_title(names[j])
            ax.set_xlabel(factor)
            if j % cols == 0:
                ax.set_ylabel(f"held-out residual ({model.report_unit})")
        axes.flat[0].legend(fontsize=7)
        fig.suptitle(f"{report.model}: residuals vs {factor}; named: {report.named_effect}")
        fig.tight_layout()
        path = os.path.join(os.fspath(directory), f"residuals_{factor}.png")
        fig.savefig(path, dpi=90)
        plt.close(fig)
        paths.append(path)
    return paths
