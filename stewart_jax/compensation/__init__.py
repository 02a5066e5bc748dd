"""Compensation look-up tables in the telescope controller's own format: read, apply, fit with
uncertainty, check and compare (the Rubin Observatory's hexapod tables, schemas v3–v7).

- The table: :class:`CompensationTable` (a pytree; :meth:`~CompensationTable.offsets` is the
  controller's rule, jitted and vectorised over attitudes), :func:`load_table` (YAML files
  merged in order, later wins), :func:`save_table` (a schema-v7 override file).
- Poses and struts: :func:`offsets_to_poses` (the controller's µm, degrees and
  ``Rx(u)·Ry(v)·Rz(w)`` to the library's mm, rad and ``Rz(ψ)·Ry(θ)·Rx(φ)``),
  :func:`strut_changes` (through any mechanism's inverse kinematics).
- Campaigns: :class:`Campaign`, :func:`read_campaign`, :func:`write_campaign`,
  :func:`simulate_campaign` from a table or a :class:`FlexureModel`; :func:`read_points_campaign`
  (a laser tracker's target points at each attitude, turned into pose offsets).
- Fit: :func:`fit_table` → :class:`TableFit` (degrees by cross-validation, σ of every
  coefficient and prediction, solid/marginal/noise labels, only significant terms kept).
- Check and compare: :func:`check_table` → :class:`TableCheck`, :func:`diff_tables` →
  :class:`TableDiff`, over a :class:`Domain`.

This layer sits above :mod:`stewart_jax.mechanism` and :mod:`stewart_jax.calibration`; nothing
below imports it.
"""

from ._apply import offsets_to_poses as offsets_to_poses, strut_changes as strut_changes
from ._campaign import (
    Campaign as Campaign,
    FlexureModel as FlexureModel,
    read_campaign as read_campaign,
    simulate_campaign as simulate_campaign,
    write_campaign as write_campaign,
)
from ._check import (
    Domain as Domain,
    TableCheck as TableCheck,
    TableDiff as TableDiff,
    check_table as check_table,
    diff_tables as diff_tables,
)
from ._fit import TableFit as TableFit, fit_table as fit_table
from ._points import read_points_campaign as read_points_campaign
from ._table import CompensationTable as CompensationTable
from ._yaml import load_table as load_table, save_table as save_table
