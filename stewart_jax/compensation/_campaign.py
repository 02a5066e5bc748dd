"""Compensation campaigns: the offsets a hexapod had to add to be aligned at each telescope
attitude (a laser-tracker survey), their CSV file, and simulated campaigns.

A campaign file states its sign convention in a header line, because the history of published
tables is one of sign flips:

- ``# sign: correction`` — each row is the offset the controller must *add* (compensated =
  uncompensated + offset), the table's own sign;
- ``# sign: error`` — each row is where the optic *was*, relative to aligned, with no
  compensation applied; the correction is its negative.

The simulated gravity and thermal flexure (:class:`FlexureModel`) treats the telescope's top end
as a linear elastic structure: deflections are linear in the gravity vector in the optic's
frame, ``(cos E·sin R, cos E·cos R, sin E)`` for elevation E and rotator angle R, and in the
temperature, measured from a reference attitude and temperature. Its shapes in E and R are not
polynomials, so that a fitted table is tested on a truth outside its own family.
"""

from __future__ import annotations

import csv
import io
import os
import re
from typing import NamedTuple

import equinox as eqx
import jax
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ._table import AIR_TEMPERATURE_SLIP, OFFSET_COLUMNS, CompensationTable, not_air_temperature

SIGNS = {
    "correction": "each row is the offset the controller adds: compensated = uncompensated + offset",
    "error": "each row is the optic's position relative to aligned with no compensation; the offset is its negative",
}
"""The sign conventions a campaign file may state, ``# sign: NAME``."""

ATTITUDE_COLUMNS = ("elevation_deg", "rotation_deg", "azimuth_deg", "temperature_degC")


class Campaign(NamedTuple):
    """A campaign of ``n`` attitudes, offsets in the table's sign (``correction``).

    - ``elevation_deg``, ``rotation_deg``, ``azimuth_deg``, ``temperature_degC``: ``Float[ndarray, " n"]``;
    - ``offsets``: ``Float[ndarray, "n 6"]``, ``x_um, y_um, z_um, u_deg, v_deg, w_deg``;
    - ``has_azimuth``, ``has_temperature``: whether the file gave those columns (else 0).
    """

    elevation_deg: np.ndarray
    rotation_deg: np.ndarray
    azimuth_deg: np.ndarray
    temperature_degC: np.ndarray
    offsets: np.ndarray
    has_azimuth: bool = False
    has_temperature: bool = False


_SIGN_LINE = re.compile(r"sign(?:[ _-]?convention)?\s*[:=]\s*([A-Za-z]*)", re.IGNORECASE)
"""``sign: NAME`` (also ``sign convention: NAME``, ``sign_convention = NAME``) in a comment line."""

_SLIPS = {"x": "x_um", "y": "y_um", "z": "z_um", "u": "u_deg", "v": "v_deg", "w": "w_deg"}


def read_campaign(path: str | os.PathLike[str]) -> Campaign:
    """A campaign CSV: ``# sign: correction|error`` in a header comment line (refused without
    it), then the columns ``elevation_deg, rotation_deg`` [``azimuth_deg, temperature_degC``]
    and ``x_um, y_um, z_um, u_deg, v_deg, w_deg``. Offsets in other units (``x_mm``, ``u_rad``,
    ``u_arcsec``, a bare ``x``) are refused naming the column; elevation outside [0, 90], a
    missing or non-numeric cell is refused naming its row."""
    with open(path, encoding="utf-8", newline="") as f:
        lines = f.read().splitlines()
    comments = [ln.lstrip().lstrip("#").strip() for ln in lines if ln.lstrip().startswith("#")]
    signs = [m.group(1).lower() for c in comments if (m := _SIGN_LINE.match(c))]
    if len(signs) != 1 or signs[0] not in SIGNS:
        got = f"got {signs!r}" if signs else "none stated"
        raise ValueError(f"{path}: a campaign states its sign convention in one header line, '# sign: correction' "
                         f"({SIGNS['correction']}) or '# sign: error' ({SIGNS['error']}); {got}")
    body = [ln for ln in lines if ln.strip() and not ln.lstrip().startswith("#")]
    if len(body) < 2:
        raise ValueError(f"{path}: no header row and data rows")
    rows = list(csv.reader(io.StringIO("\n".join(body))))
    header = [h.strip() for h in rows[0]]
    for h in header:
        base, _, unit = h.partition("_")
        if base in _SLIPS and h != _SLIPS[base]:
            raise ValueError(f"{path}: column {h!r}: a campaign's offsets are {', '.join(OFFSET_COLUMNS)} (µm and "
                             f"degrees); convert {base} to {_SLIPS[base]}")
    missing = [c for c in ("elevation_deg", "rotation_deg", *OFFSET_COLUMNS) if c not in header]
    if missing:
        raise ValueError(f"{path}: missing column(s) {missing}; the columns are elevation_deg, rotation_deg, "
                         f"[azimuth_deg, temperature_degC,] {', '.join(OFFSET_COLUMNS)}")
    wanted = [c for c in (*ATTITUDE_COLUMNS, *OFFSET_COLUMNS) if c in header]
    data = np.empty((len(rows) - 1, len(wanted)))
    for i, row in enumerate(rows[1:]):
        for j, c in enumerate(wanted):
            cell = row[header.index(c)].strip() if header.index(c) < len(row) else ""
            try:
                data[i, j] = float(cell)
            except ValueError:
                raise ValueError(f"{path}: row {i + 1}, column {c}: not a number ({cell!r})") from None
            if not np.isfinite(data[i, j]):
                raise ValueError(f"{path}: row {i + 1}, column {c}: not finite ({cell!r})")
    col = {c: data[:, j] for j, c in enumerate(wanted)}
    n = len(data)
    off = np.stack([col[c] for c in OFFSET_COLUMNS], axis=1)
    camp = Campaign(col["elevation_deg"], col["rotation_deg"], col.get("azimuth_deg", np.zeros(n)),
                    col.get("temperature_degC", np.zeros(n)), -off if signs[0] == "error" else off,
                    "azimuth_deg" in col, "temperature_degC" in col)
    check_campaign(camp, str(path))
    return camp


def check_campaign(c: Campaign, where: str = "campaign") -> None:
    """Refuse a campaign whose elevations leave [0, 90], whose temperatures are no air temperature
    in °C (:data:`~stewart_jax.compensation._table.AIR_TEMPERATURE_DEGC`) or whose arrays disagree
    in length."""

    n = len(c.elevation_deg)
    if c.offsets.shape != (n, 6) or any(len(a) != n for a in (c.rotation_deg, c.azimuth_deg, c.temperature_degC)):
        raise ValueError(f"{where}: {n} elevations but offsets of shape {c.offsets.shape} and attitudes of lengths "
                         f"{[len(a) for a in (c.rotation_deg, c.azimuth_deg, c.temperature_degC)]}")
    bad = np.flatnonzero((c.elevation_deg < 0) | (c.elevation_deg > 90))
    if bad.size:
        raise ValueError(f"{where}: elevation must be in [0, 90] deg; row {bad[0] + 1} has {c.elevation_deg[bad[0]]}")
    bad = np.flatnonzero(not_air_temperature(c.temperature_degC))
    if bad.size:
        raise ValueError(f"{where}: row {bad[0] + 1} has temperature_degC {c.temperature_degC[bad[0]]}, "
                         f"{AIR_TEMPERATURE_SLIP}")


def campaign_csv(c: Campaign, comments: tuple[str, ...] = ()) -> str:
    """The campaign as CSV text, ``# sign: correction``, numbers written losslessly (``repr``)."""
    cols = ["elevation_deg", "rotation_deg"] + (["azimuth_deg"] if c.has_azimuth else []) + (
        ["temperature_degC"] if c.has_temperature else [])
    attitude = {"elevation_deg": c.elevation_deg, "rotation_deg": c.rotation_deg, "azimuth_deg": c.azimuth_deg,
                "temperature_degC": c.temperature_degC}
    out = [f"# {x}" for x in comments] + [f"# sign: correction ({SIGNS['correction']})",
                                          ",".join(cols + list(OFFSET_COLUMNS))]
    for i in range(len(c.elevation_deg)):
        out.append(",".join([repr(float(attitude[k][i])) for k in cols] + [repr(float(v)) for v in c.offsets[i]]))
    return "\n".join(out) + "\n"


def write_campaign(c: Campaign, path: str | os.PathLike[str], comments: tuple[str, ...] = ()) -> None:
    """Write :func:`campaign_csv` atomically."""
    from .._files import write_text_atomic

    write_text_atomic(path, campaign_csv(c, comments))


class FlexureModel(eqx.Module):
    """Gravity and thermal flexure of a hexapod-mounted optic, linear in the gravity vector
    ``g = (cos E·sin R, cos E·cos R, sin E)`` in the rotator's frame and in the temperature:
    ``offset = K·(g − g_ref) + α·(T − T_ref)`` per axis (µm or deg).

    - ``compliance``: ``Float[Array, "6 3"]``, the offset per unit of each gravity component;
    - ``thermal``: ``Float[Array, " 6"]``, per °C;
    - ``reference_elevation_deg``, ``reference_temperature_degC``: where the optic was aligned.
    """

    compliance: Float[Array, "6 3"]
    thermal: Float[Array, " 6"]
    reference_elevation_deg: float = 90.0
    reference_temperature_degC: float = 10.0

    def offsets(self, elevation_deg: ArrayLike, rotation_deg: ArrayLike, azimuth_deg: ArrayLike = 0.0,
                temperature_degC: ArrayLike = 0.0) -> np.ndarray:
        """The correction offsets (µm, deg) at the attitudes (broadcast)."""
        e, r, t = (np.deg2rad(np.asarray(elevation_deg, float)), np.deg2rad(np.asarray(rotation_deg, float)),
                   np.asarray(temperature_degC, float))
        e, r, t = np.broadcast_arrays(e, r, t)
        g = np.stack([np.cos(e) * np.sin(r), np.cos(e) * np.cos(r), np.sin(e)], axis=-1)
        e0 = np.deg2rad(self.reference_elevation_deg)
        g0 = np.array([0.0, np.cos(e0), np.sin(e0)])
        k, a = np.asarray(self.compliance), np.asarray(self.thermal)
        return (g - g0) @ k.T + (t - self.reference_temperature_degC)[..., None] * a


def camera_flexure() -> FlexureModel:
    """A flexure model of the size of the Rubin camera hexapod's table (mm of decentre and z,
    0.03° of tilt between zenith and horizon; 66 µm/°C in z, the thermal z term of the v3
    table): for simulations and tests."""
    k = np.array([[2000.0, 0.0, 0.0], [0.0, 3000.0, 0.0], [0.0, 0.0, 1800.0],
                  [0.0, 0.03, 0.0], [-0.02, 0.0, 0.0], [0.0, 0.0, 0.0]])
    return FlexureModel(jax.numpy.asarray(k), jax.numpy.asarray([1.0, -2.0, -66.0, 1e-4, -1e-4, 0.0]))


def attitude_grid(elevations_deg: ArrayLike, rotations_deg: ArrayLike,
                  temperatures_degC: ArrayLike | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every combination of the given elevations, rotator angles and temperatures, flattened."""
    t = np.zeros(1) if temperatures_degC is None else np.atleast_1d(np.asarray(temperatures_degC, float))
    e, r, tt = np.meshgrid(np.atleast_1d(np.asarray(elevations_deg, float)),
                           np.atleast_1d(np.asarray(rotations_deg, float)), t, indexing="ij")
    return e.ravel(), r.ravel(), tt.ravel()


def simulate_campaign(
    key: Array,
    truth: CompensationTable | FlexureModel,
    elevations_deg: ArrayLike,
    rotations_deg: ArrayLike,
    temperatures_degC: ArrayLike | None = None,
    *,
    sigma_um: float = 5.0,
    sigma_arcsec: float = 1.0,
) -> Campaign:
    """A tracker campaign over the grid of :func:`attitude_grid`: the truth's offsets plus
    Gaussian noise of σ ``sigma_um`` on x, y, z and ``sigma_arcsec`` on u, v, w (the noise of the
    tracker's pose). ``truth`` is a table (the controller's rule, no filter) or a flexure model."""
    if sigma_um < 0 or sigma_arcsec < 0:
        raise ValueError(f"noise σ must be >= 0, got {sigma_um} µm, {sigma_arcsec}″")
    e, r, t = attitude_grid(elevations_deg, rotations_deg, temperatures_degC)
    if np.any((e < 0) | (e > 90)):
        raise ValueError(f"elevations must be in [0, 90] deg, got {np.unique(e[(e < 0) | (e > 90)]).tolist()}")
    clean = np.asarray(truth.offsets(e, r, 0.0, t))
    sigma = np.array([sigma_um] * 3 + [sigma_arcsec / 3600.0] * 3)
    noise = np.asarray(jax.random.normal(key, clean.shape, dtype=np.float64)) * sigma
    return Campaign(e, r, np.zeros_like(e), t, clean + noise, False, temperatures_degC is not None)
