"""The compensation look-up table of the Rubin Observatory's hexapod controllers and its
evaluation rule.

Rubin Observatory, *MTHexapod CSC* (``lsst-ts/ts_mthexapod``, 2020–2025), compensation model
and configuration schema "MTHexapod v7"; the tables themselves are published in
``lsst-ts/ts_config_mttcs`` (``MTHexapod/v3`` … ``v7``). Written from the documented rule:

    offset_i = Σ_jk C_i[j, k]·E^j·R^k + Σ_j A_i[j]·Az^j + T_i(temperature),   i = x, y, z, u, v, w

with E the elevation (deg, refused outside [0, 90]), R the rotator angle (deg, wrapped to
[-180, 180)), Az the azimuth (deg, wrapped to [0, 360)), and ``T_i`` a *ranged* polynomial:
``Σ_j c_j·t^j`` inside ``[t_min, t_max]`` and, outside, its value at the nearer edge plus the
linear coefficient ``c_1`` times the distance to that edge. A filter's ``z_offset`` adds to z.
x, y, z are in µm, u, v, w in degrees; the compensated position is the uncompensated one plus
the offset. The older schema (v3–v6) sums separate power series in elevation and rotation: it is
the case ``C_i[j, 0] = e_j``, ``C_i[0, k] += r_k`` of the same rule.
"""

from __future__ import annotations

from collections.abc import Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float, Int

from .._checks import is_traced

AXES = ("x", "y", "z", "u", "v", "w")
"""The six offsets of a table, in the controller's order."""

AXIS_UNITS = ("um", "um", "um", "deg", "deg", "deg")
"""Their units: µm for x, y, z and degrees for u, v, w (the controller's)."""

OFFSET_COLUMNS = tuple(f"{a}_{u}" for a, u in zip(AXES, AXIS_UNITS, strict=True))
"""``("x_um", "y_um", "z_um", "u_deg", "v_deg", "w_deg")``: the CSV and JSON names of the offsets."""

AIR_TEMPERATURE_DEGC = (-90.0, 70.0)
"""Air temperatures a telescope can meet (°C; Earth's records are −89 and +57): a value outside is
a unit slip (kelvin, °F) and is refused, not extrapolated."""


def not_air_temperature(t: np.ndarray) -> np.ndarray:
    """Where temperatures ``t`` (°C) lie outside :data:`AIR_TEMPERATURE_DEGC`."""
    lo, hi = AIR_TEMPERATURE_DEGC
    return (t < lo) | (t > hi)


AIR_TEMPERATURE_SLIP = (f"not an air temperature in °C (a telescope meets {AIR_TEMPERATURE_DEGC[0]:g} to "
                        f"{AIR_TEMPERATURE_DEGC[1]:g} °C): a value in kelvin is 273.15 more, in °F (t − 32) × 5/9")
"""What a temperature outside :data:`AIR_TEMPERATURE_DEGC` is said to be."""

HEXAPODS = {"camera": "camera_config", "m2": "m2_config"}
"""The table of each hexapod in a configuration file."""


def _horner(coeffs: Float[Array, "... n"], x: Float[Array, "..."]) -> Float[Array, "..."]:
    """``Σ_j coeffs[..., j]·x^j`` by Horner's rule (no powers of negative numbers)."""
    out = jnp.zeros_like(x) + coeffs[..., -1]
    for j in range(coeffs.shape[-1] - 2, -1, -1):
        out = out * x + coeffs[..., j]
    return out


class CompensationTable(eqx.Module):
    """One hexapod's compensation table (a pytree; float64).

    - ``elevation_rotation``: ``Float[Array, "6 ne nr"]``, ``C_i[j, k]``, the coefficient of
      ``E^j·R^k`` (µm or deg per deg^(j+k)), zero-padded to a common shape;
    - ``azimuth``: ``Float[Array, "6 na"]``, the azimuth power series;
    - ``temperature``: ``Float[Array, "6 nt"]``, the ranged temperature polynomial;
    - ``min_temperature_degC``, ``max_temperature_degC``: its range (°C);
    - ``filter_names`` (static) and ``filter_z_um``: ``Float[Array, " nf"]``, each filter's z offset;
    - ``enable_temperature`` (static): the table's ``enable_lut_temperature``; the controller
      evaluates at 0 °C when it is false (the evaluation here always takes the temperature given);
    - ``hexapod`` (static): ``"camera"`` or ``"m2"``.

    :meth:`offsets` evaluates the rule for any batch of attitudes under one jitted function.
    """

    elevation_rotation: Float[Array, "6 ne nr"]
    azimuth: Float[Array, "6 na"]
    temperature: Float[Array, "6 nt"]
    min_temperature_degC: Float[Array, ""]
    max_temperature_degC: Float[Array, ""]
    filter_z_um: Float[Array, " nf"]
    filter_names: tuple[str, ...] = eqx.field(static=True, default=())
    enable_temperature: bool = eqx.field(static=True, default=False)
    hexapod: str = eqx.field(static=True, default="camera")

    def __check_init__(self):
        for name, arr, ndim in (("elevation_rotation", self.elevation_rotation, 3), ("azimuth", self.azimuth, 2),
                                ("temperature", self.temperature, 2)):
            if arr.ndim != ndim or arr.shape[0] != 6 or 0 in arr.shape:
                raise ValueError(f"CompensationTable.{name} must have 6 axes (x, y, z, u, v, w) of at least one "
                                 f"coefficient, got shape {arr.shape}")
        if self.filter_z_um.shape != (len(self.filter_names),):
            raise ValueError(f"{len(self.filter_names)} filter names but {self.filter_z_um.shape} z offsets")
        if self.hexapod not in HEXAPODS:
            raise ValueError(f"hexapod must be one of {sorted(HEXAPODS)}, got {self.hexapod!r}")
        if not is_traced((self.min_temperature_degC, self.max_temperature_degC)):
            if not float(self.min_temperature_degC) < float(self.max_temperature_degC):
                raise ValueError(f"min_temperature {float(self.min_temperature_degC)} °C must be below "
                                 f"max_temperature {float(self.max_temperature_degC)} °C")

    def offsets(
        self,
        elevation_deg: ArrayLike,
        rotation_deg: ArrayLike,
        azimuth_deg: ArrayLike = 0.0,
        temperature_degC: ArrayLike = 0.0,
        filter: str | Sequence[str | None] | None = None,
    ) -> Float[Array, "... 6"]:
        """The offsets ``[x_um, y_um, z_um, u_deg, v_deg, w_deg]`` at attitudes of any
        broadcastable batch shape. Elevation outside [0, 90], a temperature outside
        :data:`AIR_TEMPERATURE_DEGC` and an unknown filter are refused
        (``ValueError``) before any work; ``filter`` is one name, one per attitude (``None``:
        no filter offset), or ``None``."""
        e, r, a, t = (np.asarray(v, dtype=np.float64) for v in (elevation_deg, rotation_deg, azimuth_deg,
                                                                 temperature_degC))
        shape = np.broadcast_shapes(e.shape, r.shape, a.shape, t.shape)
        for name, v in (("elevation_deg", e), ("rotation_deg", r), ("azimuth_deg", a), ("temperature_degC", t)):
            if not np.all(np.isfinite(v)):
                raise ValueError(f"{name} must be finite, got {v[~np.isfinite(v)][:3].tolist()}")
        if np.any((e < 0.0) | (e > 90.0)):
            raise ValueError(f"elevation must be in [0, 90] deg (the controller refuses other values), got "
                             f"{e[(e < 0.0) | (e > 90.0)][:3].tolist()}")
        if np.any(not_air_temperature(t)):
            raise ValueError(f"temperature_degC {t[not_air_temperature(t)][:3].tolist()} is {AIR_TEMPERATURE_SLIP}")
        index = self.filter_index(filter, shape)
        return _offsets_jit(self, *(jnp.broadcast_to(v, shape) for v in (e, r, a, t)), jnp.asarray(index))

    def filter_index(self, filter: str | Sequence[str | None] | None, shape: tuple[int, ...] = ()) -> np.ndarray:
        """Indices into ``filter_names`` (−1: no filter), broadcast to ``shape``; an unknown
        name is refused naming the known ones."""
        if filter is None:
            return np.full(shape, -1)
        names = [filter] if isinstance(filter, str) else list(filter)
        known = {n: i for i, n in enumerate(self.filter_names)}
        out = []
        for n in names:
            if n is None or n == "":
                out.append(-1)
            elif n in known:
                out.append(known[n])
            else:
                raise ValueError(f"unknown filter {n!r}: the {self.hexapod} table has "
                                 f"{', '.join(self.filter_names) or 'no filter offsets'}")
        idx = np.asarray(out[0] if isinstance(filter, str) else out, dtype=np.int64)
        return np.broadcast_to(idx, shape)

    def scaled(self, factor: ArrayLike) -> CompensationTable:
        """The table with every axis's coefficients (and filter offsets) times ``factor``
        (one number, or six, one per axis)."""
        f = jnp.broadcast_to(jnp.asarray(factor, dtype=jnp.float64), (6,))
        return eqx.tree_at(lambda t: (t.elevation_rotation, t.azimuth, t.temperature, t.filter_z_um), self,
                           (self.elevation_rotation * f[:, None, None], self.azimuth * f[:, None],
                            self.temperature * f[:, None], self.filter_z_um * f[2]))


def evaluate(
    table: CompensationTable,
    elevation_deg: Float[Array, "..."],
    rotation_deg: Float[Array, "..."],
    azimuth_deg: Float[Array, "..."],
    temperature_degC: Float[Array, "..."],
    filter_index: Int[Array, "..."],
) -> Float[Array, "... 6"]:
    """The rule on arrays of one batch shape, without input checks (jit-friendly; the checks are
    :meth:`CompensationTable.offsets`'). ``filter_index`` −1 means no filter."""
    rot = jnp.mod(rotation_deg + 180.0, 360.0) - 180.0
    az = jnp.mod(azimuth_deg, 360.0)
    e, r, a, t = (x[..., None] for x in (elevation_deg, rot, az, temperature_degC))
    c = table.elevation_rotation
    er = jnp.zeros(e.shape[:-1] + (6,))
    for j in range(c.shape[1] - 1, -1, -1):  # Horner in E over the rows, each a polynomial in R
        er = er * e + _horner(c[:, j, :], r)
    out = er + _horner(table.azimuth, a) + _ranged(table, t)
    if table.filter_names:
        fz = jnp.where(filter_index >= 0, table.filter_z_um[jnp.clip(filter_index, 0)], 0.0)
        out = out.at[..., 2].add(fz)
    return out


def _ranged(table: CompensationTable, t: Float[Array, "... 1"]) -> Float[Array, "... 6"]:
    """The ranged temperature polynomial: the polynomial inside the range, outside it the edge
    value plus the linear coefficient times the distance to the edge."""
    c = table.temperature
    lo, hi = table.min_temperature_degC, table.max_temperature_degC
    linear = c[:, 1] if c.shape[1] > 1 else jnp.zeros(6)
    inside = _horner(c, t)
    below = _horner(c, lo) + linear * (t - lo)
    above = _horner(c, hi) + linear * (t - hi)
    return jnp.where(t < lo, below, jnp.where(t > hi, above, inside))


_offsets_jit = jax.jit(evaluate)
