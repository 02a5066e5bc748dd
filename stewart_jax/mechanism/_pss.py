"""The 6-PSS Stewart mechanism: six vertical sliders, each carrying a fixed-length rod.

Wang H., Cao X. et al., "Improved cuckoo calibration method of space telescope secondary mirror
adjusting mechanism", Infrared and Laser Engineering 47(5), 2018, §1.1–1.2: leg vector (eq. 2),
inverse kinematics (eq. 4), the 36 calibration parameters, Table 1 (the nominal and "actual"
joint centres used by the simulation study).

The 36 parameters are the joint centres: the upper (moving-platform) spherical joints ``Ac_i``
in frame A and the lower spherical joints ``Bc_i`` in frame B at zero slider stroke. The rod
lengths are not parameters: they follow from the zero pose, ``L_i = |Ac_i + v0 - Bc_i|`` (§1.2).
Slider i moves the lower joint to ``Bc_i + q_i·e_z``. Units: mm.
"""

from __future__ import annotations

from typing import Any, ClassVar, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._math import rotation_matrix
from ._abstract import AbstractMechanism, IKSolution
from ._registry import check_file_header, register_family, register_preset

N_LEGS = 6
N_PARAMS = 36


@register_family
class PSSMechanism(AbstractMechanism):
    """The 6-PSS mechanism of Wang et al. (2018): joint centres in mm.

    A pytree: batch it (``jax.vmap`` over a leading axis of every leaf) to evaluate many
    parameter sets at once.

    **Fields:**

    - ``upper``: ``Float[Array, "6 3"]``, upper joint centres ``Ac_i`` in the moving frame A.
    - ``lower``: ``Float[Array, "6 3"]``, lower joint centres ``Bc_i`` in the fixed frame B at
      zero slider stroke.
    - ``v0``: ``Float[Array, "3"]``, position of A's origin in B at the zero pose (the paper
      gives no value, the default is the origin).
    """

    family: ClassVar[str] = "6-PSS"

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

    @property
    def param_names(self) -> tuple[str, ...]:
        return tuple(f"{side}{i}{c}" for side in ("Ac", "Bc") for i in range(1, 7) for c in "xyz")

    @classmethod
    def from_params(cls, params: ArrayLike, v0: ArrayLike = (0.0, 0.0, 0.0)) -> PSSMechanism:
        """Build a geometry from the 36-vector of :attr:`params`."""
        return geometry_from_params(params, v0)

    @property
    def leg_parameters(self) -> tuple[tuple[int, ...], ...]:
        """Leg i's stroke depends on ``Ac_i`` and ``Bc_i`` only (eq. 4; ``L_i`` from the zero pose)."""
        return tuple((3 * i, 3 * i + 1, 3 * i + 2, 18 + 3 * i, 19 + 3 * i, 20 + 3 * i) for i in range(N_LEGS))

    @property
    def travel_half_widths(self) -> np.ndarray:
        """Wang et al. (2018) §4: ±1 mm and ±1° on every pose component."""
        return np.array([1.0, 1.0, 1.0] + [float(np.deg2rad(1.0))] * 3)

    def tracker_layout(self) -> tuple[float, float]:
        """The paper gives no ball layout; ours: 100 mm from A's z axis, 90 mm above its origin."""
        return (100.0, 90.0)

    def with_params(self, params: Float[Array, "36"]) -> PSSMechanism:
        return geometry_from_params(params, self.v0)

    def moving_joints(self, poses: Float[Array, "... 6"]) -> Float[Array, "... 6 3"]:
        """``a_i = T·Ac_i + d + v0``: the upper joint centres in B (eq. 2)."""
        rot = rotation_matrix(poses[..., 3:])
        return jnp.einsum("...jk,ik->...ij", rot, self.upper) + poses[..., None, :3] + self.v0

    def solve_inverse_kinematics(self, poses: Float[Array, "... 6"]) -> IKSolution:
        """Inverse kinematics (eq. 4) with its reachability margin; pure and jittable.

        ``q_i = a_iz − Bc_iz − sqrt(L_i² − (Bc_ix − a_ix)² − (Bc_iy − a_iy)²)``, the root with
        the slider below the upper joint; ``margin`` is the square-root argument (mm²).
        ``poses`` may have any leading batch shape; batch over geometries with ``jax.vmap``.

        NOTE: eq. 4 is evaluated in a cancellation-free form. With ``e_i = Ac_i + v0 − Bc_i``
        the zero-pose leg and ``δ_i = T·Ac_i − Ac_i + d`` the joint's displacement,
        ``L² − ℓx² − ℓy² = e_z² − δx(2e_x + δx) − δy(2e_y + δy)`` and, rationalising
        ``q = ℓz − sqrt(m)``, ``q = Σ_k δ_k(2e_k + δ_k) / (ℓz + sqrt(m))``. Strokes of a few mm
        then keep full relative precision instead of being the difference of two ~200 mm
        numbers, and ``q`` is exactly 0 at the zero pose for any geometry.
        """
        parts = _ik_parts(self, poses)
        return IKSolution(parts.strokes, parts.margin, jnp.all(parts.margin >= 0.0, axis=-1))

    def ik_and_jacobian(self, poses: Float[Array, "... 6"]):
        """Strokes, margins (``(..., 6)``) and the analytic Jacobian ``∂q_i/∂P_k`` (``(..., 6, 6)``).

        With the rod vector at zero stroke ``ℓ = T·Ac + d + v0 − Bc`` and ``h = sqrt(m)`` its
        z-extent once the slider has moved, ``q = ℓz − h`` gives ``∂q = ∂ℓz + (ℓx·∂ℓx + ℓy·∂ℓy)/h``
        with ``∂ℓ/∂d = I``, ``∂ℓ/∂φ = T·(e_x × Ac)``, ``∂ℓ/∂θ = (Rz(ψ)·e_y) × T·Ac`` and
        ``∂ℓ/∂ψ = e_z × T·Ac``.
        """
        parts = _ik_parts(self, poses)
        rot, w, ell, h = parts.rot, parts.w, parts.ell, parts.root
        upper = self.upper
        ax, ay = ell[..., 0] / h, ell[..., 1] / h  # ∂q/∂dx, ∂q/∂dy
        dphi = -upper[:, 2:3] * rot[..., None, :, 1] + upper[:, 1:2] * rot[..., None, :, 2]
        sp, cp = jnp.sin(poses[..., 5:6]), jnp.cos(poses[..., 5:6])
        wx, wy, wz = w[..., 0], w[..., 1], w[..., 2]
        jac = jnp.stack(
            [
                ax,
                ay,
                jnp.ones_like(ax),
                dphi[..., 2] + ax * dphi[..., 0] + ay * dphi[..., 1],
                -sp * wy - cp * wx + (ax * cp + ay * sp) * wz,
                ay * wx - ax * wy,
            ],
            axis=-1,
        )
        return parts.strokes, parts.margin, jac

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> PSSMechanism:
        return geometry_from_dict(d)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (mm)."""
        return {
            "mechanism": self.family,
            "units": "mm",
            "upper": np.asarray(self.upper).tolist(),
            "lower": np.asarray(self.lower).tolist(),
            "v0": np.asarray(self.v0).tolist(),
        }


Geometry = PSSMechanism
"""The 6-PSS mechanism under its original name."""


class _IKParts(NamedTuple):
    rot: Array  # T, (..., 3, 3)
    w: Array  # T·Ac_i, (..., 6, 3)
    ell: Array  # rod vector at zero stroke, T·Ac_i + d + v0 − Bc_i, (..., 6, 3)
    growth: Array  # δ(2e + δ), (..., 6, 3)
    margin: Array  # (..., 6)
    root: Array  # sqrt(max(margin, 0)), (..., 6)
    strokes: Array  # (..., 6)


def _ik_parts(geometry: PSSMechanism, poses: Float[Array, "... 6"]) -> _IKParts:
    rot = rotation_matrix(poses[..., 3:])
    upper = geometry.upper
    w = jnp.einsum("...jk,ik->...ij", rot, upper)
    delta = w - upper + poses[..., None, :3]
    e = upper + geometry.v0 - geometry.lower
    growth = delta * (2.0 * e + delta)
    margin = e[:, 2] ** 2 - growth[..., 0] - growth[..., 1]
    root = jnp.sqrt(jnp.maximum(margin, 0.0))
    ell = e + delta
    denom = ell[..., 2] + root
    rationalised = jnp.sum(growth, axis=-1) / jnp.where(denom > 0, denom, 1.0)
    strokes = jnp.where(denom > 0, rationalised, ell[..., 2] - root)
    return _IKParts(rot, w, ell, growth, margin, root, strokes)


def geometry_from_params(params: Float[Array, "36"], v0: ArrayLike = (0.0, 0.0, 0.0)) -> PSSMechanism:
    """A 6-PSS mechanism from the 36-vector of :attr:`PSSMechanism.params` (order ``Ac_1..Ac_6`` then
    ``Bc_1..Bc_6``, each x, y, z); traceable, vmap it over ``params``."""
    p = jnp.asarray(params, dtype=jnp.float64)
    if p.shape[-1:] != (N_PARAMS,):
        raise ValueError(f"params must have a last axis of 36, got shape {p.shape}")
    batch = p.shape[:-1]
    return PSSMechanism(p[..., :18].reshape(*batch, N_LEGS, 3), p[..., 18:].reshape(*batch, N_LEGS, 3), v0)


def rod_lengths(geometry: PSSMechanism) -> Float[Array, "6"]:
    """``L_i = |Ac_i + v0 - Bc_i|`` (Wang et al. 2018, §1.2)."""
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


# Wang et al. (2018), Table 1 (mm). Rows: rod 1..6.
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

@register_preset("nominal")
def nominal_geometry(v0: ArrayLike = (0.0, 0.0, 0.0)) -> PSSMechanism:
    """The nominal parameters ``u_0`` of Wang et al. (2018), Table 1."""
    return PSSMechanism(_NOMINAL_UPPER, _NOMINAL_LOWER, v0)


@register_preset("actual")
def actual_geometry(v0: ArrayLike = (0.0, 0.0, 0.0)) -> PSSMechanism:
    """The "true" parameters ``u_a`` of Wang et al. (2018), Table 1, used by the simulation study."""
    return PSSMechanism(_ACTUAL_UPPER, _ACTUAL_LOWER, v0)


def geometry_from_dict(d: dict[str, Any]) -> PSSMechanism:
    """Inverse of :meth:`PSSMechanism.to_dict`. Accepts either ``upper``/``lower`` (6×3 each) or
    ``params`` (36 numbers, order ``Ac_1..Ac_6, Bc_1..Bc_6``); ``v0`` optional; lengths in mm."""
    check_file_header(d, PSSMechanism.family)
    v0 = d.get("v0", (0.0, 0.0, 0.0))
    if "params" in d:
        p = np.asarray(d["params"], dtype=np.float64)
        if p.shape != (N_PARAMS,):
            raise ValueError(f"geometry 'params' must hold 36 numbers, got shape {p.shape}")
        return PSSMechanism(p[:18].reshape(6, 3), p[18:].reshape(6, 3), v0)
    missing = [k for k in ("upper", "lower") if k not in d]
    if missing:
        raise ValueError(f"geometry is missing {missing}: give 'upper' and 'lower' (6x3, mm) or 'params' (36)")
    return PSSMechanism(d["upper"], d["lower"], v0)
