"""Figures of a mechanism's reachable workspace (:mod:`stewart_jax.mechanism`'s
:func:`~stewart_jax.mechanism.translation_envelope` and
:func:`~stewart_jax.mechanism.workspace_along_rays`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ._common import finish_figure

_PLANES = {"xy": (0, 1, 2), "xz": (0, 2, 1), "yz": (1, 2, 0)}


def plot_workspace(
    envelope: Any,
    *,
    sections: Mapping[str, Any] | Sequence[str] = ("xy", "xz"),
    travel: Any = None,
    band_deg: float = 10.0,
    title: str | None = None,
):
    """The translation envelope (mm): its boundary points in 3-D, coloured by the leg whose limit
    ends each ray, and two sections through the centre.

    ``envelope``: a :class:`~stewart_jax.mechanism.RayExtents` of translation-only directions
    (e.g. :func:`~stewart_jax.mechanism.translation_envelope`). ``sections``: two planes, either
    a mapping plane → the envelope of that plane's section (exact: e.g.
    ``translation_envelope(m, 72, plane="xy")``) or plane names only, among ``"xy"``, ``"xz"``,
    ``"yz"``; a named plane is then approximated by the rays of ``envelope`` within
    ``band_deg`` of it, each drawn at its angle in the plane with its full extent.
    ``travel``: the published half-widths ``[x, y, z, …]`` (mm; e.g.
    ``mechanism.travel_half_widths``), drawn as a dashed black box labelled "published travel".
    Rays that reached ``max_extent`` (no limit met) are drawn grey.
    """
    import matplotlib.pyplot as plt

    dirs, extent, centre, hit, leg = _rays(envelope, "envelope")
    planes = list(sections)
    if len(planes) != 2 or any(p not in _PLANES for p in planes):
        raise ValueError(f"sections must name two of {sorted(_PLANES)}, got {planes!r}")
    pts = centre[:3] + extent[:, None] * dirs[:, :3]
    half = None if travel is None else np.asarray(travel, dtype=float)[:3]

    cmap = plt.get_cmap("tab10")
    fig = plt.figure(figsize=(14, 4.8))
    ax3 = fig.add_subplot(1, 3, 1, projection="3d")
    for k in range(6):
        sel = (leg == k) & ~hit
        if np.any(sel):
            ax3.scatter(*pts[sel].T, s=8, color=cmap(k), label=f"limit of leg {k + 1}")
    if np.any(hit):
        ax3.scatter(*pts[hit].T, s=8, color="0.6", label="max_extent reached")
    if half is not None:
        _box_3d(ax3, centre[:3], half)
    ax3.set_xlabel("x (mm)")
    ax3.set_ylabel("y (mm)")
    ax3.set_zlabel("z (mm)")
    ax3.set_title(f"boundary points ({len(extent)} rays)", fontsize=10)
    ax3.legend(fontsize=7, loc="upper left")

    for p, plane in enumerate(planes):
        a, b, normal = _PLANES[plane]
        ax = fig.add_subplot(1, 3, p + 2)
        if isinstance(sections, Mapping):
            sd, se, sc, sh, sl = _rays(sections[plane], f"sections[{plane!r}]")
            if np.any(np.abs(sd[:, normal]) > 1e-12):
                raise ValueError(f"sections[{plane!r}] has directions out of the {plane} plane")
            label = f"section ({len(se)} rays in the plane)"
        else:
            keep = np.abs(dirs[:, normal]) <= np.sin(np.deg2rad(band_deg))
            sd, se, sc, sh, sl = dirs[keep], extent[keep], centre, hit[keep], leg[keep]
            label = f"approximate section ({int(keep.sum())} rays within {band_deg:g}° of the plane)"
        if len(se):
            ang = np.arctan2(sd[:, b], sd[:, a])
            order = np.argsort(ang)
            ua, ub = np.cos(ang[order]), np.sin(ang[order])
            xa, xb = sc[a] + se[order] * ua, sc[b] + se[order] * ub
            ax.plot(np.append(xa, xa[0]), np.append(xb, xb[0]), "-", color="C0", lw=1, label=label)
            colors = ["0.6" if h else cmap(k) for h, k in zip(sh[order], sl[order], strict=True)]
            ax.scatter(xa, xb, s=12, c=colors, zorder=3)
        ax.plot(centre[a], centre[b], "k+", ms=8, label="centre")
        if half is not None:
            ax.add_patch(plt.Rectangle((centre[a] - half[a], centre[b] - half[b]), 2 * half[a], 2 * half[b],
                                       fill=False, ls="--", ec="k", lw=1, label="published travel"))
        ax.set_xlabel(f"{'xyz'[a]} (mm)")
        ax.set_ylabel(f"{'xyz'[b]} (mm)")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"section {plane} (colour: leg whose limit binds)", fontsize=10)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc="upper right")
    return finish_figure(fig, title)


def _rays(envelope: Any, name: str):
    dirs = np.asarray(envelope.directions, dtype=float)
    extent = np.asarray(envelope.extent, dtype=float)
    if dirs.ndim != 2 or dirs.shape[1] != 6 or extent.shape != (dirs.shape[0],):
        raise ValueError(f"{name} must hold (n, 6) directions and (n,) extents, got {dirs.shape}, {extent.shape}")
    if np.any(np.abs(dirs[:, 3:]) > 0):
        raise ValueError(f"{name}: plot_workspace draws translation envelopes; φ = θ = ψ must be 0 in every direction")
    return (dirs, extent, np.asarray(envelope.centre, dtype=float), np.asarray(envelope.hit_max, dtype=bool),
            np.asarray(envelope.binding_leg, dtype=int))


def _box_3d(ax, centre: np.ndarray, half: np.ndarray) -> None:
    """The dashed edges of the box ``centre ± half``."""
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    first = True
    for i in range(8):
        for j in range(i + 1, 8):
            if np.sum(corners[i] != corners[j]) == 1:
                seg = centre + np.vstack([corners[i], corners[j]]) * half
                ax.plot(*seg.T, "k--", lw=0.8, label="published travel" if first else None)
                first = False
