"""Figures of compensation tables: offsets against elevation at several rotator angles."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from ._common import COLORS, finish_figure

_AXES = (("x", "µm"), ("y", "µm"), ("z", "µm"), ("u", "deg"), ("v", "deg"), ("w", "deg"))
"""A compensation table's offsets, in the controller's order and units."""
_STYLES = ("-", "--", ":", "-.")


def plot_table_offsets(
    tables: Mapping[str, Any],
    rotations_deg: Sequence[float] = (-90.0, -45.0, 0.0, 45.0, 90.0),
    *,
    temperature_degC: float = 0.0,
    title: str | None = None,
) -> Figure:
    """Six panels (x, y, z in µm; u, v, w in deg): each table's offsets against elevation
    (0–90°) at each rotator angle, one colour per angle and one line style per table (at most
    four :class:`~stewart_jax.compensation.CompensationTable`, by label)."""
    if not 1 <= len(tables) <= len(_STYLES):
        raise ValueError(f"plot_table_offsets draws 1 to {len(_STYLES)} tables, got {len(tables)}")
    e = np.linspace(0.0, 90.0, 91)
    fig, axs = plt.subplots(2, 3, figsize=(12, 6.5), sharex=True)
    for (label, table), style in zip(tables.items(), _STYLES, strict=False):
        for j, rot in enumerate(rotations_deg):
            off = np.asarray(table.offsets(e, rot, 0.0, temperature_degC))
            for i, ax in enumerate(axs.ravel()):
                ax.plot(e, off[:, i], style, color=COLORS[j % len(COLORS)], lw=1.2,
                        label=f"{label}, rotation {rot:g}°")
    for i, ax in enumerate(axs.ravel()):
        ax.set_ylabel(f"{_AXES[i][0]} offset ({_AXES[i][1]})")
        ax.grid(True, alpha=0.3)
        if i >= 3:
            ax.set_xlabel("elevation (deg)")
    axs[0, 0].legend(fontsize=6)
    return finish_figure(fig, title)
