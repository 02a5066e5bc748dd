"""Figures of the FAST cable-driven feed support: the scenario's time series (Figs. 6–9),
Table 2 beside the paper's, and (beyond the paper) maps over the focal surface and the cabin's
natural frequencies.

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

from ._common import COLORS, finish, finish_figure


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


def plot_fast_focal_map(
    positions: Any,
    values: Any,
    *,
    feasible: Any | None = None,
    label: str = "value",
    title: str | None = None,
    cmap: str = "viridis",
) -> Figure:
    """A quantity over FAST's focal surface, seen from above: one marker per cabin position at
    its (x, y) in G (m), coloured by ``values`` (``label`` names it with its unit); positions
    where ``feasible`` is false are drawn as grey crosses. Tower directions are marked on the
    rim (Yin et al., eq. 1: towers at azimuths 0°, 60°, …, 300°).

    ``positions``: ``(n, 3)`` metres; ``values``: ``(n,)``; ``feasible``: ``(n,)`` booleans.
    """
    p = np.asarray(positions, dtype=float)
    v = np.asarray(values, dtype=float)
    ok = np.ones(len(p), bool) if feasible is None else np.asarray(feasible, bool)
    ok = ok & np.isfinite(v)
    fig, ax = plt.subplots(figsize=(6.4, 5.6))
    sc = ax.scatter(p[ok, 0], p[ok, 1], c=v[ok], cmap=cmap, s=28, label="feasible")
    if (~ok).any():
        ax.plot(p[~ok, 0], p[~ok, 1], "x", color="0.6", ms=5, label="infeasible")
    fig.colorbar(sc, ax=ax, label=label)
    r = 1.05 * np.max(np.linalg.norm(p[:, :2], axis=1)) if len(p) else 1.0
    for k in range(6):
        a = k * np.pi / 3
        ax.annotate(f"T{k + 1}", (r * np.cos(a), r * np.sin(a)), ha="center", va="center", fontsize=8,
                    color="0.3")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    return finish(fig, ax, title)


def plot_fast_frequencies(
    frequencies: Mapping[str, Sequence[float]],
    *,
    checks: Mapping[str, float] | None = None,
    cable: Mapping[str, Sequence[float]] | None = None,
    title: str | None = None,
) -> Figure:
    """Natural frequencies (Hz, log axis) of the cabin per case (a position and attitude,
    ``frequencies``: label → six values) as dots; ``checks``: label → the lowest frequency
    from the FFT of the free response (open circles); ``cable``: label → the six cables' first
    string frequencies (grey bars from their least to their greatest)."""
    labels = list(frequencies)
    fig, ax = plt.subplots(figsize=(max(6.0, 1.3 * len(labels) + 2), 4.6))
    x = np.arange(len(labels))
    for i, lab in enumerate(labels):
        f = np.asarray(frequencies[lab], dtype=float)
        ax.plot(np.full(len(f), x[i]), f, "o", color=COLORS[0], label=None if i else "cabin modes")
        if checks is not None and lab in checks:
            ax.plot(x[i] + 0.15, checks[lab], "o", mfc="none", color="k", ms=9,
                    label=None if i else "lowest, FFT of free response")
        if cable is not None and lab in cable:
            c = np.asarray(cable[lab], dtype=float)
            ax.plot([x[i] - 0.15] * 2, [c.min(), c.max()], "-", color="0.5", lw=5, alpha=0.6,
                    label=None if i else "cables' first string modes")
    ax.set_xticks(x, labels, rotation=20, ha="right", fontsize=8)
    ax.set_yscale("log")
    ax.set_ylabel("frequency (Hz)")
    return finish(fig, ax, title)
