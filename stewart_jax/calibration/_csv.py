"""Measured calibration data as CSV (the columns of ``docs/conventions.md``).

One row per pose; header row; readings ``q1``…``q6`` (mm for a stroke; degrees for a rotary
family's crank angles, ``reading_unit="rad"``), pose ``x, y, z`` (mm) and ``rx, ry, rz``
(degrees); optional ``dir1``…``dir6`` (±1), ``temperature`` (°C), ``time`` (s); other columns
ignored. Numbers are written with ``repr`` (lossless float64), degrees exactly as
:func:`format_degrees` writes them.
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Mapping
from decimal import Context, Decimal, InvalidOperation

import numpy as np

from .._files import write_text_atomic
from .._units import READING_UNITS, check_unit
from ._problem import CalibrationData, make_calibration_data

STROKE_COLUMNS = tuple(f"q{i}" for i in range(1, 7))
POSE_COLUMNS = ("x", "y", "z", "rx", "ry", "rz")
DIRECTION_COLUMNS = tuple(f"dir{i}" for i in range(1, 7))
REQUIRED_COLUMNS = STROKE_COLUMNS + POSE_COLUMNS

MAX_ANGLE_DEG = 10.0
"""A degree column with |angle| beyond this is taken as a unit mistake (the mechanisms this
format serves have a travel of a few degrees at most)."""


def write_csv(
    path: str | os.PathLike[str],
    data: CalibrationData,
    extra: Mapping[str, np.ndarray] | None = None,
    *,
    reading_unit: str = "mm",
) -> None:
    """Write ``data`` (mm, rad inside) as measurement CSV (mm, degrees; ``docs/conventions.md``);
    ``reading_unit``: the mechanism's (``"rad"``: the readings are crank angles, written in degrees).
    ``extra`` adds columns
    (e.g. the true poses of a simulation), each an array of length m or shape (m, k) with
    names given as ``name`` or a tuple of k names via a mapping key ``"a,b,c"``."""
    q = np.asarray(data.readings, dtype=np.float64)
    p = np.asarray(data.poses, dtype=np.float64)
    cols: dict[str, np.ndarray | list[str]] = {}
    angular = check_unit(reading_unit, "reading_unit", READING_UNITS) == "rad"
    for i, c in enumerate(STROKE_COLUMNS):
        cols[c] = [format_degrees(r) for r in q[:, i]] if angular else q[:, i]
    for i, c in enumerate(POSE_COLUMNS):
        cols[c] = p[:, i] if i < 3 else [format_degrees(r) for r in p[:, i]]
    if data.directions is not None:
        d = np.asarray(data.directions)
        for i, c in enumerate(DIRECTION_COLUMNS):
            cols[c] = d[:, i]
    if data.temperature is not None:
        cols["temperature"] = np.asarray(data.temperature)
    if data.time is not None:
        cols["time"] = np.asarray(data.time)
    for key, value in (extra or {}).items():
        v = np.asarray(value, dtype=np.float64)
        names = key.split(",")
        v = v.reshape(len(v), -1)
        if v.shape[1] != len(names):
            raise ValueError(f"extra column {key!r}: {len(names)} names for {v.shape[1]} columns")
        for i, n in enumerate(names):
            cols[n] = v[:, i]
    buf = io.StringIO(newline="")
    w = csv.writer(buf)
    w.writerow(cols)
    for row in zip(*cols.values(), strict=True):
        w.writerow([x if isinstance(x, str) else repr(float(x)) for x in row])
    write_text_atomic(path, buf.getvalue())


_PI = Decimal("3.141592653589793238462643383279502884197169399375105820974944")
_DEC = Context(prec=50)


def format_degrees(radians: float) -> str:
    """Degrees as text that :func:`parse_degrees` turns back into exactly ``radians``.

    NOTE: no float64 degree value maps back to every float64 radian value (``180/π`` is not
    a power of two: about 1 in 10 radian values has no exact float64 preimage in degrees).
    The degrees are therefore written with 25 significant digits of the exact product
    ``r·180/π``, and read back in 50-digit decimal arithmetic with one final rounding. Any
    other reader parsing the column with ``float`` gets the nearest float64 in degrees.
    """
    deg = _DEC.divide(_DEC.multiply(Decimal(float(radians)), Decimal(180)), _PI)
    return format(deg, ".25g")


def parse_degrees(text: str) -> float:
    """Inverse of :func:`format_degrees`: degrees (text) to radians, rounded once."""
    return float(_DEC.divide(_DEC.multiply(Decimal(text.strip()), _PI), Decimal(180)))



def csv_rows(path) -> tuple[list[list[str]], list[str]]:
    """The rows of a CSV file and its stripped header, with a clear error for a folder, text that
    is not UTF-8 or an empty file."""
    if os.path.isdir(path):
        raise ValueError(f"{path} is a folder, not a CSV file")
    try:
        # utf-8-sig: a byte-order mark (Excel's "CSV UTF-8") is not part of the first column's name
        with open(path, newline="", encoding="utf-8-sig") as f:
            rows = list(csv.reader(f))
    except UnicodeDecodeError as e:
        raise ValueError(f"{path}: not UTF-8 text ({e.reason} at byte {e.start}); save the CSV as UTF-8") from None
    if not rows:
        raise ValueError(f"{path}: empty file (expected a header row)")
    return rows, [h.strip() for h in rows[0]]

def read_csv_columns(
    path: str | os.PathLike[str], degree_columns: tuple[str, ...] = ()
) -> dict[str, np.ndarray]:
    """Every column of a CSV file as float64 arrays, with a clear error for a ragged or
    non-numeric cell (naming row and column). ``degree_columns`` are returned in radians,
    converted by :func:`parse_degrees`."""
    rows, header = csv_rows(path)
    repeated = sorted({h for h in header if header.count(h) > 1})
    if repeated:
        raise ValueError(f"{path}: column(s) {repeated} appear more than once in the header")
    body = [r for r in rows[1:] if any(c.strip() for c in r)]
    if not body:
        raise ValueError(f"{path}: no data rows under the header")
    out = {h: np.empty(len(body)) for h in header}
    for i, r in enumerate(body, start=2):
        if len(r) != len(header):
            raise ValueError(f"{path}, line {i}: {len(r)} cells for {len(header)} columns")
        for h, cell in zip(header, r, strict=True):
            try:
                out[h][i - 2] = parse_degrees(cell) if h in degree_columns else float(cell)
            except (ValueError, InvalidOperation):
                if h in REQUIRED_COLUMNS:
                    raise ValueError(f"{path}, line {i}, column {h!r}: {cell!r} is not a number") from None
                out[h][i - 2] = np.nan  # an ignored or optional column; optional ones are checked later
    return out


def read_csv(path: str | os.PathLike[str], *, reading_unit: str = "mm") -> CalibrationData:
    """Read measurement CSV (``docs/conventions.md``) into :class:`CalibrationData` (mm, radians);
    ``reading_unit``: the mechanism's (``"rad"``: ``q1``…``q6`` are crank angles in degrees).

    Raises ``ValueError`` naming the problem: a missing column, a NaN, an angle beyond
    ±10° in a pose's degree column, a direction other than ±1.
    """
    angular = check_unit(reading_unit, "reading_unit", READING_UNITS) == "rad"
    cols = read_csv_columns(path, degree_columns=POSE_COLUMNS[3:] + (STROKE_COLUMNS if angular else ()))
    missing = [c for c in REQUIRED_COLUMNS if c not in cols]
    if missing:
        raise ValueError(f"{path}: missing column(s) {missing}; required: {list(REQUIRED_COLUMNS)}")
    for c in REQUIRED_COLUMNS:
        bad = np.flatnonzero(~np.isfinite(cols[c]))
        if bad.size:
            raise ValueError(f"{path}: column {c!r} has NaN/inf at data row(s) {(bad + 1).tolist()[:10]}")
    for c in POSE_COLUMNS[3:]:
        worst = float(np.degrees(np.max(np.abs(cols[c]))))
        if worst > MAX_ANGLE_DEG:
            raise ValueError(
                f"{path}: column {c!r} reaches {worst:.6g}, beyond ±{MAX_ANGLE_DEG}°; angle columns "
                "are in degrees and no pose of this mechanism is that far out: the column is "
                "almost certainly in another unit (radians converted twice, arc-seconds, mrad)"
            )
    q = np.stack([cols[c] for c in STROKE_COLUMNS], axis=-1)
    p = np.stack([cols[c] for c in POSE_COLUMNS], axis=-1)
    directions = temperature = time = None
    present_dirs = [c for c in DIRECTION_COLUMNS if c in cols]
    if present_dirs:
        if len(present_dirs) != 6:
            raise ValueError(f"{path}: direction columns must be all of dir1..dir6, found {present_dirs}")
        directions = np.stack([cols[c] for c in DIRECTION_COLUMNS], axis=-1)
        if not np.all(np.isin(directions, (-1.0, 1.0))):
            raise ValueError(f"{path}: dir1..dir6 must hold +1 or -1")
    if "temperature" in cols:
        temperature = _finite_optional(path, cols, "temperature")
    if "time" in cols:
        time = _finite_optional(path, cols, "time")
    return make_calibration_data(q, p, directions, temperature, time)


def _finite_optional(path, cols, name):
    v = cols[name]
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{path}: column {name!r} has NaN/inf or non-numeric cells")
    return v
