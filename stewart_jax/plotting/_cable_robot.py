"""Figures of the FAST cable-driven feed support: the scenario's time series (Figs. 6–9) and
Table 2 beside the paper's.

Yin J., Jiang P., Chen M., Yao R., *Dynamic modeling of a cable-driven parallel robot with a
Stewart platform for use in FAST*: §6, eqs. 62–66, Figs. 6–9, Table 2.

The results are duck-typed (any object with the fields of
:class:`stewart_jax.cable_robot.ScenarioResult`), so importing this module does not import
:mod:`stewart_jax.cable_robot`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from ._common import COLORS, finish_figure


def plot_fast_time_series(result: Any, *, title: str | None = None) -> Figure:
    """Yin et al. Figs. 6–9 from a :class:`stewart_jax.cable_robot.ScenarioResult`: planned and actual
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
    return finish_figure(fig, title)


def plot_fast_table2(
    ours: Mapping[Any, Mapping[str, Any]],
    *,
    paper: Mapping[Any, Mapping[str, Sequence[float]]] | None = None,
    title: str | None = None,
) -> Figure:
    """Yin et al. Table 2 per cabin position and axis: std of (extra error − cabin displacement)
    and amplitude of the extra error (m, log axis), ours as bars, the paper's as black markers.

    ``ours``: position → ``{"std": 3 values, "amplitude": 3 values}`` (and optionally
    ``"peak_to_peak"``, drawn as open circles). ``paper``: position → axis → (std, amplitude),
    as :data:`stewart_jax.cable_robot.PAPER_TABLE2`.
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
            color = COLORS[i % len(COLORS)]
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
    return finish_figure(fig, title)
