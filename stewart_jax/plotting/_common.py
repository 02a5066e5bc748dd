"""What every figure shares: :func:`show`, the pose-component labels, colours and the common
end of the single-axes plots."""

from __future__ import annotations

import os
import sys
from collections.abc import Mapping
from typing import Any

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from .._units import COMPONENTS

_GREEK = {"phi": "φ", "theta": "θ", "psi": "ψ"}

COMPONENT_LABELS = tuple(_GREEK.get(c, c) for c in COMPONENTS)
"""Pose components in report order, ``("dx", "dy", "dz", "φ", "θ", "ψ")``: the first three in
µm, the last three in ″."""

COLORS = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
"""The default colour cycle, indexed by series."""


def as_mapping(x: Any, default_label: str) -> dict[str, np.ndarray]:
    """``x`` as label → float array: a mapping as it is, anything else under ``default_label``."""
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


def finish(fig: Figure, ax, title: str | None) -> Figure:
    """Grid, legend, optional title, tight layout: the common end of the single-axes plots."""
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    if title:
        ax.set_title(title, fontsize=10)
    fig.tight_layout()
    return fig


def finish_figure(fig: Figure, title: str | None) -> Figure:
    """Optional figure title and tight layout: the common end of the multi-axes plots."""
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig
