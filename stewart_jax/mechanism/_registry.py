"""Mechanism families and named presets, and the geometry files that name them.

A geometry file (JSON or TOML, lengths in mm) names its family with the key ``"mechanism"``; a
file without it is the 6-PSS of Wang et al. (2018), so older files keep loading. A family is
registered once, by decorating its class with :func:`register_family`; a preset (a named
geometry, e.g. ``"nominal"``) by decorating a zero-argument factory with :func:`register_preset`.
"""

from __future__ import annotations

import json
import os
import tomllib
from collections.abc import Callable
from typing import Any, TypeVar

from .._files import write_text_atomic
from .._units import READING_UNITS
from ._abstract import AbstractMechanism

DEFAULT_FAMILY = "6-PSS"

_FAMILIES: dict[str, type[AbstractMechanism]] = {}
_PRESETS: dict[str, Callable[[], AbstractMechanism]] = {}
_MEASURED: dict[str, str] = {}

M = TypeVar("M", bound=type[AbstractMechanism])


def register_family(cls: M) -> M:
    """Class decorator: geometry files with ``"mechanism": cls.family`` load as ``cls``; the class
    names its family and its readings' unit (``reading_unit``, ``"mm"`` or ``"rad"``)."""
    name = getattr(cls, "family", None)
    if not isinstance(name, str) or not name:
        raise TypeError(f"{cls.__name__} needs a class attribute `family` (the geometry file's name)")
    unit = getattr(cls, "reading_unit", None)
    if unit not in READING_UNITS:
        raise TypeError(f"{cls.__name__} needs a class attribute `reading_unit`, one of {list(READING_UNITS)} (a "
                        f"linear or an angular actuator reading), got {unit!r}")
    if name in _FAMILIES and _FAMILIES[name] is not cls:
        raise ValueError(f"mechanism family {name!r} is already registered by {_FAMILIES[name].__name__}")
    _FAMILIES[name] = cls
    return cls


def register_preset(
    name: str, *, measured: str | None = None
) -> Callable[[Callable[[], AbstractMechanism]], Callable[[], AbstractMechanism]]:
    """Decorator: ``factory()`` is the geometry named ``name`` (``--geometry NAME`` in the CLI).
    ``measured``: the preset that is this design's measured, as-built geometry (Wang et al. (2018)
    publish the nominal 6-PSS beside its "actual" one): the simulated true mechanism when no
    other is given, instead of a random perturbation."""

    def deco(factory: Callable[[], AbstractMechanism]) -> Callable[[], AbstractMechanism]:
        if name in _PRESETS and _PRESETS[name] is not factory:
            raise ValueError(f"preset {name!r} is already registered")
        _PRESETS[name] = factory
        if measured is not None:
            _MEASURED[name] = measured
        return factory

    return deco


def check_file_header(d: dict[str, Any], family: str) -> None:
    """A family's ``from_dict`` starts here: the file names this family (or none, for the
    default family) and its lengths are in mm."""
    named = d.get("mechanism", DEFAULT_FAMILY)
    if named != family:
        raise ValueError(f"a {family!r} geometry was expected, the file says mechanism={named!r}; "
                         "use load_mechanism to read any family")
    units = d.get("units", "mm")
    if units != "mm":
        raise ValueError(f"{family} geometry lengths must be in mm, the file says units={units!r}")


TRAVEL_KEYS = ("x_mm", "y_mm", "z_mm", "rx_deg", "ry_deg", "rz_deg")
"""The geometry file's ``"travel"`` object, for every family: the pose half-widths (mm, degrees)."""


def read_travel(travel: Any, family: str) -> tuple[float, ...] | None:
    """A geometry file's ``"travel"`` (``None`` where absent) as the six pose half-widths in mm and
    rad, or an error naming the keys of :data:`TRAVEL_KEYS`."""
    if travel is None:
        return None
    if not isinstance(travel, dict) or set(travel) != set(TRAVEL_KEYS):
        raise ValueError(f"{family} travel must be an object with exactly the keys {list(TRAVEL_KEYS)}, got {travel!r}")
    import numpy as np

    try:
        t = np.asarray([travel[k] for k in TRAVEL_KEYS], dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{family} travel must be numbers, got {travel!r}") from None
    if not np.all(np.isfinite(t)):
        raise ValueError(f"{family} travel must be finite, got {travel!r}")
    return (*(float(v) for v in t[:3]), *(float(v) for v in np.deg2rad(t[3:])))


def travel_dict(travel: tuple[float, ...]) -> dict[str, float]:
    """The six pose half-widths (mm, rad) as the geometry file's ``"travel"`` object."""
    import numpy as np

    x, y, z, *angles = travel
    return dict(zip(TRAVEL_KEYS, (x, y, z, *(float(np.rad2deg(a)) for a in angles)), strict=True))


DOCUMENTATION_KEYS = ("name", "description", "comment", "source", "notes")
"""Keys a geometry file may carry for people (ignored), besides any key starting with ``_``."""


def check_keys(d: dict[str, Any], family: str, known: tuple[str, ...]) -> None:
    """Refuse a key the family does not read, with the nearest known key: a misspelt
    ``strok_limits`` would otherwise silently drop the stroke limits."""
    import difflib

    allowed = {"mechanism", "units", *known, *DOCUMENTATION_KEYS}
    unknown = [k for k in d if k not in allowed and not (isinstance(k, str) and k.startswith("_"))]
    if not unknown:
        return
    hints = []
    for k in unknown:
        near = difflib.get_close_matches(str(k), sorted(allowed), n=1, cutoff=0.6)
        hints.append(f"{k!r}" + (f" (did you mean {near[0]!r}?)" if near else ""))
    raise ValueError(f"{family} geometry has unknown key(s) {', '.join(hints)}; the keys it reads are "
                     f"{sorted(allowed - set(DOCUMENTATION_KEYS))} (keys starting with '_' and "
                     f"{list(DOCUMENTATION_KEYS)} are notes for people)")


def _zero_pose(m: AbstractMechanism, zero):
    import jax

    global _ZERO_POSE_JIT
    if _ZERO_POSE_JIT is None:  # jitted: one compilation instead of one per operation
        _ZERO_POSE_JIT = jax.jit(lambda m, p: m.ik_and_jacobian(p))
    return _ZERO_POSE_JIT(m, zero)


_ZERO_POSE_JIT = None


def check_geometry(m: AbstractMechanism) -> None:
    """Checks every geometry file passes at load (and so ``simulate``, ``calibrate`` and ``export``
    alike), each naming the leg and the value: no two legs the same, the zero pose reachable and
    its pose Jacobian ``∂q/∂P`` not singular (a singular one means the struts cannot hold the
    platform: all horizontal, joints on one line, a zero-length strut)."""
    import jax.numpy as jnp
    import numpy as np

    params = np.asarray(m.params)
    legs = m.leg_parameters
    if legs is not None:
        for i in range(len(legs)):
            for j in range(i + 1, len(legs)):
                a, b = params[list(legs[i])], params[list(legs[j])]
                if np.allclose(a, b, rtol=0.0, atol=1e-9 * max(1.0, float(np.max(np.abs(params))))):
                    raise ValueError(f"legs {i + 1} and {j + 1} are the same leg (identical joints "
                                     f"{a.tolist()}): a copy-paste slip? Six distinct legs are needed")
    readings, margin, jac = (np.asarray(x) for x in _zero_pose(m, jnp.zeros((1, 6))))
    margin, jac = margin[0], jac[0]
    if not np.all(margin >= 0):
        bad = np.flatnonzero(~(margin >= 0))
        raise ValueError(
            f"the zero pose is not reachable: legs {(bad + 1).tolist()} (readings {readings[0][bad].tolist()} mm, "
            f"margins {margin[bad].tolist()}) are outside their limits or cannot be assembled; check the "
            "lengths, the limits and their units (mm, degrees)")
    if not np.all(np.isfinite(jac)):
        raise ValueError("the pose Jacobian at the zero pose is not finite (a zero-length leg?)")
    # mm and rad columns: scale the angle columns by the size of the mechanism before comparing
    size = max(float(np.max(np.abs(params))), 1e-12)
    scaled = jac * np.array([1.0] * 3 + [1.0 / size] * 3)
    sv = np.linalg.svd(scaled, compute_uv=False)
    if sv[-1] <= 1e-9 * sv[0]:
        _, _, vt = np.linalg.svd(scaled)
        null = vt[-1] * np.array([1.0] * 3 + [1.0 / size] * 3)
        names = ("dx", "dy", "dz", "φ", "θ", "ψ")
        k = np.argsort(-np.abs(null))
        direction = " + ".join(f"{null[i] / np.abs(null[k[0]]):.3g}·{names[i]}" for i in k if abs(null[i]) > 1e-3 *
                               abs(null[k[0]]))
        raise ValueError(
            f"the legs cannot hold the platform at the zero pose: the pose Jacobian ∂q/∂P is singular "
            f"(condition number {sv[0] / max(sv[-1], 1e-300):.3g}); the platform can move along "
            f"{direction} with no reading changing. Causes: all legs horizontal for dz, the joints of one side on "
            "a line or at one point, a zero-length leg, legs pointing through one line")


def families() -> tuple[str, ...]:
    """The registered family names (geometry files' ``"mechanism"`` values)."""
    return tuple(_FAMILIES)


def presets() -> tuple[str, ...]:
    """The registered preset names."""
    return tuple(_PRESETS)


def measured_preset(name: str) -> str | None:
    """The preset registered as the measured geometry of preset ``name``, or ``None``."""
    return _MEASURED.get(name)


def family(name: str) -> type[AbstractMechanism]:
    """The class of a registered family."""
    try:
        return _FAMILIES[name]
    except KeyError:
        raise ValueError(f"unknown mechanism family {name!r}; known: {families()}") from None


def preset(name: str) -> AbstractMechanism:
    """The geometry of a registered preset."""
    try:
        factory = _PRESETS[name]
    except KeyError:
        raise ValueError(f"unknown geometry preset {name!r}; choose one of {presets()} or give a file") from None
    return factory()


def mechanism_from_dict(d: dict[str, Any]) -> AbstractMechanism:
    """A geometry file's content → the mechanism of the family it names (default 6-PSS): the
    family's ``from_dict`` (its own fields and refusals), then, once for every family,
    :func:`check_geometry`, then the family's :meth:`~AbstractMechanism.file_warnings`."""
    if not isinstance(d, dict):
        raise ValueError(f"a geometry must be a JSON/TOML object (mapping), got {type(d).__name__}")
    m = family(d.get("mechanism", DEFAULT_FAMILY)).from_dict(d)
    check_geometry(m)  # refusals before warnings
    m.file_warnings()
    return m


def load_mechanism(source: str | os.PathLike[str]) -> AbstractMechanism:
    """A preset name or a JSON/TOML geometry file (written by :func:`save_mechanism` or by hand)."""
    s = os.fspath(source)
    if s in _PRESETS:
        return preset(s)
    if not os.path.exists(s):
        raise FileNotFoundError(f"geometry {s!r} is neither a preset {presets()} nor an existing file")
    if os.path.isdir(s):
        raise ValueError(f"geometry {s!r} is a folder, not a geometry file")
    kind = "TOML" if s.endswith(".toml") else "JSON"
    try:
        if kind == "TOML":
            with open(s, "rb") as f:
                d = tomllib.load(f)
        else:
            with open(s, encoding="utf-8-sig") as f:  # tolerate a byte-order mark (files saved by Windows tools)
                d = json.load(f)
    except UnicodeDecodeError as e:
        raise ValueError(f"geometry file {s!r} is not UTF-8 text ({e.reason} at byte {e.start})") from None
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as e:
        raise ValueError(f"geometry file {s!r} is not valid {kind}: {e}") from None
    try:
        return mechanism_from_dict(d)
    except ValueError as e:
        raise ValueError(f"geometry file {s!r}: {e}") from None


def mechanism_json(mechanism: AbstractMechanism) -> str:
    """The geometry file of ``mechanism`` as JSON text (full float64 precision)."""
    return json.dumps(mechanism.to_dict(), indent=2) + "\n"


def save_mechanism(mechanism: AbstractMechanism, path: str | os.PathLike[str]) -> None:
    """Write a geometry file as JSON (full float64 precision), atomically."""
    write_text_atomic(path, mechanism_json(mechanism))
