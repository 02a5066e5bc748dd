"""Geometry of a 6-PSS Stewart mechanism (seed 000, §1.1–1.2; SPEC §2).

The 36 calibration parameters of Wang et al. (2018) are the joint centres: the upper
(moving-platform) spherical joints ``Ac_i`` in frame A and the lower spherical joints
``Bc_i`` in frame B at zero slider stroke. The rod lengths are not parameters: they follow
from the zero pose, ``L_i = |Ac_i + v0 - Bc_i|`` (seed 000, §1.2).

Units: mm throughout (SPEC §1).
"""

from __future__ import annotations

import json
import os
import tomllib
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

N_LEGS = 6
N_PARAMS = 36


class Geometry(eqx.Module):
    """Joint centres of a 6-PSS Stewart mechanism, in mm.

    A pytree: batch it (``jax.vmap`` over a leading axis of every leaf) to evaluate many
    parameter sets at once.

    **Fields:**

    - ``upper``: ``Float[Array, "6 3"]``, upper joint centres ``Ac_i`` in the moving frame A.
    - ``lower``: ``Float[Array, "6 3"]``, lower joint centres ``Bc_i`` in the fixed frame B at
      zero slider stroke.
    - ``v0``: ``Float[Array, "3"]``, position of A's origin in B at the zero pose (SPEC §2;
      the paper gives no value, the default is the origin).
    """

    upper: Float[Array, "6 3"]
    lower: Float[Array, "6 3"]
    v0: Float[Array, "3"]

    def __init__(self, upper: ArrayLike, lower: ArrayLike, v0: ArrayLike = (0.0, 0.0, 0.0)):
        self.upper = _as_float64(upper, "upper", (N_LEGS, 3))
        self.lower = _as_float64(lower, "lower", (N_LEGS, 3))
        self.v0 = _as_float64(v0, "v0", (3,))

    @property
    def params(self) -> Float[Array, "36"]:
        """The 36 calibration parameters: ``Ac_1..Ac_6`` then ``Bc_1..Bc_6``, each x, y, z."""
        return jnp.concatenate(
            [self.upper.reshape(*self.upper.shape[:-2], 18), self.lower.reshape(*self.lower.shape[:-2], 18)],
            axis=-1,
        )

    @property
    def rod_lengths(self) -> Float[Array, "6"]:
        """Rod lengths ``L_i = |Ac_i + v0 - Bc_i|`` (zero stroke at the zero pose)."""
        return rod_lengths(self)

    @classmethod
    def from_params(cls, params: ArrayLike, v0: ArrayLike = (0.0, 0.0, 0.0)) -> Geometry:
        """Build a geometry from the 36-vector of :attr:`params`."""
        return geometry_from_params(params, v0)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (mm)."""
        return {
            "units": "mm",
            "upper": np.asarray(self.upper).tolist(),
            "lower": np.asarray(self.lower).tolist(),
            "v0": np.asarray(self.v0).tolist(),
        }


def geometry_from_params(params: Float[Array, "36"], v0: ArrayLike = (0.0, 0.0, 0.0)) -> Geometry:
    """Geometry from the 36-vector of :attr:`Geometry.params` (order ``Ac_1..Ac_6`` then
    ``Bc_1..Bc_6``, each x, y, z); traceable, vmap it over ``params``."""
    p = jnp.asarray(params, dtype=jnp.float64)
    if p.shape[-1:] != (N_PARAMS,):
        raise ValueError(f"params must have a last axis of 36, got shape {p.shape}")
    batch = p.shape[:-1]
    return Geometry(p[..., :18].reshape(*batch, N_LEGS, 3), p[..., 18:].reshape(*batch, N_LEGS, 3), v0)


def rod_lengths(geometry: Geometry) -> Float[Array, "6"]:
    """``L_i = |Ac_i + v0 - Bc_i|`` (seed 000, §1.2)."""
    return jnp.linalg.norm(geometry.upper + geometry.v0 - geometry.lower, axis=-1)


def _as_float64(x: ArrayLike, name: str, shape: tuple[int, ...]) -> Array:
    if isinstance(x, jax.core.Tracer):
        return x  # traced (jit/vmap): validated where the concrete value was built
    a = np.asarray(x, dtype=np.float64)
    if a.shape[-len(shape):] != shape:
        raise ValueError(f"Geometry.{name} must have shape {shape}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"Geometry.{name} contains NaN or inf: {a.tolist()}")
    return jnp.asarray(a)


# Table 1 of seed 000 (mm). Rows: rod 1..6.
_NOMINAL_UPPER = np.array(
    [
        [103.6, 34.6, 84.7],
        [-21.5, 107.1, 84.7],
        [-81.8, 72.4, 84.7],
        [-81.8, -72.4, 84.7],
        [-21.5, -107.1, 84.7],
        [103.6, -34.6, 84.7],
    ]
)
_NOMINAL_LOWER = np.array(
    [
        [67.9, 61.8, -132.1],
        [19.6, 89.7, -132.1],
        [-87.5, 27.9, -132.1],
        [-87.5, -27.9, -132.1],
        [19.6, -89.7, -132.1],
        [67.9, -61.8, -132.1],
    ]
)
_ACTUAL_UPPER = np.array(
    [
        [103.7, 37.2, 79.2],
        [-20.8, 106.7, 81.1],
        [-83.7, 72.1, 90.9],
        [-77.2, -76.1, 89.8],
        [-21.1, -108.2, 85.1],
        [102.2, -35.8, 86.7],
    ]
)
_ACTUAL_LOWER = np.array(
    [
        [69.7, 63.7, -131.8],
        [16.1, 90.2, -129.9],
        [-86.5, 27.8, -131.7],
        [-89.1, -28.3, -134.7],
        [20.3, -93.0, -135.3],
        [65.3, -68.7, -130.3],
    ]
)

PRESETS = ("nominal", "actual")


def nominal_geometry(v0: ArrayLike = (0.0, 0.0, 0.0)) -> Geometry:
    """The nominal parameters ``u_0`` of seed 000, Table 1."""
    return Geometry(_NOMINAL_UPPER, _NOMINAL_LOWER, v0)


def actual_geometry(v0: ArrayLike = (0.0, 0.0, 0.0)) -> Geometry:
    """The "true" parameters ``u_a`` of seed 000, Table 1, used by the simulation study."""
    return Geometry(_ACTUAL_UPPER, _ACTUAL_LOWER, v0)


def preset_geometry(name: str, v0: ArrayLike = (0.0, 0.0, 0.0)) -> Geometry:
    """A named preset: ``"nominal"`` or ``"actual"`` (seed 000, Table 1)."""
    if name == "nominal":
        return nominal_geometry(v0)
    if name == "actual":
        return actual_geometry(v0)
    raise ValueError(f"unknown geometry preset {name!r}; choose one of {PRESETS} or give a file")


def geometry_from_dict(d: dict[str, Any]) -> Geometry:
    """Inverse of :meth:`Geometry.to_dict`. Accepts either ``upper``/``lower`` (6×3 each) or
    ``params`` (36 numbers, order ``Ac_1..Ac_6, Bc_1..Bc_6``); ``v0`` optional; lengths in mm."""
    units = d.get("units", "mm")
    if units != "mm":
        raise ValueError(f"geometry lengths must be in mm, the file says units={units!r}")
    v0 = d.get("v0", (0.0, 0.0, 0.0))
    if "params" in d:
        p = np.asarray(d["params"], dtype=np.float64)
        if p.shape != (N_PARAMS,):
            raise ValueError(f"geometry 'params' must hold 36 numbers, got shape {p.shape}")
        return Geometry(p[:18].reshape(6, 3), p[18:].reshape(6, 3), v0)
    missing = [k for k in ("upper", "lower") if k not in d]
    if missing:
        raise ValueError(f"geometry is missing {missing}: give 'upper' and 'lower' (6x3, mm) or 'params' (36)")
    return Geometry(d["upper"], d["lower"], v0)


def load_geometry(source: str | os.PathLike[str]) -> Geometry:
    """A preset name (``nominal``, ``actual``) or a JSON/TOML file written by
    :func:`save_geometry` (or by hand, see :func:`geometry_from_dict`)."""
    s = os.fspath(source)
    if s in PRESETS:
        return preset_geometry(s)
    if not os.path.exists(s):
        raise FileNotFoundError(f"geometry {s!r} is neither a preset {PRESETS} nor an existing file")
    if s.endswith(".toml"):
        with open(s, "rb") as f:
            return geometry_from_dict(tomllib.load(f))
    with open(s) as f:
        return geometry_from_dict(json.load(f))


def save_geometry(geometry: Geometry, path: str | os.PathLike[str]) -> None:
    """Write a geometry as JSON (full float64 precision)."""
    with open(path, "w") as f:
        json.dump(geometry.to_dict(), f, indent=2)
        f.write("\n")
