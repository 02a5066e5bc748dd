"""The 6-RUS rotary hexapod: six motors on the base turn cranks, each crank carries a rod of fixed length.

Eisele R., "Inverse Kinematics of a Stewart Platform" (2019, https://raw.org/research/inverse-kinematics-of-a-stewart-platform/,
with the MIT-licensed library ``stewart.js``), and Szufnarowski F., "Stewart platform with fixed
rotary actuators: a low cost design study" (Bielefeld University, 2013): the closed-form inverse
kinematics of a crank-and-rod leg. Frames, pose and units as everywhere in the library: B fixed,
A moving, ``P = [dx, dy, dz, φ, θ, ψ]`` (mm, rad), ``T = Rz(ψ)·Ry(θ)·Rx(φ)``.

Leg ``i``: a motor at ``base_i`` (in B) turns a crank of length ``a_i`` in the vertical plane
through ``base_i`` along the horizontal direction ``u_i = (cos β_i, sin β_i, 0)`` (``β_i``: the
crank's azimuth); at crank angle ``α`` (from the horizontal, up positive) the crank end is
``h = base_i + a_i·(cos α·u_i + sin α·e_z)``, and a rod of length ``s_i`` joins it to the platform
joint ``platform_i`` (in A), with spherical (or universal) joints at both ends. With
``l = T·platform_i + d + v0 − base_i``, ``|l − (h − base_i)| = s_i`` reads

    ``E·cos α + F·sin α = G``,  ``E = u_i·l``,  ``F = l_z``,  ``G = (|l|² + a_i² − s_i²) / (2 a_i)``,

so ``α = atan2(F, E) − atan2(sqrt(E² + F² − G²), G)``: the root of Eisele's and Szufnarowski's
closed form (the crank end below the line from the motor to the joint). The reading is the crank
angle from its zero, ``q_i = α − crank_zero_i`` (rad; reports give µrad); by default
``crank_zero`` is the zero pose's crank angle, so every reading is 0 at the zero pose.

Reachability ``margin`` (mm): ``sqrt(E² + F²) − |G|`` (≥ 0 exactly when the rod reaches the
crank's circle) and, with ``crank_limits`` (the motors' range of absolute crank angles), the arc
``a_i·(α − α_min)`` and ``a_i·(α_max − α)`` the crank end may still travel; the smallest of them.

Calibration parameters, in this order: ``platform`` (18, mm), ``base`` (18, mm), ``crank_lengths``
(6, mm), ``rod_lengths`` (6, mm) and, in the default ``"54"`` set, ``crank_zero`` (6, rad: a servo
horn is keyed on a spline, its zero is known only to a tooth); the ``"48"`` set keeps
``crank_zero`` fixed (the homing is taken as exact; an error of it is the discrepancy workflow's
``crank_offset`` effect). The azimuths, ``v0``, the limits and the travel are not calibrated.

The leg is written once, :func:`crank_leg`, on components that broadcast against each other: the
inverse kinematics calls it on arrays (poses by legs), the population objective on
structure-of-arrays columns (poses by population members), the discrepancy model through
:meth:`RUSMechanism.solve_inverse_kinematics`.
"""

from __future__ import annotations

import warnings
from typing import Any, ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float

from .._checks import field_array, field_travel, on_host, to_device, valid_poses
from .._math import rotation_matrix
from ._abstract import AbstractMechanism, IKSolution, population_totals
from ._registry import check_file_header, check_keys, read_travel, register_family, register_preset, travel_dict

N_LEGS = 6
PARAM_SETS = ("54", "48")
"""The 6-RUS calibration parameter sets: with the crank zeros (default), without."""
_FILE_KEYS = ("base", "platform", "v0", "crank_lengths", "rod_lengths", "crank_azimuths_rad", "crank_azimuths_deg",
              "crank_zero_rad", "crank_limits_deg", "travel", "param_set")


def crank_leg(t, d, platform, base, azimuth, crank, rod) -> tuple[Array, Array]:
    """The crank-and-rod leg on components that broadcast against each other (poses by legs, or
    poses by population members): ``t[a][b]`` the rotation's entries, ``d`` the translation plus
    ``v0`` (three components each), ``platform`` and ``base`` the leg's joints (three components
    each), ``azimuth`` the crank's ``(cos β, sin β)``, ``crank`` and ``rod`` the lengths (mm).
    Returns the absolute crank angle ``α`` (rad) and the assembly margin ``sqrt(E² + F²) − |G|``
    (mm) of the module docstring."""
    lv = [t[k][0] * platform[0] + t[k][1] * platform[1] + t[k][2] * platform[2] + d[k] - base[k] for k in range(3)]
    e = azimuth[0] * lv[0] + azimuth[1] * lv[1]
    f = lv[2]
    g = (lv[0] * lv[0] + lv[1] * lv[1] + lv[2] * lv[2] + crank * crank - rod * rod) / (2.0 * crank)
    r2 = e * e + f * f
    alpha = jnp.arctan2(f, e) - jnp.arctan2(jnp.sqrt(jnp.maximum(r2 - g * g, 0.0)), g)
    return alpha, jnp.sqrt(r2) - jnp.abs(g)


@register_family
class RUSMechanism(AbstractMechanism):
    """A 6-RUS rotary hexapod (mm, rad); see the module docstring for the model.

    **Fields:**

    - ``base``: ``Float[Array, "6 3"]``, the crank pivots (motor axes' centres) in B.
    - ``platform``: ``Float[Array, "6 3"]``, the rods' platform joints in A.
    - ``v0``: ``Float[Array, "3"]``, A's origin in B at the zero pose.
    - ``crank_lengths``, ``rod_lengths``: ``Float[Array, "6"]`` (mm).
    - ``crank_zero``: ``Float[Array, "6"]``, the crank angle of a zero reading (rad); default the
      zero pose's.
    - ``azimuth``: ``Float[Array, "6"]``, each crank's plane direction ``β_i`` (rad; not calibrated).
    - ``crank_limits``: ``None`` or ``(min, max)`` absolute crank angle (rad, static).
    - ``travel``: ``None`` or six pose half-widths (mm, rad; static), the travel plans stay in.
    - ``param_set``: ``"54"`` or ``"48"`` (static).
    """

    family: ClassVar[str] = "6-RUS"
    reading_unit: ClassVar[str] = "rad"
    param_sets: ClassVar[tuple[str, ...]] = PARAM_SETS

    base: Float[Array, "6 3"]
    platform: Float[Array, "6 3"]
    v0: Float[Array, "3"]
    crank_lengths: Float[Array, "6"]
    rod_lengths: Float[Array, "6"]
    crank_zero: Float[Array, "6"]
    azimuth: Float[Array, "6"]
    crank_limits: tuple[float, float] | None = eqx.field(static=True)
    travel: tuple[float, ...] | None = eqx.field(static=True)
    param_set: str = eqx.field(static=True)

    def __init__(self, base: ArrayLike, platform: ArrayLike, v0: ArrayLike, crank_lengths: ArrayLike,
                 rod_lengths: ArrayLike, azimuth: ArrayLike, crank_zero: ArrayLike | None = None, *,
                 crank_limits: tuple[float, float] | None = None, travel: ArrayLike | None = None,
                 param_set: str = "54"):
        if param_set not in PARAM_SETS:
            raise ValueError(f"6-RUS param_set must be one of {PARAM_SETS}, got {param_set!r}")
        name = type(self).__name__
        self.base = field_array(base, name, "base", (N_LEGS, 3), unit="mm")
        self.platform = field_array(platform, name, "platform", (N_LEGS, 3), unit="mm")
        self.v0 = field_array(v0, name, "v0", (3,), unit="mm")
        self.crank_lengths = field_array(crank_lengths, name, "crank_lengths", (N_LEGS,), positive=True, unit="mm")
        self.rod_lengths = field_array(rod_lengths, name, "rod_lengths", (N_LEGS,), positive=True, unit="mm")
        self.azimuth = field_array(azimuth, name, "azimuth", (N_LEGS,), unit="rad")
        self.crank_limits = None if crank_limits is None else _limits(crank_limits)
        self.travel = None if travel is None else _travel(travel)
        self.param_set = param_set
        if crank_zero is None:  # the zero pose's crank angles: every reading 0 there
            crank_zero = self._crank_angles(jnp.zeros(6))[0]
        self.crank_zero = field_array(crank_zero, name, "crank_zero", (N_LEGS,), unit="rad")

    # ---- parameters -------------------------------------------------------------------------

    @property
    def params(self) -> Float[Array, " n"]:
        """``platform`` (18), ``base`` (18), ``crank_lengths`` (6), ``rod_lengths`` (6) (mm), and in
        the ``"54"`` set ``crank_zero`` (6, rad)."""
        batch = self.base.shape[:-2]
        xp, (platform, base, crank, rod, zero) = on_host(self.platform, self.base, self.crank_lengths,
                                                         self.rod_lengths, self.crank_zero)
        parts = [xp.reshape(platform, (*batch, 18)), xp.reshape(base, (*batch, 18)), crank, rod] + (
            [zero] if self.param_set == "54" else [])
        return to_device(xp.concatenate(parts, axis=-1))

    @property
    def param_units(self) -> tuple[str, ...]:
        return ("mm",) * 48 + ("rad",) * (6 if self.param_set == "54" else 0)

    @property
    def param_names(self) -> tuple[str, ...]:
        joints = [f"{side}{i}{c}" for side in ("platform", "base") for i in range(1, 7) for c in "xyz"]
        names = joints + [f"crank{i}" for i in range(1, 7)] + [f"rod{i}" for i in range(1, 7)]
        return tuple(names + ([f"crank_zero{i}" for i in range(1, 7)] if self.param_set == "54" else []))

    def with_params(self, params: Float[Array, " n"]) -> RUSMechanism:
        p = self.checked_params(params)
        batch = p.shape[:-1]
        zero = p[..., 48:54] if self.param_set == "54" else self.crank_zero
        return RUSMechanism(p[..., 18:36].reshape(*batch, N_LEGS, 3), p[..., :18].reshape(*batch, N_LEGS, 3),
                            self.v0, p[..., 36:42], p[..., 42:48], self.azimuth, zero,
                            crank_limits=self.crank_limits, travel=self.travel, param_set=self.param_set)

    def with_param_set(self, param_set: str) -> RUSMechanism:
        """The same mechanism calibrated with the crank zeros (``"54"``) or without (``"48"``); the
        constructor refuses any other set."""
        return RUSMechanism(self.base, self.platform, self.v0, self.crank_lengths, self.rod_lengths, self.azimuth,
                            self.crank_zero, crank_limits=self.crank_limits, travel=self.travel,
                            param_set=param_set)

    @property
    def n_params(self) -> int:
        return 54 if self.param_set == "54" else 48

    @property
    def leg_parameters(self) -> tuple[tuple[int, ...], ...]:
        """Leg i's reading depends on its own joints, crank and rod (and crank zero) only."""
        zero = (lambda i: (48 + i,)) if self.param_set == "54" else (lambda i: ())
        return tuple((3 * i, 3 * i + 1, 3 * i + 2, 18 + 3 * i, 19 + 3 * i, 20 + 3 * i, 36 + i, 42 + i) + zero(i)
                     for i in range(N_LEGS))

    @property
    def travel_half_widths(self) -> np.ndarray | None:
        return None if self.travel is None else np.asarray(self.travel)

    # ---- kinematics -------------------------------------------------------------------------

    def fixed_joints(self) -> Float[Array, "6 3"]:
        return self.base

    def moving_joints(self, poses: Float[Array, "... 6"]) -> Float[Array, "... 6 3"]:
        """``T·platform_i + d + v0``: the platform joints in B (mm)."""
        rot = rotation_matrix(poses[..., 3:])
        return jnp.einsum("...jk,ik->...ij", rot, self.platform) + poses[..., None, :3] + self.v0

    def _crank_angles(self, poses: Float[Array, "... 6"]) -> tuple[Array, Array]:
        """Absolute crank angles and assembly margins, ``(..., 6)`` each: :func:`crank_leg` on
        arrays of poses (rows) by legs (columns)."""
        rot = rotation_matrix(poses[..., 3:])
        t = [[rot[..., a, b, None] for b in range(3)] for a in range(3)]
        d = [poses[..., k, None] + self.v0[..., k, None] for k in range(3)]
        cols = lambda x: [x[..., k] for k in range(3)]  # noqa: E731
        return crank_leg(t, d, cols(self.platform), cols(self.base), (jnp.cos(self.azimuth), jnp.sin(self.azimuth)),
                         self.crank_lengths, self.rod_lengths)

    def _margin(self, alpha: Array, assembly: Array) -> Array:
        if self.crank_limits is None:
            return assembly
        lo, hi = self.crank_limits
        return jnp.minimum(assembly, self.crank_lengths * jnp.minimum(alpha - lo, hi - alpha))

    def solve_inverse_kinematics(self, poses: Float[Array, "... 6"]) -> IKSolution:
        """Crank readings ``q = α − crank_zero`` (rad), margins (mm) and reachability; pure and
        jittable, any leading batch shape of ``poses``."""
        alpha, assembly = self._crank_angles(poses)
        margin = self._margin(alpha, assembly)
        return IKSolution(alpha - self.crank_zero, margin, jnp.all(margin >= 0.0, axis=-1) & valid_poses(poses))

    def population_squared_residuals(
        self, params: Float[Array, "n p"], poses: Float[Array, "m 6"], readings: Float[Array, "m 6"]
    ) -> tuple[Float[Array, " n"], Bool[Array, " n"]]:
        """``Σ (readings − q(poses; u))²`` (rad²) and reachability for every row ``u`` of ``params``:
        :func:`crank_leg` on ``(m, n)`` arrays, pose by row and the population innermost."""
        u = jnp.asarray(params, jnp.float64).T  # (n_params, n)
        rot = rotation_matrix(poses[:, 3:])
        t = [[rot[:, a, b, None] for b in range(3)] for a in range(3)]  # (m, 1) each
        d = [poses[:, k, None] + self.v0[k] for k in range(3)]
        cos_b, sin_b = jnp.cos(self.azimuth), jnp.sin(self.azimuth)

        def leg(i):
            crank = u[36 + i]
            alpha, assembly = crank_leg(t, d, [u[3 * i + k] for k in range(3)], [u[18 + 3 * i + k] for k in range(3)],
                                        (cos_b[i], sin_b[i]), crank, u[42 + i])
            zero = u[48 + i] if self.param_set == "54" else self.crank_zero[i]
            margin = assembly
            if self.crank_limits is not None:
                lo, hi = self.crank_limits
                margin = jnp.minimum(assembly, crank * jnp.minimum(alpha - lo, hi - alpha))
            return alpha - zero, margin

        return population_totals(readings, poses, (leg(i) for i in range(N_LEGS)))

    # ---- files ------------------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """The geometry file: lengths in mm; the calibrated angles (crank zeros) and the azimuths in
        rad (keys ``*_rad``, so that a calibrated geometry reloads bit for bit), the limits and the
        travel's angles in degrees."""
        d: dict[str, Any] = {
            "mechanism": self.family,
            "units": "mm",
            "base": np.asarray(self.base).tolist(),
            "platform": np.asarray(self.platform).tolist(),
            "v0": np.asarray(self.v0).tolist(),
            "crank_lengths": np.asarray(self.crank_lengths).tolist(),
            "rod_lengths": np.asarray(self.rod_lengths).tolist(),
            "crank_azimuths_rad": np.asarray(self.azimuth).tolist(),
            "crank_zero_rad": np.asarray(self.crank_zero).tolist(),
        }
        if self.crank_limits is not None:
            d["crank_limits_deg"] = [float(np.rad2deg(a)) for a in self.crank_limits]
        if self.travel is not None:
            d["travel"] = travel_dict(self.travel)
        if self.param_set != "54":
            d["param_set"] = self.param_set
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> RUSMechanism:
        """Inverse of :meth:`to_dict`. Required: ``base``, ``platform`` (6×3, mm), ``crank_lengths``,
        ``rod_lengths`` (6, mm) and the crank azimuths (``crank_azimuths_rad`` or
        ``crank_azimuths_deg``, 6); optional: ``v0`` (default: the origin), ``crank_zero_rad`` (6;
        default the zero pose's crank angles), ``crank_limits_deg`` (``[min, max]``), ``travel``
        (``{"x_mm", "y_mm", "z_mm", "rx_deg", "ry_deg", "rz_deg"}``), ``param_set`` (``"54"``, ``"48"``)."""
        check_file_header({"mechanism": cls.family, **d}, cls.family)
        check_keys(d, cls.family, _FILE_KEYS)
        missing = [k for k in ("base", "platform", "crank_lengths", "rod_lengths") if k not in d]
        if ("crank_azimuths_rad" in d) == ("crank_azimuths_deg" in d):
            missing.append("crank_azimuths_rad or crank_azimuths_deg (one of them)")
        if missing:
            raise ValueError(f"6-RUS geometry is missing {missing}")
        azimuth = d["crank_azimuths_rad"] if "crank_azimuths_rad" in d else np.deg2rad(
            np.asarray(d["crank_azimuths_deg"], dtype=np.float64))
        limits = d.get("crank_limits_deg")
        travel = read_travel(d.get("travel"), cls.family)
        m = cls(d["base"], d["platform"], d.get("v0", (0.0, 0.0, 0.0)), d["crank_lengths"], d["rod_lengths"], azimuth,
                d.get("crank_zero_rad"), crank_limits=None if limits is None else tuple(np.deg2rad(limits)),
                travel=travel, param_set=str(d.get("param_set", "54")))
        return m

    def file_warnings(self) -> None:
        """Unit slips of a 6-RUS file, in both directions: a mechanism of a few mm (metres in a
        file of mm) or of a hundred metres (µm), joints smaller than the travel, crank zeros past
        ±π or azimuths spread over more than 4π (degrees in a radian field), and crank limits
        narrower than 6° (radians in a degree field)."""
        joints = np.concatenate([np.asarray(self.base), np.asarray(self.platform) + np.asarray(self.v0)])
        size = float(np.max(np.linalg.norm(joints, axis=-1)))
        reach = float(np.max(np.asarray(self.travel)[:3]))
        slips = []
        if size < 20.0 or size < reach:
            slips.append(f"the joints lie within {size:.3g} mm of the origin against a travel of ±{reach:.3g} mm "
                         "(lengths are mm: a file in metres needs every length × 1000)")
        elif size > 1e5:
            slips.append(f"joints {size / 1e3:.3g} m from the origin (lengths are mm: a file in µm needs ÷ 1000)")
        zero = np.asarray(self.crank_zero)
        if np.any(np.abs(zero) > np.pi):
            slips.append(f"crank_zero_rad {np.round(zero, 3).tolist()} has values past ±π (degrees typed in a "
                         "radian field?)")
        az = np.asarray(self.azimuth)
        if float(np.ptp(az)) > 4 * np.pi:
            slips.append(f"crank azimuths spread over {np.ptp(az):.4g} rad (degrees typed in "
                         "crank_azimuths_rad? use crank_azimuths_deg)")
        if self.crank_limits is not None and self.crank_limits[1] - self.crank_limits[0] < np.deg2rad(6.0):
            lo, hi = np.rad2deg(self.crank_limits)
            slips.append(f"crank_limits_deg [{lo:.3g}, {hi:.3g}]° (radians typed in a degree field? "
                         f"{lo:.3g} rad = {np.rad2deg(lo):.4g}°)")
        for slip in slips:
            warnings.warn(f"6-RUS geometry: {slip}", UserWarning, stacklevel=3)


def _limits(x: Any) -> tuple[float, float]:
    a = np.asarray(x, dtype=np.float64)
    if a.shape != (2,) or not np.all(np.isfinite(a)) or not a[0] < a[1]:
        raise ValueError(f"RUSMechanism.crank_limits must be [min, max] crank angles with min < max (rad), got {x!r}")
    if np.max(np.abs(a)) > 2 * np.pi:
        raise ValueError(f"RUSMechanism.crank_limits are radians inside the library; {a.tolist()} looks like degrees")
    return float(a[0]), float(a[1])


def _travel(x: Any) -> tuple[float, ...]:
    return field_travel(x, "RUSMechanism", ("x", "y", "z"), ("rx", "ry", "rz"))


# ---- presets ------------------------------------------------------------------------------------

EISELE_TRAVEL = (10.0, 10.0, 10.0, float(np.deg2rad(5.0)), float(np.deg2rad(5.0)), float(np.deg2rad(5.0)))
"""The ``rotary_stewart`` preset's travel (our choice; the source gives none): ±10 mm and ±5° on
each axis, a box whose 64 corners the design reaches with every crank inside ±90°."""


def _eisele_layout(base_radius: float, platform_radius: float, shaft_mm: float, anchor_mm: float):
    """The circular layout of Eisele's ``stewart.js`` (``initCircular``), leg ``i = 0..5``: the
    motor at angle ``(i + i mod 2)·60° ± shaft/2`` on the base circle, the platform joint at
    ``(1 + i − i mod 2)·60° ∓ anchor/2`` on the platform circle (both arc separations divided by the
    base radius, as the library does), the crank turning tangentially, alternate legs mirrored:
    azimuth ``motor angle + 90° + (i mod 2)·180°``."""
    base, platform, azimuth = [], [], []
    for i in range(N_LEGS):
        pm = (-1) ** i
        phi_b = (i + i % 2) * np.pi / 3 + pm * shaft_mm / base_radius / 2
        phi_p = (1 + i - i % 2) * np.pi / 3 - pm * anchor_mm / base_radius / 2
        base.append([base_radius * np.cos(phi_b), base_radius * np.sin(phi_b), 0.0])
        platform.append([platform_radius * np.cos(phi_p), platform_radius * np.sin(phi_p), 0.0])
        azimuth.append(phi_b + (i % 2) * np.pi + np.pi / 2)
    return np.array(base), np.array(platform), np.array(azimuth)


@register_preset("rotary_stewart")
def rotary_stewart() -> RUSMechanism:
    """The servo-driven rotary Stewart platform of Eisele (2019), the default circular design of his
    ``stewart.js``: motors on an 80 mm circle in pairs 20 mm apart, platform joints on a 50 mm circle
    in pairs 20 mm apart, cranks (servo horns) of 50 mm, rods of 130 mm, the servos' range ±90°;
    the platform at its home height ``sqrt(s² + a² − Δx² − Δy²) ≈ 126.85 mm`` above the base
    (``v0``). Travel: :data:`EISELE_TRAVEL`."""
    base, platform, azimuth = _eisele_layout(80.0, 50.0, 20.0, 20.0)
    crank, rod = 50.0, 130.0
    home = float(np.sqrt(rod**2 + crank**2 - np.sum((platform[0, :2] - base[0, :2]) ** 2)))
    return RUSMechanism(base, platform, (0.0, 0.0, home), np.full(N_LEGS, crank), np.full(N_LEGS, rod), azimuth,
                        crank_limits=(-np.pi / 2, np.pi / 2), travel=EISELE_TRAVEL)
