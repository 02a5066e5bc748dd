"""Figures for the notebooks and the command line (matplotlib), one module per domain.

Import explicitly, ``from stewart_jax import plotting``; ``import stewart_jax`` does not import
this package, so the core library never imports matplotlib.

NOTE: the library never chooses the matplotlib backend. A script that only writes files
selects one before the first figure (the command line sets ``matplotlib.use("Agg")`` for
``--plot``; the tests set ``MPLBACKEND=Agg``); otherwise matplotlib's own choice applies
(a notebook's inline backend, a GUI where there is a display, Agg where there is none).

Every function returns a :class:`matplotlib.figure.Figure` and draws nothing on the screen;
:func:`show` displays a figure in a notebook (once), optionally saves it, and closes it.
Conventions: pose errors in µm (dx, dy, dz) and arc-seconds (φ, θ, ψ), as the papers' tables;
every axis has its unit and every panel a legend; values from a paper are drawn as black
markers or dashed lines labelled "paper".

- calibration (Wang et al. 2018): :func:`plot_pose_errors`, :func:`plot_table_comparison`,
  :func:`plot_convergence`, :func:`plot_singular_values`, :func:`plot_parameter_std`,
  :func:`plot_reading_residuals`;
- the FAST cable robot (Yin et al.): :func:`plot_fast_time_series`, :func:`plot_fast_table2`,
  :func:`plot_fast_focal_map` (workspace and frequency maps), :func:`plot_fast_frequencies`;
- model discrepancy: :func:`plot_residuals_vs_factor`, :func:`plot_residuals` (PNG files),
  :func:`plot_discrepancy_ranking`, :func:`plot_discrepancy_gap`, :func:`plot_cabin_record`;
- compensation tables: :func:`plot_table_offsets`.
"""


from ._cable_robot import (
    plot_fast_focal_map as plot_fast_focal_map,
    plot_fast_frequencies as plot_fast_frequencies,
    plot_fast_table2 as plot_fast_table2,
    plot_fast_time_series as plot_fast_time_series,
)
from ._calibration import (
    PAPER_TABLE4 as PAPER_TABLE4,
    plot_convergence as plot_convergence,
    plot_parameter_std as plot_parameter_std,
    plot_pose_errors as plot_pose_errors,
    plot_reading_residuals as plot_reading_residuals,
    plot_singular_values as plot_singular_values,
    plot_table_comparison as plot_table_comparison,
)
from ._common import show as show
from ._compensation import plot_table_offsets as plot_table_offsets
from ._discrepancy import (
    plot_cabin_record as plot_cabin_record,
    plot_discrepancy_gap as plot_discrepancy_gap,
    plot_discrepancy_ranking as plot_discrepancy_ranking,
    plot_residuals as plot_residuals,
    plot_residuals_vs_factor as plot_residuals_vs_factor,
)
from ._mechanism import plot_workspace as plot_workspace

