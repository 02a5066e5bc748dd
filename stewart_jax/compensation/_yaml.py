"""Reading and writing compensation tables in the controller's own YAML format.

Rubin Observatory, *MTHexapod CSC* configuration (``lsst-ts/ts_config_mttcs``, ``MTHexapod/v3``
… ``v7``): a file ``_init.yaml`` holds both hexapods' tables (``camera_config``, ``m2_config``);
override files (a newer table, new filter offsets) are merged over it recursively, in order,
the later file winning key by key, a list replaced whole. Schema v7 has
``elevation_rotation_coeffs`` (per axis a 2-D list: rows are powers of elevation, columns powers
of the rotator angle); schemas v3–v6 have ``elevation_coeffs`` and ``rotation_coeffs`` power
series. Both have ``azimuth_coeffs``, ``temperature_coeffs``, ``min_temperature``,
``max_temperature`` and optionally ``enable_lut_temperature`` and ``filter_offsets``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from typing import Any

import jax.numpy as jnp
import numpy as np

from ._table import AXES, HEXAPODS, CompensationTable

_V7 = ("elevation_rotation_coeffs",)
_V3 = ("elevation_coeffs", "rotation_coeffs")


def merge_configs(base: Mapping[str, Any], override: Mapping[str, Any]) -> dict[str, Any]:
    """``override`` merged over ``base``: mappings merge key by key, recursively; any other
    value (a list, a number) replaces the old one whole."""
    out = dict(base)
    for key, value in override.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = merge_configs(out[key], value)
        else:
            out[key] = value
    return out


def read_config(paths: str | os.PathLike[str] | Sequence[str | os.PathLike[str]]) -> dict[str, Any]:
    """The YAML files merged in order (later wins). Each must hold a mapping."""
    import yaml

    paths = [paths] if isinstance(paths, str | os.PathLike) else list(paths)
    if not paths:
        raise ValueError("no table file given")
    merged: dict[str, Any] = {}
    for path in paths:
        with open(path, encoding="utf-8") as f:
            try:
                doc = yaml.safe_load(f)
            except yaml.YAMLError as e:
                raise ValueError(f"{path}: not valid YAML: {e}") from None
        if doc is None:
            continue
        if not isinstance(doc, Mapping):
            raise ValueError(f"{path}: a compensation table file holds a mapping (camera_config, m2_config, …), "
                             f"got {type(doc).__name__}")
        merged = merge_configs(merged, doc)
    return merged


def load_table(paths: str | os.PathLike[str] | Sequence[str | os.PathLike[str]],
               hexapod: str = "camera") -> CompensationTable:
    """The ``hexapod``'s table (``"camera"`` or ``"m2"``) of the YAML files merged in order.

    Refused with a ``ValueError`` naming the key: a table without six axes, a non-numeric or
    non-finite coefficient (a YAML ``1e-5`` without a decimal point is a string), a 2-D row list
    of unequal rows, mixed schemas, a filter without a numeric ``z_offset``, and
    ``min_temperature`` not below ``max_temperature``."""
    return table_from_config(read_config(paths), hexapod, source=", ".join(map(str, _as_list(paths))))


def _as_list(paths) -> list:
    return [paths] if isinstance(paths, str | os.PathLike) else list(paths)


def table_from_config(config: Mapping[str, Any], hexapod: str = "camera", source: str = "table") -> CompensationTable:
    """The ``hexapod``'s :class:`CompensationTable` of a merged configuration mapping."""
    if hexapod not in HEXAPODS:
        raise ValueError(f"hexapod must be one of {', '.join(HEXAPODS)}, got {hexapod!r}")
    key = HEXAPODS[hexapod]
    sub = config.get(key)
    if not isinstance(sub, Mapping):
        raise ValueError(f"{source}: no {key!r} mapping (the {hexapod} hexapod's table); keys: {sorted(config)}")
    where = f"{source}: {key}"
    has7, has3 = any(k in sub for k in _V7), any(k in sub for k in _V3)
    if has7 and has3:
        raise ValueError(f"{where} mixes the v7 schema (elevation_rotation_coeffs) and the v3–v6 schema "
                         f"(elevation_coeffs, rotation_coeffs): the controller reads one; remove the other")
    if has7:
        er = [_grid(c, f"{where}.elevation_rotation_coeffs[{AXES[i]}]")
              for i, c in enumerate(_six(sub, "elevation_rotation_coeffs", where))]
    elif has3:
        el, ro = ([_series(c, f"{where}.{name}[{AXES[i]}]") for i, c in enumerate(_six(sub, name, where))]
                  for name in _V3)
        er = []
        for e, r in zip(el, ro, strict=True):
            g = np.zeros((len(e), len(r)))
            g[:, 0] = e
            g[0, :] += r
            er.append(g)
    else:
        raise ValueError(f"{where} has neither elevation_rotation_coeffs (schema v7) nor elevation_coeffs and "
                         f"rotation_coeffs (schema v3–v6)")
    az = [_series(c, f"{where}.azimuth_coeffs[{AXES[i]}]") for i, c in enumerate(_six(sub, "azimuth_coeffs", where))]
    te = [_series(c, f"{where}.temperature_coeffs[{AXES[i]}]")
          for i, c in enumerate(_six(sub, "temperature_coeffs", where))]
    tmin = _number(sub.get("min_temperature"), f"{where}.min_temperature")
    tmax = _number(sub.get("max_temperature"), f"{where}.max_temperature")
    if not tmin < tmax:
        raise ValueError(f"{where}: min_temperature {tmin} must be below max_temperature {tmax} (°C)")
    enable = sub.get("enable_lut_temperature", False)
    if not isinstance(enable, bool):
        raise ValueError(f"{where}.enable_lut_temperature must be true or false, got {enable!r}")
    names, zs = _filters(sub.get("filter_offsets") or {}, f"{where}.filter_offsets")
    return CompensationTable(
        elevation_rotation=jnp.asarray(_pad(er)), azimuth=jnp.asarray(_pad(az)), temperature=jnp.asarray(_pad(te)),
        min_temperature_degC=jnp.asarray(tmin), max_temperature_degC=jnp.asarray(tmax),
        filter_z_um=jnp.asarray(np.asarray(zs, dtype=np.float64)), filter_names=tuple(names),
        enable_temperature=enable, hexapod=hexapod)


def _six(sub: Mapping[str, Any], name: str, where: str) -> list:
    value = sub.get(name)
    if not isinstance(value, list) or len(value) != 6:
        got = "missing" if value is None else (f"{len(value)} items" if isinstance(value, list) else repr(value))
        raise ValueError(f"{where}.{name} must list 6 axes (x, y, z in µm; u, v, w in deg), got {got}")
    return value


def _number(x: Any, where: str) -> float:
    if isinstance(x, bool) or not isinstance(x, int | float):
        hint = (" (YAML reads a number without a decimal point before its exponent, such as 1e-5, as text: "
                "write 1.0e-5)") if isinstance(x, str) else ""
        raise ValueError(f"{where} must be a number, got {x!r}{hint}")
    if not math.isfinite(x):
        raise ValueError(f"{where} must be finite, got {x!r}")
    return float(x)


def _series(c: Any, where: str) -> np.ndarray:
    if not isinstance(c, list) or not c:
        raise ValueError(f"{where} must be a non-empty list of coefficients, got {c!r}")
    return np.array([_number(x, f"{where}[{j}]") for j, x in enumerate(c)])


def _grid(c: Any, where: str) -> np.ndarray:
    if not isinstance(c, list) or not c or not all(isinstance(row, list) for row in c):
        raise ValueError(f"{where} must be a 2-D list (rows: powers of elevation; columns: powers of the rotator "
                         f"angle), got {c!r}")
    rows = [_series(row, f"{where}[{j}]") for j, row in enumerate(c)]
    if len({len(r) for r in rows}) != 1:
        raise ValueError(f"{where} has rows of {[len(r) for r in rows]} coefficients: the controller evaluates "
                         f"a rectangular array; pad the short rows with zeros")
    return np.stack(rows)


def _pad(arrays: list[np.ndarray]) -> np.ndarray:
    shape = tuple(max(a.shape[k] for a in arrays) for k in range(arrays[0].ndim))
    out = np.zeros((len(arrays), *shape))
    for i, a in enumerate(arrays):
        out[(i, *(slice(0, n) for n in a.shape))] = a
    return out


def _filters(f: Any, where: str) -> tuple[list[str], list[float]]:
    if not isinstance(f, Mapping):
        raise ValueError(f"{where} must map filter names to {{z_offset: µm}}, got {f!r}")
    names, zs = [], []
    for name, entry in f.items():
        if not isinstance(entry, Mapping) or "z_offset" not in entry:
            raise ValueError(f"{where}.{name} must be {{z_offset: µm}}, got {entry!r}")
        names.append(str(name))
        zs.append(_number(entry["z_offset"], f"{where}.{name}.z_offset"))
    return names, zs


# ---- writing -----------------------------------------------------------------------------------


def _yaml_float(x: float) -> str:
    """A float that YAML 1.1 readers (PyYAML, the controller's) read back bit for bit: ``repr``
    with a decimal point in the mantissa (``1e-05`` alone would be read as text)."""
    s = repr(float(x))
    if "e" in s and "." not in s.split("e")[0]:
        m, e = s.split("e")
        s = f"{m}.0e{e}"
    return s


def _row(values: np.ndarray) -> str:
    return "[" + ", ".join(_yaml_float(v) for v in values) + "]"


def table_yaml(table: CompensationTable, comments: Sequence[str] = ()) -> str:
    """The table as a schema-v7 override file: the ``camera_config`` or ``m2_config`` keys of
    the compensation only (merge it over the controller's ``_init.yaml``). Every coefficient is
    written so that it reads back bit for bit."""
    key = HEXAPODS[table.hexapod]
    lines = [f"# {c}" for c in comments] + [f"{key}:", "  elevation_rotation_coeffs:"]
    lines.append("    # per axis x, y, z (µm), u, v, w (deg): rows are powers of elevation (deg), columns powers of "
                 "the rotator angle (deg)")
    for i, grid in enumerate(np.asarray(table.elevation_rotation)):
        grid = _trim(grid)
        lines.append(f"    - # {AXES[i]}")
        lines += [f"      - {_row(row)}" for row in grid]
    for name, arr in (("azimuth_coeffs", table.azimuth), ("temperature_coeffs", table.temperature)):
        lines.append(f"  {name}:")
        lines += [f"    - {_row(_trim(np.asarray(c)[None])[0])}  # {AXES[i]}" for i, c in enumerate(np.asarray(arr))]
    lines.append(f"  min_temperature: {_yaml_float(float(table.min_temperature_degC))}")
    lines.append(f"  max_temperature: {_yaml_float(float(table.max_temperature_degC))}")
    lines.append(f"  enable_lut_temperature: {'true' if table.enable_temperature else 'false'}")
    if table.filter_names:
        lines.append("  filter_offsets:")
        for name, z in zip(table.filter_names, np.asarray(table.filter_z_um), strict=True):
            lines += [f"    {name}:", f"      z_offset: {_yaml_float(z)}"]
    return "\n".join(lines) + "\n"


def _trim(grid: np.ndarray) -> np.ndarray:
    """Trailing all-zero rows and columns removed (at least one coefficient kept)."""
    grid = np.atleast_2d(grid)
    rows = np.flatnonzero(np.any(grid != 0.0, axis=1))
    cols = np.flatnonzero(np.any(grid != 0.0, axis=0))
    return grid[: (rows.max() + 1 if rows.size else 1), : (cols.max() + 1 if cols.size else 1)]


def save_table(table: CompensationTable, path: str | os.PathLike[str], comments: Sequence[str] = ()) -> None:
    """Write :func:`table_yaml` atomically."""
    from .._files import write_text_atomic

    write_text_atomic(path, table_yaml(table, comments))
