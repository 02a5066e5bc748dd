"""Checking a compensation table before it is deployed, and comparing two tables.

Rubin Observatory, *MTHexapod CSC* (``lsst-ts/ts_mthexapod``, 2020–2025): the controller checks
every compensated position against the axis limits and, through the inverse kinematics, the
struts' length changes against the actuators' range. :func:`check_table` does the same over the
whole domain (a grid of elevation × rotator angle × temperature) instead of at one attitude, and
against a campaign asks of each axis whether the table reduces the measured offsets' RMS.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..mechanism._abstract import AbstractMechanism
from ._apply import strut_changes, travel_limits
from ._campaign import Campaign
from ._table import AXES, AXIS_UNITS, CompensationTable

WORSE_RATIO = 1.02
"""An axis is made worse when the RMS of measured − table exceeds the measured RMS by 2 %."""


class Domain(NamedTuple):
    """The attitudes a check scans: ranges (deg, °C) and grid sizes."""

    elevation_deg: tuple[float, float] = (0.0, 90.0)
    rotation_deg: tuple[float, float] = (-90.0, 90.0)
    temperature_degC: tuple[float, float] | None = None
    n_elevation: int = 46
    n_rotation: int = 61
    n_temperature: int = 5

    def grid(self, table: CompensationTable) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The flattened grid; the temperature range defaults to the table's own range when its
        temperature polynomial is not zero, else 0 °C."""
        lo, hi = self.elevation_deg
        if not 0.0 <= lo <= hi <= 90.0:
            raise ValueError(f"the elevation range must lie in [0, 90] deg, got {self.elevation_deg}")
        if self.rotation_deg[0] > self.rotation_deg[1]:
            raise ValueError(f"the rotation range must be MIN,MAX, got {self.rotation_deg}")
        t_range = self.temperature_degC
        if t_range is None:
            uses_t = bool(np.any(np.asarray(table.temperature) != 0.0))
            t_range = ((float(table.min_temperature_degC), float(table.max_temperature_degC)) if uses_t else (0.0, 0.0))
        nt = 1 if t_range[0] == t_range[1] else self.n_temperature
        e, r, t = np.meshgrid(np.linspace(lo, hi, self.n_elevation), np.linspace(*self.rotation_deg, self.n_rotation),
                              np.linspace(*t_range, nt), indexing="ij")
        return e.ravel(), r.ravel(), t.ravel()


def _at(att: dict, i: int) -> dict:
    """The attitude of grid point ``i`` (with its filter, where the table has filters)."""
    out = {k: float(v[i]) for k, v in att.items() if k != "filter"}
    if "filter" in att:
        out["filter"] = att["filter"][i]
    return out


def _where(att: dict, i: int) -> str:
    a = _at(att, i)
    text = f"elevation {a['elevation_deg']:g}°, rotation {a['rotation_deg']:g}°, {a['temperature_degC']:g} °C"
    return text + (f", filter {a['filter']}" if a.get("filter") else "")


def _scan(table: CompensationTable, domain: Domain | None, filters: bool) -> tuple[dict, np.ndarray]:
    """The domain's grid (× every filter of the table and none, where ``filters``) and the
    table's offsets there."""
    e, r, t = (domain or Domain()).grid(table)
    att = {"elevation_deg": e, "rotation_deg": r, "temperature_degC": t}
    if not (filters and table.filter_names):
        return att, np.asarray(table.offsets(e, r, 0.0, t))
    names = [None, *table.filter_names]
    att = {k: np.tile(v, len(names)) for k, v in att.items()} | {"filter": [n for n in names for _ in e]}
    return att, np.asarray(table.offsets(att["elevation_deg"], att["rotation_deg"], 0.0, att["temperature_degC"],
                                         att["filter"]))


class TableCheck(NamedTuple):
    """:func:`check_table`'s verdict. ``offsets``: per axis the largest |offset|, the travel,
    their ratio and the attitude; ``struts``: the largest |length change| (µm), the smallest
    margin (mm, negative beyond a limit) and their attitudes, ``None`` without a geometry;
    ``campaign``: per axis the RMS of the measured offsets and of measured − table, and whether
    the table makes the axis worse; ``problems``: sentences, empty when the table passes."""

    offsets: dict
    struts: dict | None
    campaign: dict | None
    problems: tuple[str, ...]

    @property
    def passed(self) -> bool:
        return not self.problems


def check_table(table: CompensationTable, mechanism: AbstractMechanism | None = None, *,
                campaign: Campaign | None = None, domain: Domain | None = None,
                strut_limit_um: float | None = None) -> TableCheck:
    """Scan ``domain`` (with every filter of the table, and none) for the worst offset against
    the mechanism's travel and the worst strut length change against its reading limits (or
    ``strut_limit_um``, µm, where given); compare
    with ``campaign`` per axis. Every exceeded limit and every axis made worse is a problem.
    ``domain`` defaults to ``Domain()``: elevation [0, 90], rotation [−90, 90], the table's
    temperature range."""
    att, off = _scan(table, domain, filters=True)
    problems: list[str] = []
    travel = None if mechanism is None else travel_limits(mechanism)
    offsets = {}
    for i, (axis, unit) in enumerate(zip(AXES, AXIS_UNITS, strict=True)):
        k = int(np.argmax(np.abs(off[:, i])))
        entry = {f"max_abs_{unit}": float(abs(off[k, i])), "at": _at(att, k)}
        if travel is not None:
            entry[f"travel_{unit}"] = float(travel[i])
            entry["ratio"] = float(abs(off[k, i]) / travel[i]) if travel[i] > 0 else float("inf")
            if entry["ratio"] > 1.0:
                problems.append(f"{axis} offset {off[k, i]:.6g} {unit} beyond the travel ±{travel[i]:.6g} {unit} at "
                                f"{_where(att, k)}")
        offsets[axis] = entry
    struts = None
    if mechanism is not None:
        struts, strut_problems = _strut_check(mechanism, off, att, strut_limit_um)
        problems += strut_problems
    result = None
    if campaign is not None:
        result, campaign_problems = _campaign_check(table, campaign)
        problems += campaign_problems
    return TableCheck(offsets, struts, result, tuple(problems))


def _strut_check(mechanism, off, att, strut_limit_um):
    dq, margin, ok = strut_changes(mechanism, off)
    k = np.unravel_index(int(np.argmax(np.abs(dq))), dq.shape)
    m = np.unravel_index(int(np.argmin(margin)), margin.shape)
    struts = {"max_abs_change_um": float(abs(dq[k])), "strut": int(k[1]) + 1, "at": _at(att, k[0]),
              "min_margin_mm": float(margin[m]), "min_margin_strut": int(m[1]) + 1, "min_margin_at": _at(att, m[0]),
              "limit_um": strut_limit_um}
    problems = []
    if not ok.all() or margin[m] < 0:
        problems.append(f"strut {m[1] + 1} beyond its limit (margin {margin[m]:.4g} mm) at {_where(att, m[0])}")
    if strut_limit_um is not None and abs(dq[k]) > strut_limit_um:
        problems.append(f"strut {k[1] + 1} changes by {dq[k]:.6g} µm, beyond ±{strut_limit_um:g} µm, at "
                        f"{_where(att, k[0])}")
    return struts, problems


def _campaign_check(table: CompensationTable, campaign: Campaign):
    pred = np.asarray(table.offsets(campaign.elevation_deg, campaign.rotation_deg, campaign.azimuth_deg,
                                    campaign.temperature_degC))
    meas = campaign.offsets
    out, problems = {}, []
    for i, (axis, unit) in enumerate(zip(AXES, AXIS_UNITS, strict=True)):
        before = float(np.sqrt(np.mean(meas[:, i] ** 2)))
        after = float(np.sqrt(np.mean((meas[:, i] - pred[:, i]) ** 2)))
        p = pred[:, i]
        # the factor k minimising |meas − k·table|: −1 is a sign flip, 1e±3 a unit slip
        factor = float(p @ meas[:, i] / (p @ p)) if p @ p > 0 else float("nan")
        worse = after > WORSE_RATIO * before
        out[axis] = {f"rms_measured_{unit}": before, f"rms_after_table_{unit}": after, "worse": bool(worse),
                     "best_factor": factor}
        if worse:
            problems.append(f"{axis}: the table makes it worse (RMS {before:.4g} → {after:.4g} {unit}); the campaign "
                            f"matches {factor:.3g} × the table: a likely {_cause(factor)}")
    return out, problems


def _cause(factor: float) -> str:
    if np.isfinite(factor) and factor < 0:
        return "sign error (the table's sign is opposite to the campaign's)"
    if np.isfinite(factor) and factor != 0 and min(abs(np.log10(abs(factor)) - d) for d in (-6, -3, 3, 6)) < 0.3:
        return "unit error (a factor of a thousand: µm against mm or m)"
    return "sign or unit error"


class TableDiff(NamedTuple):
    """:func:`diff_tables`' result: per axis the largest |A − B| and its attitude; per strut
    the same in µm of length change (``None`` without a geometry)."""

    offsets: dict
    struts: dict | None


def diff_tables(a: CompensationTable, b: CompensationTable, mechanism: AbstractMechanism | None = None, *,
                domain: Domain | None = None) -> TableDiff:
    """The largest difference of two tables over ``domain`` (default ``Domain()``), per axis
    and per strut."""
    domain = domain or Domain()
    e, r, t = domain.grid(a)
    e2, r2, t2 = domain.grid(b)
    if t2.size > t.size:
        e, r, t = e2, r2, t2
    att = {"elevation_deg": e, "rotation_deg": r, "temperature_degC": t}
    oa, ob = np.asarray(a.offsets(e, r, 0.0, t)), np.asarray(b.offsets(e, r, 0.0, t))
    d = oa - ob
    offsets = {}
    for i, (axis, unit) in enumerate(zip(AXES, AXIS_UNITS, strict=True)):
        k = int(np.argmax(np.abs(d[:, i])))
        offsets[axis] = {f"max_abs_diff_{unit}": float(abs(d[k, i])), f"a_{unit}": float(oa[k, i]),
                         f"b_{unit}": float(ob[k, i]), "at": _at(att, k)}
    struts = None
    if mechanism is not None:
        dd = strut_changes(mechanism, oa)[0] - strut_changes(mechanism, ob)[0]
        struts = {}
        for j in range(6):
            k = int(np.argmax(np.abs(dd[:, j])))
            struts[f"strut{j + 1}"] = {"max_abs_diff_um": float(abs(dd[k, j])), "at": _at(att, k)}
    return TableDiff(offsets, struts)
