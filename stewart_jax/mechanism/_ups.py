"""The 6-UPS strut hexapod: six legs that change length between joints on the base and the platform.

Most telescope hexapods are of this kind (the Rubin Observatory's camera and M2 hexapods, the
Stewart platform in the FAST feed cabin of Yin, Jiang, Chen, Yao, "Dynamic modeling of a
cable-driven parallel robot with a Stewart platform for use in FAST"), often with flexures in
place of the universal and spherical joints. The kinematics is the strut-length form of the
6-PSS leg of Wang H., Cao X. et al., "Improved cuckoo calibration method of space telescope
secondary mirror adjusting mechanism", Infrared and Laser Engineering 47(5), 2018, eq. 2.

Frames and units as everywhere in the library: B fixed, A moving, pose ``P = [dx, dy, dz, φ, θ,
ψ]`` (mm, rad), ``T = Rz(ψ)·Ry(θ)·Rx(φ)``; lengths in mm.

- Strut ``i`` joins ``base_i`` (in B) to ``platform_i`` (in A); its length is
  ``l_i = |T·platform_i + d + v0 − base_i|``.
- The actuator reading is ``q_i = l_i − lengths0_i``; by default ``lengths0_i`` is the zero-pose
  length ``|platform_i + v0 − base_i|``, so every reading is 0 at the zero pose.
- Calibration parameters (42): ``platform`` (18), ``base`` (18), ``lengths0`` (6), each joint
  x, y, z, in that order. ``v0`` and the limits are not calibrated.

The strut is written once, :func:`strut_leg`, on components that broadcast against each other:
the inverse kinematics calls it on arrays (poses by struts), the population objective on
structure-of-arrays columns (poses by population members), the discrepancy model through
:meth:`UPSMechanism.solve_inverse_kinematics`.

Limits (optional, static metadata of the mechanism, not calibrated, not traced):

- ``stroke_limits``: ``[min, max]`` of the reading (mm) per strut.
- ``joint_angle_limit``: the largest angle (rad inside the library, degrees in files) a strut
  may make with its zero-pose direction at either end: at the base end the strut direction is
  compared in B, at the platform end in A (the platform joint turns with the platform).

The reachability ``margin`` of strut ``i`` is in mm: the smallest of ``q − min``, ``max − q``
and ``l·(θ_max − θ)`` (the joint-angle margin as the arc the strut's far end may still sweep),
over the limits that are set; with no limit set it is the strut length ``l`` (always ≥ 0, a
strut cannot be "too long" without a limit).

``travel`` (optional, static): the mechanism's published travel ``(x, y, z, rx, ry, rz)``: the
largest ``|dx|``, ``|dy|``, ``|dz|`` (mm), ``|φ|``, ``|θ|`` and ``|ψ|`` (rad). It describes the
presets and is written to geometry files under the key ``"travel"`` (every family's schema:
``{"x_mm", "y_mm", "z_mm", "rx_deg", "ry_deg", "rz_deg"}``); the kinematics does not use it. A
published travel is per axis: a pose at several axes' extremes at once may exceed a stroke limit.
"""

from __future__ import annotations

import functools
from typing import Any, ClassVar, NamedTuple

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float

from .._checks import field_array, field_numbers, field_travel, on_host, to_device, valid_poses
from .._math import rotation_matrix
from ._abstract import AbstractMechanism, IKSolution, dense_parameter_jacobian, population_totals
from ._registry import check_file_header, check_keys, read_travel, register_family, travel_dict
from ._ups_checks import check_layout, warn_unit_slips

N_LEGS = 6
N_PARAMS_UPS = 42

_FILE_KEYS = ("base", "platform", "v0", "lengths0", "stroke_limits", "joint_angle_limits", "joint_angle_limit",
              "travel")


@register_family
class UPSMechanism(AbstractMechanism):
    """A 6-UPS strut hexapod (mm); see the module docstring for the model.

    A pytree: batch it (``jax.vmap`` over a leading axis of every array leaf) to evaluate many
    parameter sets at once. The limits and the travel are static metadata (hashable tuples),
    shared by every member of a batch.

    **Fields:**

    - ``base``: ``Float[Array, "6 3"]``, fixed-side joint centres in B.
    - ``platform``: ``Float[Array, "6 3"]``, moving-side joint centres in A.
    - ``v0``: ``Float[Array, "3"]``, A's origin (the pivot whose pose is commanded) in B at the
      zero pose.
    - ``lengths0``: ``Float[Array, "6"]``, strut lengths at zero reading; default
      ``|platform_i + v0 − base_i|``.
    - ``stroke_limits``: ``None`` or six ``(min, max)`` reading pairs (mm); the constructor
      also takes one pair for all struts.
    - ``joint_angle_limit``: ``None`` or six angles (rad, each in (0, π/2)); the constructor
      also takes one number.
    - ``travel``: ``None`` or ``(x_mm, y_mm, z_mm, rx_rad, ry_rad, rz_rad)``, the published travel.
    """

    family: ClassVar[str] = "6-UPS"
    reading_unit: ClassVar[str] = "mm"

    base: Float[Array, "6 3"]
    platform: Float[Array, "6 3"]
    v0: Float[Array, "3"]
    lengths0: Float[Array, "6"]
    stroke_limits: tuple[tuple[float, float], ...] | None = eqx.field(static=True)
    joint_angle_limit: tuple[float, ...] | None = eqx.field(static=True)
    travel: tuple[float, ...] | None = eqx.field(static=True)

    def __init__(
        self,
        base: ArrayLike,
        platform: ArrayLike,
        v0: ArrayLike = (0.0, 0.0, 0.0),
        lengths0: ArrayLike | None = None,
        *,
        stroke_limits: ArrayLike | None = None,
        joint_angle_limit: ArrayLike | None = None,
        travel: ArrayLike | None = None,
    ):
        self.base = _as_float64(base, "base", (N_LEGS, 3))
        self.platform = _as_float64(platform, "platform", (N_LEGS, 3))
        self.v0 = _as_float64(v0, "v0", (3,))
        if lengths0 is None:
            e = self.platform + self.v0 - self.base
            lengths0 = _length([e[..., k] for k in range(3)])  # as strut_leg's |e|: 0 at the zero pose
        self.lengths0 = _as_float64(lengths0, "lengths0", (N_LEGS,))
        self.stroke_limits = _stroke_limits(stroke_limits)
        self.joint_angle_limit = _angle_limit(joint_angle_limit)
        self.travel = _travel(travel)

    # ---- parameters -------------------------------------------------------------------------

    @property
    def params(self) -> Float[Array, "42"]:
        """The 42 calibration parameters: ``platform`` (18), ``base`` (18), ``lengths0`` (6)."""
        batch = self.base.shape[:-2]
        xp, (platform, base, lengths0) = on_host(self.platform, self.base, self.lengths0)
        return to_device(xp.concatenate([xp.reshape(platform, (*batch, 18)), xp.reshape(base, (*batch, 18)), lengths0],
                                        axis=-1))

    @property
    def param_units(self) -> tuple[str, ...]:
        """Every parameter is a length (mm)."""
        return ("mm",) * N_PARAMS_UPS

    @property
    def param_names(self) -> tuple[str, ...]:
        joints = tuple(f"{side}{i}{c}" for side in ("platform", "base") for i in range(1, 7) for c in "xyz")
        return joints + tuple(f"lengths0_{i}" for i in range(1, 7))

    def with_params(self, params: Float[Array, "42"]) -> UPSMechanism:
        """The same mechanism (v0, limits, travel kept) with the 42 parameters replaced; traceable."""
        p = self.checked_params(params)
        batch = p.shape[:-1]
        return UPSMechanism(
            p[..., 18:36].reshape(*batch, N_LEGS, 3),
            p[..., :18].reshape(*batch, N_LEGS, 3),
            self.v0,
            p[..., 36:],
            stroke_limits=self.stroke_limits,
            joint_angle_limit=self.joint_angle_limit,
            travel=self.travel,
        )

    @property
    def leg_parameters(self) -> tuple[tuple[int, ...], ...]:
        """Strut i's reading depends on ``platform_i``, ``base_i`` and ``lengths0_i`` only."""
        return tuple((3 * i, 3 * i + 1, 3 * i + 2, 18 + 3 * i, 19 + 3 * i, 20 + 3 * i, 36 + i) for i in range(N_LEGS))

    @property
    def travel_half_widths(self) -> np.ndarray | None:
        """The travel as pose half-widths ``[x, y, z, rx, ry, rz]`` (mm, rad), or ``None``."""
        return None if self.travel is None else np.asarray(self.travel)

    # ---- kinematics -------------------------------------------------------------------------

    def fixed_joints(self) -> Float[Array, "6 3"]:
        return self.base

    def moving_joints(self, poses: Float[Array, "... 6"]) -> Float[Array, "... 6 3"]:
        """``T·platform_i + d + v0``: the moving joint centres in B (mm)."""
        rot = rotation_matrix(poses[..., 3:])
        return jnp.einsum("...jk,ik->...ij", rot, self.platform) + poses[..., None, :3] + self.v0

    def strut_lengths(self, poses: Float[Array, "... 6"]) -> Float[Array, "... 6"]:
        """Strut lengths ``l_i = lengths0_i + q_i`` (mm) at ``poses``."""
        return self.lengths0 + _ik_parts(self, poses).readings

    def solve_inverse_kinematics(self, poses: Float[Array, "... 6"]) -> IKSolution:
        """Readings ``q_i = l_i − lengths0_i`` (mm), the margin (mm) and reachability; pure and
        jittable, any leading batch shape of ``poses``.

        The strut :func:`strut_leg` on poses by struts: with ``e_i = platform_i + v0 − base_i`` the
        zero-pose strut and ``δ_i = (T − I)·platform_i + d`` the moving joint's displacement
        (``T − I`` built with ``1 − cos x = 2 sin²(x/2)`` on its diagonal),
        ``q = δ·(2e + δ) / (l + |e|) + (|e| − lengths0)``, cancellation-free and exactly 0 at the
        zero pose when ``lengths0`` is the default.
        """
        parts = _ik_parts(self, poses)
        return IKSolution(parts.readings, parts.margin, jnp.all(parts.margin >= 0.0, axis=-1) & valid_poses(poses))

    def ik_and_jacobian(self, poses: Float[Array, "... 6"]):
        """Readings, margins (``(..., 6)``) and the analytic pose Jacobian ``∂q_i/∂P_k``
        (``(..., 6, 6)``): row ``i`` is ``u_iᵀ [I | ∂(T·p_i)/∂φ, ∂(T·p_i)/∂θ, ∂(T·p_i)/∂ψ]`` with
        ``u_i`` the unit strut vector and ``∂(T·p)/∂φ = T·(e_x × p)``,
        ``∂(T·p)/∂θ = (Rz(ψ)·e_y) × T·p``, ``∂(T·p)/∂ψ = e_z × T·p``."""
        parts = _ik_parts(self, poses)
        u = parts.unit
        tp = parts.tp
        ex_p = jnp.stack(
            [jnp.zeros_like(self.platform[:, 0]), -self.platform[:, 2], self.platform[:, 1]], axis=-1
        )  # e_x × p
        d_phi = jnp.einsum("...jk,ik->...ij", parts.rot, ex_p)
        psi = poses[..., 5:6]
        axis_theta = jnp.concatenate([-jnp.sin(psi), jnp.cos(psi), jnp.zeros_like(psi)], axis=-1)
        d_theta = jnp.cross(jnp.broadcast_to(axis_theta[..., None, :], tp.shape), tp)
        d_psi = jnp.stack([-tp[..., 1], tp[..., 0], jnp.zeros_like(tp[..., 0])], axis=-1)
        jac = jnp.concatenate(
            [
                u,
                jnp.sum(u * d_phi, axis=-1, keepdims=True),
                jnp.sum(u * d_theta, axis=-1, keepdims=True),
                jnp.sum(u * d_psi, axis=-1, keepdims=True),
            ],
            axis=-1,
        )
        return parts.readings, parts.margin, jac

    def population_squared_residuals(
        self, params: Float[Array, "n 42"], poses: Float[Array, "m 6"], readings: Float[Array, "m 6"]
    ) -> tuple[Float[Array, " n"], Bool[Array, " n"]]:
        """``Σ (readings − q(poses; u))²`` and reachability (stroke limits, joint angles) for
        every row ``u`` of ``params``, in structure-of-arrays form: every quantity an ``(m, n)``
        array, the population innermost (see
        :meth:`~stewart_jax.mechanism.PSSMechanism.population_squared_residuals`): the strut
        :func:`strut_leg` on ``(m, n)`` arrays.
        """
        u = jnp.asarray(params, jnp.float64).T  # (42, n)
        angles = poses[:, 3:]
        t, tm1 = _entries(rotation_matrix(angles)), _entries(_rotation_minus_identity(angles))  # (m, 1) each
        d = [poses[:, k, None] for k in range(3)]
        limits = None if self.stroke_limits is None else np.asarray(self.stroke_limits)

        def leg(i):
            p = [u[3 * i + k] for k in range(3)]  # platform_i, (n,) each
            e = [p[k] + self.v0[k] - u[18 + 3 * i + k] for k in range(3)]  # zero-pose strut
            out = strut_leg(t, tm1, d, p, e, u[36 + i], None if limits is None else limits[i],
                            None if self.joint_angle_limit is None else self.joint_angle_limit[i])
            return out.readings, out.margin

        return population_totals(readings, poses, (leg(i) for i in range(N_LEGS)))

    def parameter_jacobian(self, poses: Float[Array, "m 6"]) -> Float[Array, "6m 42"]:
        """Analytic ``∂q/∂u`` (row ``6j + i`` is strut ``i`` at pose ``j``), from
        :meth:`leg_parameter_jacobian`."""
        return dense_parameter_jacobian(self.leg_parameter_jacobian(poses), self.leg_parameters, self.n_params)

    def leg_parameter_jacobian(self, poses: Float[Array, "m 6"]) -> Float[Array, "6 m 7"]:
        """Per strut ``i``, ``∂q_i/∂(platform_i, base_i, lengths0_i)`` at each pose: ``u_iᵀ·T``,
        ``−u_iᵀ`` and ``−1`` (``(6, m, 7)``, :attr:`leg_parameters` order)."""
        parts = _ik_parts(self, poses)
        u = parts.unit  # (m, 6, 3)
        d_platform = jnp.einsum("mij,mjk->mik", u, parts.rot)  # uᵀT, (m, 6, 3)
        return jnp.moveaxis(jnp.concatenate([d_platform, -u, -jnp.ones_like(u[..., :1])], axis=-1), 0, 1)

    # ---- files ------------------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """The geometry file (JSON-ready): lengths in mm, the joint-angle limit and the travel's
        angles in degrees; limits and travel only where set."""
        d: dict[str, Any] = {
            "mechanism": self.family,
            "units": "mm",
            "base": np.asarray(self.base).tolist(),
            "platform": np.asarray(self.platform).tolist(),
            "v0": np.asarray(self.v0).tolist(),
            "lengths0": np.asarray(self.lengths0).tolist(),
        }
        if self.stroke_limits is not None:
            pairs = [list(p) for p in self.stroke_limits]
            d["stroke_limits"] = pairs[0] if all(p == pairs[0] for p in pairs) else pairs
        if self.joint_angle_limit is not None:
            deg = [float(np.rad2deg(a)) for a in self.joint_angle_limit]
            d["joint_angle_limits"] = deg[0] if all(a == deg[0] for a in deg) else deg
        if self.travel is not None:
            d["travel"] = travel_dict(self.travel)
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> UPSMechanism:
        """Inverse of :meth:`to_dict`. Required: ``base``, ``platform`` (6×3, mm); optional:
        ``v0``, ``lengths0``, ``stroke_limits`` (one ``[min, max]`` pair or six, mm),
        ``joint_angle_limits`` (degrees, one number or six, each in (0, 90)), ``travel``
        (``{"x_mm", "y_mm", "z_mm", "rx_deg", "ry_deg", "rz_deg"}``), ``units`` (must be ``"mm"``)."""
        check_file_header({"mechanism": cls.family, **d}, cls.family)  # called directly, the key may be absent
        check_keys(d, cls.family, _FILE_KEYS)
        missing = [k for k in ("base", "platform") if k not in d]
        if missing:
            raise ValueError(f"6-UPS geometry is missing {missing}: give 'base' and 'platform' (6x3, mm)")
        angle = d.get("joint_angle_limits", d.get("joint_angle_limit"))
        if angle is not None:
            a = _finite(angle, "joint_angle_limits")
            if a.shape not in ((), (N_LEGS,)):
                raise ValueError(f"6-UPS joint_angle_limits must be one number or six (degrees), got shape {a.shape}")
            if not np.all((a > 0) & (a < 90)):
                raise ValueError(
                    f"6-UPS joint_angle_limits must be in degrees, in (0, 90), got {a.tolist()}"
                )
            angle = np.deg2rad(a)
        travel = read_travel(d.get("travel"), cls.family)
        m = cls(
            d["base"],
            d["platform"],
            d.get("v0", (0.0, 0.0, 0.0)),
            d.get("lengths0"),
            stroke_limits=d.get("stroke_limits"),
            joint_angle_limit=angle,
            travel=travel,
        )
        check_layout(m)
        return m

    def file_warnings(self) -> None:
        warn_unit_slips(self)


class _Strut(NamedTuple):
    """One strut's quantities, on whatever the inputs of :func:`strut_leg` broadcast to: vectors
    as three components, scalars as one array."""

    tp: list[Array]  # T·platform_i
    strut: list[Array]  # s = T·platform_i + d + v0 − base_i
    length: Array  # l = |s| (mm)
    readings: Array  # q = l − lengths0_i (mm)
    margin: Array  # mm


def strut_leg(t, tm1, d, platform, e, lengths0, stroke_limits=None, angle_limit=None) -> _Strut:
    """The 6-UPS strut, written once: its reading and margin on components that broadcast
    against each other (poses by struts, or poses by population members).

    ``t[a][b]`` and ``tm1[a][b]``: the entries of ``T`` and of ``T − I`` (its diagonal from
    versines, :func:`_rotation_minus_identity`); ``d``: the translation; ``platform``: the joint
    ``platform_i``; ``e = platform_i + v0 − base_i``: the strut at the zero pose (three components
    each); ``lengths0``: the length at zero reading (mm). ``stroke_limits``: ``None`` or the
    reading's ``(min, max)`` (mm); ``angle_limit``: ``None`` or the largest joint angle (rad).
    Every caller derives from it: :meth:`UPSMechanism.solve_inverse_kinematics` (arrays of poses
    by struts), :meth:`UPSMechanism.population_squared_residuals` (poses by population members)
    and, through the mechanism, the 6-UPS discrepancy model.

    NOTE: the reading is evaluated cancellation-free. With ``δ = (T − I)·platform + d`` the
    moving joint's displacement the strut is ``s = e + δ`` and ``l² − |e|² = δ·(2e + δ)``, so
    ``q = δ·(2e + δ) / (l + |e|) + (|e| − lengths0)``: a reading of a few mm on a 1–3 m strut
    keeps full relative precision instead of being the difference of two metre-scale numbers,
    and is exactly 0 at the zero pose when ``lengths0`` is the default ``|e|``.
    """
    tp = [t[k][0] * platform[0] + t[k][1] * platform[1] + t[k][2] * platform[2] for k in range(3)]
    delta = [tm1[k][0] * platform[0] + tm1[k][1] * platform[1] + tm1[k][2] * platform[2] + d[k] for k in range(3)]
    e_len = _length(e)
    strut = [e[k] + delta[k] for k in range(3)]
    length = _length(strut)
    growth = [delta[k] * (2.0 * e[k] + delta[k]) for k in range(3)]
    rise = growth[0] + growth[1] + growth[2]  # l² − |e|²
    denom = length + e_len
    ok = denom > 0
    q = jnp.where(ok, rise / jnp.where(ok, denom, 1.0), length - e_len) + (e_len - lengths0)
    margins = []  # the strut's length where nothing limits it
    if stroke_limits is not None:
        margins += [q - stroke_limits[0], stroke_limits[1] - q]
    if angle_limit is not None:  # at the base end in B, at the platform end in A (Tᵀ·s)
        s_in_a = [t[0][j] * strut[0] + t[1][j] * strut[1] + t[2][j] * strut[2] for j in range(3)]
        theta = jnp.maximum(_angle(strut, e), _angle(s_in_a, e))
        margins.append(length * (angle_limit - theta))
    margin = length if not margins else functools.reduce(jnp.minimum, margins)
    return _Strut(tp, strut, length, q, margin)


class _IKParts(NamedTuple):
    rot: Array  # T, (..., 3, 3)
    tp: Array  # T·platform_i, (..., 6, 3)
    strut: Array  # s = T·p + d + v0 − b, (..., 6, 3)
    length: Array  # |s|, (..., 6)
    unit: Array  # s/|s|, (..., 6, 3)
    readings: Array  # (..., 6)
    margin: Array  # (..., 6)


def _rotation_minus_identity(angles: Array) -> Array:
    """``T − I`` without the cancellation of ``cos x − 1`` on the diagonal (versines)."""
    rot = rotation_matrix(angles)
    half = 0.5 * angles
    vf, vt, vp = (2.0 * jnp.sin(half[..., k]) ** 2 for k in range(3))  # 1 − cos
    sf, st, sp = (jnp.sin(angles[..., k]) for k in range(3))
    d00 = -(vp + vt - vp * vt)
    d11 = sp * st * sf - (vp + vf - vp * vf)
    d22 = -(vt + vf - vt * vf)
    diag = jnp.stack([d00, d11, d22], axis=-1)
    eye = jnp.eye(3, dtype=rot.dtype)
    return rot * (1.0 - eye) + diag[..., None] * eye


def _entries(r: Array) -> list[list[Array]]:
    """The entries ``r[a][b]`` of a batch of 3×3 matrices, each with a trailing axis of 1."""
    return [[r[..., a, b, None] for b in range(3)] for a in range(3)]


def _ik_parts(m: UPSMechanism, poses: Float[Array, "... 6"]) -> _IKParts:
    """:func:`strut_leg` on arrays, poses (any batch shape) by the six struts, its vectors stacked."""
    angles = poses[..., 3:]
    rot = rotation_matrix(angles)
    cols = lambda x: [x[..., k] for k in range(3)]  # noqa: E731
    limits = None if m.stroke_limits is None else np.asarray(m.stroke_limits).T  # (min, max) per strut
    angle = None if m.joint_angle_limit is None else np.asarray(m.joint_angle_limit)
    leg = strut_leg(_entries(rot), _entries(_rotation_minus_identity(angles)), [poses[..., k, None] for k in range(3)],
                    cols(m.platform), cols(m.platform + m.v0 - m.base), m.lengths0, limits, angle)
    stack = lambda v: jnp.stack(jnp.broadcast_arrays(*v), axis=-1)  # noqa: E731
    strut = stack(leg.strut)
    safe = jnp.where(leg.length > 0, leg.length, 1.0)
    return _IKParts(rot, stack(leg.tp), strut, leg.length, strut / safe[..., None], leg.readings, leg.margin)


def _angle(a: list[Array], b: list[Array]) -> Array:
    """Angle between vectors given as three components (rad), accurate near 0: ``atan2(|a × b|, a·b)``."""
    cross = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    return jnp.arctan2(_length(cross), a[0] * b[0] + a[1] * b[1] + a[2] * b[2])


def _length(v: list[Array]) -> Array:
    """``|v|`` of a vector given as three components."""
    return jnp.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


# ---- validation -------------------------------------------------------------------------------


def _as_float64(x: ArrayLike, name: str, shape: tuple[int, ...]) -> Array:
    return field_array(x, "UPSMechanism", name, shape, unit="mm")


def _finite(x: Any, name: str) -> np.ndarray:
    return field_numbers(x, "UPSMechanism", name)


def _stroke_limits(x: Any) -> tuple[tuple[float, float], ...] | None:
    if x is None:
        return None
    a = _finite(x, "stroke_limits")
    if a.shape == (2,):
        a = np.broadcast_to(a, (N_LEGS, 2))
    if a.shape != (N_LEGS, 2):
        raise ValueError(f"UPSMechanism.stroke_limits must be one [min, max] pair or six (mm), got shape {a.shape}")
    if not np.all(a[:, 0] < a[:, 1]):
        raise ValueError(f"UPSMechanism.stroke_limits must be ordered [min, max] with min < max, got {a.tolist()}")
    return tuple((float(lo), float(hi)) for lo, hi in a)


def _angle_limit(x: Any) -> tuple[float, ...] | None:
    if x is None:
        return None
    a = _finite(x, "joint_angle_limit")
    if a.shape == ():
        a = np.full(N_LEGS, float(a))
    if a.shape != (N_LEGS,):
        raise ValueError(f"UPSMechanism.joint_angle_limit must be one angle or six (rad), got shape {a.shape}")
    if not np.all((a > 0) & (a < np.pi / 2)):
        raise ValueError(
            f"UPSMechanism.joint_angle_limit must be in (0, π/2) rad (radians inside the library; "
            f"files give degrees), got {a.tolist()}"
        )
    return tuple(float(v) for v in a)


def _travel(x: Any) -> tuple[float, ...] | None:
    return None if x is None else field_travel(x, "UPSMechanism", ("x", "y", "z"), ("rx", "ry", "rz"))
