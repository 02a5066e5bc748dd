"""The laser tracker's files: the targets file (JSON: where the targets sit on the platform and
the base) and the points CSV (one row per target seen at a pose, with the pose's readings), read
with a clear error naming the file, line and column, and written atomically. The model and its
units are those of :mod:`._points`."""

from __future__ import annotations

import json
import os
from typing import NamedTuple

import numpy as np

from .._units import READING_UNITS, check_unit
from ._csv import DIRECTION_COLUMNS, STROKE_COLUMNS, csv_rows, format_degrees, parse_degrees
from ._points import _READING_ATOL, POINT_COLUMNS, REFERENCE_POSE, PointData, TrackerTargets


def read_targets(path: str | os.PathLike[str]) -> TrackerTargets:
    """Read a targets file ``{"platform_targets": {NAME: [x, y, z]}, "base_references": {NAME: [x, y, z]}}``
    (mm), refusing a missing key, a non-finite or non-3-vector coordinate, and fewer than three
    base references (each error names the entry)."""
    try:
        with open(path, encoding="utf-8") as f:
            d = json.load(f)
    except json.JSONDecodeError as e:
        raise ValueError(f"{path}: not valid JSON ({e.msg} at line {e.lineno})") from None
    if not isinstance(d, dict):
        raise ValueError(f"{path}: expected an object with 'platform_targets' and 'base_references'")
    out = []
    for key in ("platform_targets", "base_references"):
        entries = d.get(key)
        if not isinstance(entries, dict) or not entries:
            raise ValueError(f"{path}: {key!r} must be a non-empty object NAME -> [x, y, z] (mm)")
        names, xyz = [], []
        for name, v in entries.items():
            a = np.asarray(v, dtype=np.float64) if isinstance(v, list) else np.full(1, np.nan)
            if a.shape != (3,) or not np.all(np.isfinite(a)):
                raise ValueError(f"{path}: {key}[{name!r}] must be three finite numbers [x, y, z] (mm), got {v!r}")
            names.append(str(name))
            xyz.append(a)
        out += [tuple(names), np.stack(xyz)]
    if len(out[2]) < 3:
        raise ValueError(f"{path}: {len(out[2])} base reference(s); at least three define the base frame "
                         "in the tracker's frame")
    if np.linalg.matrix_rank(out[3] - out[3].mean(0), tol=1e-6) < 2:
        raise ValueError(f"{path}: the base references are collinear; they cannot define the base frame")
    return TrackerTargets(*out)


def write_targets(path: str | os.PathLike[str], targets: TrackerTargets) -> None:
    """Write ``targets`` as a targets file (atomic; full float64 precision)."""
    from .._files import json_text, write_text_atomic

    d = {"platform_targets": {n: [float(x) for x in p] for n, p in zip(targets.platform_names, targets.platform,
                                                                        strict=True)},
         "base_references": {n: [float(x) for x in p] for n, p in zip(targets.base_names, targets.base, strict=True)}}
    write_text_atomic(path, json_text(d))


def read_points_csv(path: str | os.PathLike[str], targets: TrackerTargets, *, reading_unit: str = "mm") -> PointData:
    """Read a points file (columns ``pose,target,q1..q6,x,y,z``; others ignored) against ``targets``.
    ``reading_unit``: the mechanism's (``"rad"``: ``q1``…``q6`` are crank angles in degrees, as in
    the pose CSV, returned in rad).

    Everything is checked before any work, each error on one line naming the file's line: a
    missing column, a non-numeric cell, a target name missing from the targets file, a repeated
    (pose, target) row, a pose whose readings disagree between its rows, fewer than three base
    references, and coordinates in metres (distances between targets 1000× shorter than their
    nominal ones).

    The pose CSV's optional per-pose columns ``dir1..dir6`` (±1, all six), ``temperature`` (°C) and
    ``time`` (s) are read when present; rows of one pose repeat them, as they repeat the readings.
    """
    angular = check_unit(reading_unit, "reading_unit", READING_UNITS) == "rad"
    rows, header = csv_rows(path)
    col, dirs, conditions = _point_columns(path, header)
    parsed = _point_rows(path, rows, header, col, dirs, conditions, targets, angular)
    if len(set(parsed.reference_index)) < 3:
        raise ValueError(f"{path}: {len(set(parsed.reference_index))} base reference(s) measured (rows with pose "
                         f"'{REFERENCE_POSE}'); at least three define the base frame in the tracker's frame")
    if not parsed.pose_names:
        raise ValueError(f"{path}: no platform target rows")
    refs_a, ridx_a = np.stack(parsed.references), np.asarray(parsed.reference_index)
    _check_millimetres(path, refs_a, targets.base[ridx_a], parsed.reference_lines)
    pts_a, pidx_a, tidx_a = np.stack(parsed.points), np.asarray(parsed.pose_index), np.asarray(parsed.target_index)
    for j in range(len(parsed.pose_names)):
        rows_j = np.flatnonzero(pidx_a == j)
        if len(rows_j) >= 2:
            _check_millimetres(path, pts_a[rows_j], targets.platform[tidx_a[rows_j]],
                               [parsed.point_lines[i] for i in rows_j])
    readings = np.stack(parsed.readings)
    cond = np.stack(parsed.conditions)
    k = len(dirs)
    return PointData(tuple(parsed.pose_names), readings, pidx_a, tidx_a, pts_a, ridx_a, refs_a,
                     directions=cond[:, :6] if dirs else None,
                     temperature=cond[:, k] if "temperature" in conditions else None,
                     time=cond[:, conditions.index("time")] if "time" in conditions else None)


def _point_columns(path, header: list[str]) -> tuple[dict[str, int], list[str], tuple[str, ...]]:
    """The points file's column indices (``{name: index}``, the required columns and the per-pose
    ones), its direction columns (``[]`` or all of ``dir1..dir6``) and its per-pose condition
    columns (the directions, then ``temperature`` and ``time`` where present), refusing a missing
    required column and an incomplete set of direction columns."""
    missing = [c for c in POINT_COLUMNS if c not in header]
    if missing:
        raise ValueError(f"{path}: missing column(s) {missing}; a points file has {list(POINT_COLUMNS)}")
    col = {c: header.index(c) for c in POINT_COLUMNS}
    dirs = [c for c in DIRECTION_COLUMNS if c in header]
    if dirs and len(dirs) != 6:
        raise ValueError(f"{path}: direction columns must be all of dir1..dir6, found {dirs}")
    conditions = tuple(dirs) + tuple(c for c in ("temperature", "time") if c in header)
    col.update({c: header.index(c) for c in conditions})
    return col, dirs, conditions


class _PointRows(NamedTuple):
    """A points file's rows, checked one by one, in file order.

    - ``pose_names``: the ``m`` platform poses in order of first appearance; ``readings``: per pose
      its ``(6,)`` readings (mm, or rad for an angular mechanism); ``conditions``: per pose its
      ``(c,)`` condition cells (the order of :func:`_point_columns`' conditions).
    - ``pose_index``, ``target_index``, ``points``, ``point_lines``: per platform row its pose (into
      ``pose_names``), its target (into the targets file's platform targets), its ``(3,)`` point
      (mm) and its line in the file.
    - ``reference_index``, ``references``, ``reference_lines``: per base reference row its target
      (into the targets file's base references), its ``(3,)`` point (mm) and its line.
    """

    pose_names: list[str]
    readings: list[np.ndarray]
    conditions: list[np.ndarray]
    pose_index: list[int]
    target_index: list[int]
    points: list[np.ndarray]
    point_lines: list[int]
    reference_index: list[int]
    references: list[np.ndarray]
    reference_lines: list[int]


def _point_rows(path, rows, header, col, dirs, conditions, targets: TrackerTargets, angular: bool) -> _PointRows:
    """The rows of a points file (:class:`_PointRows`), each checked where it first allows it so
    that every error names its line: the cell count, the pose and target cells, the numbers, a
    repeated (pose, target), the target's name, a base reference with readings, the directions'
    signs and a pose whose rows disagree."""
    platform = {n: i for i, n in enumerate(targets.platform_names)}
    base = {n: i for i, n in enumerate(targets.base_names)}
    seen: dict[tuple[str, str], int] = {}
    pose_rows: dict[str, tuple[int, np.ndarray, np.ndarray]] = {}
    pose_id: dict[str, int] = {}
    out = _PointRows([], [], [], [], [], [], [], [], [], [])
    for line, r in enumerate(rows[1:], start=2):
        if not any(c.strip() for c in r):
            continue
        if len(r) != len(header):
            raise ValueError(f"{path}, line {line}: {len(r)} cells for {len(header)} columns")
        pose, target = r[col["pose"]].strip(), r[col["target"]].strip()
        if not pose or not target:
            raise ValueError(f"{path}, line {line}: empty 'pose' or 'target' cell")
        xyz = np.array([_number(path, line, c, r[col[c]]) for c in ("x", "y", "z")])
        if (pose, target) in seen:
            raise ValueError(f"{path}, line {line}: duplicate row: pose {pose!r}, target {target!r} was already "
                             f"measured on line {seen[(pose, target)]}")
        seen[(pose, target)] = line
        if pose == REFERENCE_POSE:
            if target not in base:
                raise ValueError(f"{path}, line {line}: base reference {target!r} is not in the targets file's "
                                 f"base_references {list(targets.base_names)}")
            if any(r[col[c]].strip() for c in STROKE_COLUMNS):
                raise ValueError(f"{path}, line {line}: a base reference row ('{REFERENCE_POSE}') has readings; "
                                 "leave q1..q6 empty (is the pose label wrong?)")
            out.reference_index.append(base[target])
            out.references.append(xyz)
            out.reference_lines.append(line)
            continue
        if target not in platform:
            raise ValueError(f"{path}, line {line}: platform target {target!r} is not in the targets file's "
                             f"platform_targets {list(targets.platform_names)}")
        q = np.array([_number(path, line, c, r[col[c]], degrees=angular) for c in STROKE_COLUMNS])
        cond = np.array([_number(path, line, c, r[col[c]]) for c in conditions])
        if dirs and not np.all(np.isin(cond[:6], (-1.0, 1.0))):
            raise ValueError(f"{path}, line {line}: dir1..dir6 must hold +1 or -1")
        if pose in pose_rows:
            _check_pose_repeat(path, line, pose, pose_rows[pose], q, cond, conditions, angular)
        else:
            pose_rows[pose] = (line, q, cond)
            pose_id[pose] = len(out.pose_names)
            out.pose_names.append(pose)
            out.readings.append(q)
            out.conditions.append(cond)
        out.pose_index.append(pose_id[pose])
        out.target_index.append(platform[target])
        out.points.append(xyz)
        out.point_lines.append(line)
    return out


def _check_pose_repeat(path, line, pose, first_row, q, cond, conditions, angular: bool) -> None:
    """Refuse a later row of ``pose`` whose readings ``q`` ``(6,)`` or conditions ``cond`` ``(c,)``
    differ from those of its first row ``first_row`` (its line, readings and conditions)."""
    first, q0, cond0 = first_row
    if np.max(np.abs(q - q0)) > _READING_ATOL:
        j = int(np.argmax(np.abs(q - q0)))
        unit = "°" if angular else " mm"
        a, b = (np.degrees([q[j], q0[j]]) if angular else (q[j], q0[j]))
        raise ValueError(f"{path}, line {line}: pose {pose!r} has readings that disagree with its row on "
                         f"line {first} ({STROKE_COLUMNS[j]}: {float(a)!r}{unit} vs {float(b)!r}{unit}); rows "
                         "of one pose repeat its readings")
    if np.any(cond != cond0):
        worst = conditions[int(np.argmax(cond != cond0))]
        raise ValueError(f"{path}, line {line}: pose {pose!r} has a {worst!r} that disagrees with its row on "
                         f"line {first}; rows of one pose repeat it")


def write_points_csv(
    path: str | os.PathLike[str], data: PointData, targets: TrackerTargets, *, reading_unit: str = "mm"
) -> None:
    """Write ``data`` as a points file (base references first; atomic; full precision).
    ``reading_unit``: the mechanism's (``"rad"``: the readings are crank angles, written in degrees
    that :func:`read_points_csv` turns back into exactly the same radians)."""
    from .._files import write_text_atomic

    angular = check_unit(reading_unit, "reading_unit", READING_UNITS) == "rad"
    reading = format_degrees if angular else (lambda x: repr(float(x)))

    extra_names, extra = [], []
    if data.directions is not None:
        extra_names += list(DIRECTION_COLUMNS)
        extra.append(np.asarray(data.directions, dtype=np.float64))
    for name, column in (("temperature", data.temperature), ("time", data.time)):
        if column is not None:
            extra_names.append(name)
            extra.append(np.asarray(column, dtype=np.float64)[:, None])
    per_pose = np.concatenate(extra, axis=1) if extra else np.zeros((data.n_poses, 0))
    lines = [",".join(POINT_COLUMNS + tuple(extra_names))]
    for i, p in zip(data.reference_index, data.references, strict=True):
        lines.append(",".join([REFERENCE_POSE, targets.base_names[i]] + [""] * 6 + [repr(float(x)) for x in p]
                              + [""] * len(extra_names)))
    for j, k, p in zip(data.pose_index, data.target_index, data.points, strict=True):
        lines.append(",".join([data.pose_names[j], targets.platform_names[k]]
                              + [reading(x) for x in data.readings[j]] + [repr(float(x)) for x in p]
                              + [repr(float(x)) for x in per_pose[j]]))
    write_text_atomic(path, "\n".join(lines) + "\n")


def _number(path, line, column, cell, degrees: bool = False) -> float:
    """A cell's number (``degrees``: a degree cell, returned in rad by :func:`parse_degrees`)."""
    try:
        x = parse_degrees(cell) if degrees else float(cell)
    except (ValueError, ArithmeticError):
        raise ValueError(f"{path}, line {line}, column {column!r}: {cell!r} is not a number") from None
    if not np.isfinite(x):
        raise ValueError(f"{path}, line {line}, column {column!r}: {cell!r} is not finite")
    return x


def _check_millimetres(path, measured, nominal, lines) -> None:
    """Distances between measured points against their nominal ones: 1000× shorter is a tracker
    file in metres; 1000× longer, a targets file in metres (or a tracker file in µm)."""
    i, j = np.triu_indices(len(measured), 1)
    dn = np.linalg.norm(nominal[i] - nominal[j], axis=1)
    dm = np.linalg.norm(measured[i] - measured[j], axis=1)
    ok = dn > 1e-3 * np.max(dn, initial=0.0)
    if not np.any(ok) or np.max(dn) == 0.0:
        return
    ratio = float(np.median(dm[ok] / dn[ok]))
    if ratio < 0.01:
        raise ValueError(f"{path}, lines {lines[0]}–{lines[-1]}: the measured distances between these targets are "
                         f"{ratio:.3g}× their nominal ones — the tracker file is in metres; the points file is "
                         "in mm")
    if ratio > 100.0:
        raise ValueError(f"{path}, lines {lines[0]}–{lines[-1]}: the measured distances between these targets are "
                         f"{ratio:.3g}× their nominal ones — the targets file's coordinates are in metres (or the "
                         "tracker's in µm); both files are in mm")
