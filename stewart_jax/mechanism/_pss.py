"""The 6-PSS Stewart mechanism: six sliders, each carrying a fixed-length rod.

Wang H., Cao X. et al., "Improved cuckoo calibration method of space telescope secondary mirror
adjusting mechanism", Infrared and Laser Engineering 47(5), 2018, §1.1–1.2: leg vector (eq. 2),
inverse kinematics (eq. 4), the 36 calibration parameters, Table 1 (the nominal and "actual"
joint centres used by the simulation study).

The paper's mechanism: the 36 parameters are the joint centres, the upper (moving-platform)
spherical joints ``Ac_i`` in frame A and the lower spherical joints ``Bc_i`` in frame B at zero
slider stroke. The rod lengths are not parameters: they follow from the zero pose,
``L_i = |Ac_i + v0 - Bc_i|`` (§1.2). Slider i moves the lower joint to ``Bc_i + q_i·e_z``.

Generalised (beyond the paper): slider i moves along an arbitrary unit axis ``n_i`` in B and the
rod lengths may be given. With ``w_i = T·Ac_i + d + v0 − Bc_i`` the rod vector at zero stroke,
``|w_i − q_i·n_i| = L_i`` gives ``q_i = w_i·n_i − sqrt(L_i² − |w_i|² + (w_i·n_i)²)``, eq. 4 for
``n_i = e_z``. Three calibration parameter sets: ``"36"`` (the paper's), ``"42"`` (+ the six rod
lengths) and ``"54"`` (+ two tilt angles per slider axis, in mrad, so that Ω's ± half-width in
mm reads as ± the same number of mrad). Units: mm.

The leg is written once, :func:`slider_leg`, on components that broadcast against each other:
the inverse kinematics and its closed-form Jacobians call it on arrays (poses by legs), the
population objective on structure-of-arrays columns (poses by population members, every parameter
set), the fast path of ``_batched.py`` on rows of poses, the discrepancy model with its per-pose
rod lengths and tilted axes.
"""

from __future__ import annotations

from typing import Any, ClassVar, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float

from .._checks import field_array, field_numpy, on_host, to_device, valid_poses
from .._math import rotation_matrix
from ._abstract import AbstractMechanism, IKSolution, dense_parameter_jacobian, population_totals
from ._pss_table1 import ACTUAL_LOWER, ACTUAL_UPPER, NOMINAL_LOWER, NOMINAL_UPPER
from ._registry import check_file_header, check_keys, register_family, register_preset

N_LEGS = 6
N_PARAMS = 36
PARAM_SETS = ("36", "42", "54")
"""The 6-PSS calibration parameter sets: the paper's joint centres; + rod lengths; + axis tilts."""
MRAD = 1e-3


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
    - ``axes``: ``Float[Array, "6 3"] | None``, unit slider axes ``n_i`` in B (the reference the
      tilts of the 54-parameter set rotate); ``None``: ``e_z`` for every leg, the paper's.
    - ``lengths``: ``Float[Array, "6"] | None``, rod lengths (mm); ``None``: ``|Ac_i + v0 − Bc_i|``,
      i.e. zero stroke at the zero pose, following the joint centres (the paper's).
    - ``tilt``: ``Float[Array, "12"] | None``, the 54-parameter set's axis tilts
      ``[α_1..α_6, β_1..β_6]`` (mrad): the slider moves along
      ``cos α·cos β·n + cos α·sin β·u − sin α·v`` with ``(u, v, n)`` a right-handed frame of the
      reference axis (``u = e_x``, ``v = e_y`` for ``n = e_z``, i.e. ``Ry(β)·Rx(α)·e_z``).
    - ``param_set``: ``"36"``, ``"42"`` or ``"54"`` (static): which of the above are calibrated.

    With ``axes``, ``lengths`` and ``tilt`` all ``None`` the mechanism is the paper's and its
    readings are computed exactly as before the generalisation (eq. 4, cancellation-free).
    """

    family: ClassVar[str] = "6-PSS"
    reading_unit: ClassVar[str] = "mm"
    param_sets: ClassVar[tuple[str, ...]] = PARAM_SETS

    upper: Float[Array, "6 3"]
    lower: Float[Array, "6 3"]
    v0: Float[Array, "3"]
    axes: Float[Array, "6 3"] | None
    lengths: Float[Array, "6"] | None
    tilt: Float[Array, "12"] | None
    param_set: str = eqx.field(static=True)

    def __init__(
        self,
        upper: ArrayLike,
        lower: ArrayLike,
        v0: ArrayLike = (0.0, 0.0, 0.0),
        *,
        axes: ArrayLike | None = None,
        rod_lengths: ArrayLike | None = None,
        tilt: ArrayLike | None = None,
        param_set: str = "36",
    ):
        if param_set not in PARAM_SETS:
            raise ValueError(f"6-PSS param_set must be one of {PARAM_SETS}, got {param_set!r}")
        self.upper = _as_float64(upper, "upper", (N_LEGS, 3))
        self.lower = _as_float64(lower, "lower", (N_LEGS, 3))
        self.v0 = _as_float64(v0, "v0", (3,))
        self.axes = None if axes is None else _unit_axes(axes)
        if rod_lengths is None and param_set != "36":
            rod_lengths = jnp.linalg.norm(self.upper + self.v0 - self.lower, axis=-1)
        self.lengths = None if rod_lengths is None else _positive(rod_lengths, "rod_lengths")
        if tilt is None and param_set == "54":
            tilt = jnp.zeros(2 * N_LEGS)
        self.tilt = None if tilt is None else field_array(tilt, "PSSMechanism", "tilt", (2 * N_LEGS,), unit="mrad")
        self.param_set = param_set

    @property
    def is_paper_model(self) -> bool:
        """Vertical sliders and rod lengths from the zero pose: Wang et al. (2018)'s mechanism."""
        return self.axes is None and self.lengths is None and self.tilt is None

    @property
    def slider_axes(self) -> Float[Array, "6 3"]:
        """The unit slider axes in B after the tilts (``e_z`` for the paper's mechanism)."""
        ref = jnp.broadcast_to(jnp.array([0.0, 0.0, 1.0]), (N_LEGS, 3)) if self.axes is None else self.axes
        if self.tilt is None:
            return ref
        return _tilted(ref, self.tilt * MRAD)

    @property
    def params(self) -> Float[Array, " n"]:
        """The calibration parameters: ``Ac_1..Ac_6`` then ``Bc_1..Bc_6`` (each x, y, z, mm) —
        the paper's 36; then, for the ``"42"`` and ``"54"`` sets, the six rod lengths (mm); then,
        for ``"54"``, the axis tilts ``α_1..α_6, β_1..β_6`` (mrad)."""
        batch = self.upper.shape[:-2]
        xp, (upper, lower, lengths, tilt) = on_host(self.upper, self.lower, self.lengths, self.tilt)
        parts = [xp.reshape(upper, (*batch, 18)), xp.reshape(lower, (*batch, 18))]
        if self.param_set != "36":
            parts.append(lengths)
        if self.param_set == "54":
            parts.append(tilt)
        return to_device(xp.concatenate(parts, axis=-1))

    @property
    def rod_lengths(self) -> Float[Array, "6"]:
        """Rod lengths ``L_i`` (mm): the given ones, or ``|Ac_i + v0 - Bc_i|`` (zero stroke at the
        zero pose)."""
        return rod_lengths(self)

    @property
    def params_label(self) -> str:
        return f"{self.family} ({self.param_set}-parameter set)"

    @property
    def param_units(self) -> tuple[str, ...]:
        """mm for the joint centres and rod lengths, mrad for the 54-parameter set's tilts."""
        return ("mm",) * (36 if self.param_set == "36" else 42) + ("mrad",) * (12 if self.param_set == "54" else 0)

    @property
    def param_names(self) -> tuple[str, ...]:
        names = [f"{side}{i}{c}" for side in ("Ac", "Bc") for i in range(1, 7) for c in "xyz"]
        if self.param_set != "36":
            names += [f"L{i}" for i in range(1, 7)]
        if self.param_set == "54":
            names += [f"{a}{i}" for a in ("alpha", "beta") for i in range(1, 7)]
        return tuple(names)

    @classmethod
    def from_params(cls, params: ArrayLike, v0: ArrayLike = (0.0, 0.0, 0.0)) -> PSSMechanism:
        """Build a geometry from the 36-vector of :attr:`params`."""
        return geometry_from_params(params, v0)

    def with_param_set(self, param_set: str) -> PSSMechanism:
        """The same mechanism calibrated with another parameter set (``"36"``, ``"42"``, ``"54"``).

        Going to a larger set fixes the current rod lengths and axes as the starting values
        (tilts 0); going back to ``"36"`` keeps them fixed (not calibrated)."""
        if param_set not in PARAM_SETS:
            raise ValueError(f"6-PSS param_set must be one of {PARAM_SETS}, got {param_set!r}")
        if param_set == self.param_set:
            return self
        axes = None if self.axes is None and self.tilt is None else self.slider_axes
        return PSSMechanism(self.upper, self.lower, self.v0, axes=axes, rod_lengths=self.lengths,
                            param_set=param_set)

    @property
    def leg_parameters(self) -> tuple[tuple[int, ...], ...]:
        """Leg i's stroke depends on ``Ac_i`` and ``Bc_i`` only (eq. 4; ``L_i`` from the zero pose),
        and on its own rod length and axis tilts in the larger parameter sets."""
        extra = {"36": lambda i: (), "42": lambda i: (36 + i,), "54": lambda i: (36 + i, 42 + i, 48 + i)}
        return tuple((3 * i, 3 * i + 1, 3 * i + 2, 18 + 3 * i, 19 + 3 * i, 20 + 3 * i) + extra[self.param_set](i)
                     for i in range(N_LEGS))

    @property
    def travel_half_widths(self) -> np.ndarray:
        """Wang et al. (2018) §4: ±1 mm and ±1° on every pose component."""
        return np.array([1.0, 1.0, 1.0] + [float(np.deg2rad(1.0))] * 3)

    def tracker_layout(self) -> tuple[float, float]:
        """The paper gives no ball layout; ours: 100 mm from A's z axis, 90 mm above its origin."""
        return (100.0, 90.0)

    def with_params(self, params: Float[Array, " n"]) -> PSSMechanism:
        p = self.checked_params(params)
        batch = p.shape[:-1]
        lengths = self.lengths if self.param_set == "36" else p[..., 36:42]
        tilt = p[..., 42:54] if self.param_set == "54" else self.tilt
        return PSSMechanism(p[..., :18].reshape(*batch, N_LEGS, 3), p[..., 18:36].reshape(*batch, N_LEGS, 3),
                            self.v0, axes=self.axes, rod_lengths=lengths, tilt=tilt, param_set=self.param_set)

    @property
    def n_params(self) -> int:
        return {"36": 36, "42": 42, "54": 54}[self.param_set]

    def moving_joints(self, poses: Float[Array, "... 6"]) -> Float[Array, "... 6 3"]:
        """``a_i = T·Ac_i + d + v0``: the upper joint centres in B (eq. 2)."""
        rot = rotation_matrix(poses[..., 3:])
        return jnp.einsum("...jk,ik->...ij", rot, self.upper) + poses[..., None, :3] + self.v0

    def solve_inverse_kinematics(self, poses: Float[Array, "... 6"]) -> IKSolution:
        """Inverse kinematics (eq. 4) with its reachability margin; pure and jittable.

        ``q_i = a_iz − Bc_iz − sqrt(L_i² − (Bc_ix − a_ix)² − (Bc_iy − a_iy)²)``, the root with
        the slider below the upper joint; ``margin`` is the square-root argument (mm²).
        ``poses`` may have any leading batch shape; batch over geometries with ``jax.vmap``.

        Evaluated cancellation-free by the leg :func:`slider_leg`: with ``e_i = Ac_i + v0 − Bc_i``
        the zero-pose leg and ``δ_i = T·Ac_i − Ac_i + d`` the joint's displacement,
        ``L² − ℓx² − ℓy² = e_z² − δx(2e_x + δx) − δy(2e_y + δy)`` and, rationalising
        ``q = ℓz − sqrt(m)``, ``q = Σ_k δ_k(2e_k + δ_k) / (ℓz + sqrt(m))``; ``q`` is exactly 0 at
        the zero pose for any geometry. The generalised mechanism (slider axes ``n``, rod lengths
        ``L``): ``q = c / (n·ℓ + sqrt((n·ℓ)² − c))`` with ``c = δ·(2e + δ) − ΔL·(2|e| + ΔL)``,
        ``ΔL = L − |e|``; the margin is ``(n·ℓ)² − c``.
        """
        parts = _ik_parts(self, poses)
        return IKSolution(parts.readings, parts.margin, jnp.all(parts.margin >= 0.0, axis=-1) & valid_poses(poses))

    def ik_and_jacobian(self, poses: Float[Array, "... 6"]):
        """Strokes, margins (``(..., 6)``) and the analytic Jacobian ``∂q_i/∂P_k`` (``(..., 6, 6)``).

        With the rod vector at zero stroke ``ℓ = T·Ac + d + v0 − Bc`` and ``h = sqrt(m)`` its
        z-extent once the slider has moved, ``q = ℓz − h`` gives ``∂q = ∂ℓz + (ℓx·∂ℓx + ℓy·∂ℓy)/h``
        with ``∂ℓ/∂d = I``, ``∂ℓ/∂φ = T·(e_x × Ac)``, ``∂ℓ/∂θ = (Rz(ψ)·e_y) × T·Ac`` and
        ``∂ℓ/∂ψ = e_z × T·Ac``.

        For general slider axes ``n`` the same derivatives of ``w = ℓ`` enter through
        ``∂q = g·∂w`` with ``g = n + (w − (n·w)·n)/h``, ``h = sqrt(margin)``.
        """
        if not self.is_paper_model:
            return _general_ik_and_jacobian(self, poses)
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
        return parts.readings, parts.margin, jac

    def parameter_jacobian(self, poses: Float[Array, "m 6"]) -> Float[Array, "6m n"]:
        """``∂q/∂u`` (row ``6j + i`` is leg ``i`` at pose ``j``); closed form for the paper's
        36 parameters (:meth:`leg_parameter_jacobian`), forward-mode AD for the 42 and 54 sets."""
        if not self.is_paper_model:
            return super().parameter_jacobian(poses)
        return dense_parameter_jacobian(self.leg_parameter_jacobian(poses), self.leg_parameters, self.n_params)

    @property
    def has_closed_form_parameter_jacobian(self) -> bool:
        """Closed form for the paper's mechanism only (the 42 and 54 sets use AD)."""
        return self.is_paper_model

    def leg_parameter_jacobian(self, poses: Float[Array, "m 6"]) -> Float[Array, "6 m k"]:
        """Per leg ``i``, ``∂q_i/∂(Ac_i, Bc_i)`` at each pose (``(6, m, 6)``, columns in
        :attr:`leg_parameters` order); closed form for the paper's 36 parameters, cut from the
        AD Jacobian for the 42 and 54 sets.

        With ``e = Ac + v0 − Bc`` (the zero-pose rod, whose length ``|e|`` the rod keeps), ``ℓ``
        and ``h`` as in :meth:`ik_and_jacobian` and ``g = (ℓx/h, ℓy/h, 1)``, eq. 4 reads
        ``q = ℓz − sqrt(|e|² − ℓx² − ℓy²)``, so ``∂q/∂Bc = −(g − e/h)`` and
        ``∂q/∂Ac = gᵀ·T − eᵀ/h = gᵀ·(T − I) + (g − e/h)ᵀ``.

        NOTE: ``g − e/h`` vanishes at the zero pose (``q ≡ 0`` there for every geometry) and is
        formed without cancellation: ``(δx/h, δy/h, −(γx + γy)/(h·(h + e_z)))`` with ``δ = ℓ − e``
        and ``γ = δ(2e + δ)`` the growth terms of the IK, since ``h² − e_z² = −γx − γy``.
        """
        if not self.is_paper_model:
            return super().leg_parameter_jacobian(poses)
        parts = _ik_parts(self, poses)
        ell, h, growth = parts.ell, parts.root, parts.growth  # (m, 6, 3), (m, 6), (m, 6, 3)
        e = self.upper + self.v0 - self.lower
        delta = ell - e
        g = jnp.stack([ell[..., 0] / h, ell[..., 1] / h, jnp.ones_like(h)], axis=-1)
        g_minus = jnp.stack([delta[..., 0] / h, delta[..., 1] / h,
                             -(growth[..., 0] + growth[..., 1]) / (h * (h + e[:, 2]))], axis=-1)
        rot_minus_eye = parts.rot - jnp.eye(3)  # (m, 3, 3)
        d_upper = jnp.einsum("mij,mjk->mik", g, rot_minus_eye) + g_minus  # (m, 6, 3)
        return jnp.moveaxis(jnp.concatenate([d_upper, -g_minus], axis=-1), 0, 1)

    def population_squared_residuals(
        self, params: Float[Array, "n p"], poses: Float[Array, "m 6"], readings: Float[Array, "m 6"]
    ) -> tuple[Float[Array, " n"], Bool[Array, " n"]]:
        """``Σ (readings − q(poses; u))²`` and reachability for every row ``u`` of ``params``
        (:meth:`AbstractMechanism.population_squared_residuals`), every parameter set, in
        structure-of-arrays form: :func:`slider_leg` on ``(m, n)`` arrays.

        NOTE: under ``vmap`` over the population the per-member IK runs on ``(n, m, 6, 3)``
        arrays whose innermost axis (x, y, z) is too short for the vector units, and the
        rotation ``T·Ac`` and the sums become small library calls per nest. Here every
        quantity is an ``(m, n)`` array, pose by row and the population innermost, built from
        the rotation entries (computed once for the ``m`` poses) by explicit multiply-adds, and
        the six legs are summed in registers: 2–5× faster for 37–370 nests.
        """
        u = jnp.asarray(params, jnp.float64).T  # (n_params, n)
        rot = rotation_matrix(poses[:, 3:])
        t = [[rot[:, a, b, None] for b in range(3)] for a in range(3)]  # (m, 1) each
        d = [poses[:, k, None] for k in range(3)]
        if self.param_set == "54":  # each member's axes from its tilts, (n, 6, 3)
            ref = jnp.broadcast_to(jnp.array([0.0, 0.0, 1.0]), (N_LEGS, 3)) if self.axes is None else self.axes
            axes = _tilted(ref, u[42:54].T * MRAD)
        else:
            axes = None if self.is_paper_model else self.slider_axes

        def leg(i):
            upper = [u[3 * i + k] for k in range(3)]  # Ac_i, (n,) each
            e = [upper[k] + self.v0[k] - u[18 + 3 * i + k] for k in range(3)]
            rod = u[36 + i] if self.param_set != "36" else None if self.lengths is None else self.lengths[i]
            out = slider_leg(t, d, upper, e, None if axes is None else [axes[..., i, k] for k in range(3)],
                             None if rod is None else rod - _length(e))
            return out.readings, out.margin

        return population_totals(readings, poses, (leg(i) for i in range(N_LEGS)))

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> PSSMechanism:
        return geometry_from_dict(d)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (mm): ``axes`` (after the tilts) and ``rod_lengths`` only where they
        differ from the paper's defaults, ``param_set`` where it is not the default the file's
        keys imply."""
        d: dict[str, Any] = {
            "mechanism": self.family,
            "units": "mm",
            "upper": np.asarray(self.upper).tolist(),
            "lower": np.asarray(self.lower).tolist(),
            "v0": np.asarray(self.v0).tolist(),
        }
        if self.axes is not None or self.tilt is not None:
            d["axes"] = np.asarray(self.slider_axes).tolist()
        if self.lengths is not None:
            d["rod_lengths"] = np.asarray(self.lengths).tolist()
        if self.param_set != _default_param_set(d):
            d["param_set"] = self.param_set
        return d


Geometry = PSSMechanism
"""The 6-PSS mechanism under its original name."""


class _Leg(NamedTuple):
    """One 6-PSS leg's quantities, on whatever the inputs of :func:`slider_leg` broadcast to:
    vectors as three components, scalars as one array."""

    w: list[Array]  # T·Ac_i
    ell: list[Array]  # the rod vector at zero stroke, ℓ = T·Ac_i + d + v0 − Bc_i = e + δ
    growth: list[Array]  # γ = δ(2e + δ), δ = T·Ac_i − Ac_i + d
    margin: Array  # the square-root argument (mm²)
    root: Array  # sqrt(max(margin, 0))
    readings: Array


def slider_leg(t, d, upper, e, axis=None, dlength=None) -> _Leg:
    """The 6-PSS leg, written once: the inverse kinematics of one slider, on components that
    broadcast against each other (poses by legs, rows of poses in the structure-of-arrays fast
    path, poses by population members, or scalars).

    ``t[a][b]``: the rotation's entries; ``d``: the translation; ``upper``: the joint ``Ac_i``;
    ``e = Ac_i + v0 − Bc_i``: the rod at the zero pose (three components each). ``axis``: the
    slider's unit axis ``n_i`` (three components), or ``None`` for the paper's vertical slider;
    ``dlength``: how much longer the rod is than ``|e|`` (``None``: exactly ``|e|``, the paper's
    rods), only with an ``axis``. Returns the stroke with its margin and the intermediates the
    closed-form Jacobians reuse. Every caller derives from it:
    :meth:`PSSMechanism.solve_inverse_kinematics` (arrays of poses by legs),
    :meth:`PSSMechanism.population_squared_residuals` (poses by population members), the
    structure-of-arrays fast path and the 6-PSS discrepancy model (per-pose rod lengths).

    NOTE: cancellation-free. With ``δ = T·Ac − Ac + d``, ``ℓ = e + δ`` and
    ``c = |ℓ|² − L² = δ·(2e + δ) − ΔL·(2|e| + ΔL)``, ``|ℓ − q·n| = L`` has the root
    ``q = c / (n·ℓ + sqrt((n·ℓ)² − c))``: a stroke of a few mm keeps full relative precision
    instead of being the difference of two ~200 mm numbers, and is exactly 0 at the zero pose.
    For the paper's slider (``n = e_z``, ``ΔL = 0``, Wang et al. (2018) eq. 4) the margin is
    formed as ``e_z² − γx − γy`` (``= L² − ℓx² − ℓy²``) without the ``ℓz² − γz`` of the general
    form. Where ``n·ℓ + sqrt(margin) ≤ 0`` (the rod below the slider) the plain
    ``n·ℓ − sqrt(margin)`` is returned.
    """
    w = [t[k][0] * upper[0] + t[k][1] * upper[1] + t[k][2] * upper[2] for k in range(3)]
    delta = [w[k] - upper[k] + d[k] for k in range(3)]
    growth = [delta[k] * (2.0 * e[k] + delta[k]) for k in range(3)]
    ell = [e[k] + delta[k] for k in range(3)]
    c = growth[0] + growth[1] + growth[2]
    if axis is None:
        if dlength is not None:
            raise ValueError("slider_leg: a rod length change needs the slider axis (the paper's rods are |e|)")
        nw = ell[2]
        margin = e[2] * e[2] - growth[0] - growth[1]
    else:
        if dlength is not None:
            c = c - dlength * (2.0 * _length(e) + dlength)
        nw = axis[0] * ell[0] + axis[1] * ell[1] + axis[2] * ell[2]
        margin = nw * nw - c
    root = jnp.sqrt(jnp.maximum(margin, 0.0))
    denom = nw + root
    ok = denom > 0
    return _Leg(w, ell, growth, margin, root, jnp.where(ok, c / jnp.where(ok, denom, 1.0), nw - root))


def _length(v: list[Array]) -> Array:
    """``|v|`` of a vector given as three components."""
    return jnp.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


class _IKParts(NamedTuple):
    rot: Array  # T, (..., 3, 3)
    w: Array  # T·Ac_i, (..., 6, 3)
    ell: Array  # rod vector at zero stroke, T·Ac_i + d + v0 − Bc_i, (..., 6, 3)
    growth: Array  # δ(2e + δ), (..., 6, 3)
    axes: Array  # unit slider axes n_i, (..., 6, 3)
    margin: Array  # (..., 6)
    root: Array  # sqrt(max(margin, 0)), (..., 6)
    readings: Array  # (..., 6)


def slider_leg_arrays(
    poses: Float[Array, "... 6"],
    upper: Float[Array, "6 3"],
    e: Float[Array, "6 3"],
    axes: Float[Array, "6 3"] | None = None,
    dlength: Float[Array, "... 6"] | None = None,
) -> _IKParts:
    """:func:`slider_leg` on arrays, poses (any batch shape) by the six legs, its vectors stacked
    to ``(..., 6, 3)``; ``axes`` ``None`` is the paper's vertical slider."""
    rot = rotation_matrix(poses[..., 3:])
    t = [[rot[..., a, b, None] for b in range(3)] for a in range(3)]  # (..., 1) each
    d = [poses[..., k, None] for k in range(3)]
    cols = lambda x: [x[..., k] for k in range(3)]  # noqa: E731
    leg = slider_leg(t, d, cols(upper), cols(e), None if axes is None else cols(axes), dlength)
    stack = lambda v: jnp.stack(jnp.broadcast_arrays(*v), axis=-1)  # noqa: E731
    ell = stack(leg.ell)
    n = jnp.array([0.0, 0.0, 1.0]) if axes is None else axes
    return _IKParts(rot, stack(leg.w), ell, stack(leg.growth), jnp.broadcast_to(n, ell.shape), leg.margin, leg.root,
                    leg.readings)


def _ik_parts(geometry: PSSMechanism, poses: Float[Array, "... 6"]) -> _IKParts:
    """The mechanism's legs at ``poses``: the paper's eq. 4, or the general slider (axes, rod lengths)."""
    e = geometry.upper + geometry.v0 - geometry.lower
    if geometry.is_paper_model:
        return slider_leg_arrays(poses, geometry.upper, e)
    dl = None if geometry.lengths is None else geometry.lengths - _length([e[..., k] for k in range(3)])
    return slider_leg_arrays(poses, geometry.upper, e, geometry.slider_axes, dl)


def _general_ik_and_jacobian(geometry: PSSMechanism, poses: Float[Array, "... 6"]):
    parts = _ik_parts(geometry, poses)
    n, ell, tp = parts.axes, parts.ell, parts.w
    nw = jnp.sum(n * ell, axis=-1, keepdims=True)
    h = jnp.where(parts.root > 0, parts.root, 1.0)[..., None]
    g = n + (ell - nw * n) / h  # ∂q/∂w, (..., 6, 3)
    upper = geometry.upper
    ex_a = jnp.stack([jnp.zeros_like(upper[:, 0]), -upper[:, 2], upper[:, 1]], axis=-1)  # e_x × Ac
    d_phi = jnp.einsum("...jk,ik->...ij", parts.rot, ex_a)
    psi = poses[..., 5:6]
    axis_theta = jnp.concatenate([-jnp.sin(psi), jnp.cos(psi), jnp.zeros_like(psi)], axis=-1)
    d_theta = jnp.cross(jnp.broadcast_to(axis_theta[..., None, :], tp.shape), tp)
    d_psi = jnp.stack([-tp[..., 1], tp[..., 0], jnp.zeros_like(tp[..., 0])], axis=-1)
    jac = jnp.concatenate(
        [g] + [jnp.sum(g * d, axis=-1, keepdims=True) for d in (d_phi, d_theta, d_psi)], axis=-1
    )
    return parts.readings, parts.margin, jac


def _frame(n: Float[Array, "6 3"]) -> tuple[Array, Array]:
    """``(u, v)`` completing each unit axis ``n`` to a right-handed frame ``(u, v, n)``:
    ``u ∝ e_y × n`` (``e_x`` for ``n = e_z``), or ``∝ e_z × n`` for axes near ``e_y``."""
    ey = jnp.array([0.0, 1.0, 0.0])
    ez = jnp.array([0.0, 0.0, 1.0])
    ref = jnp.where(jnp.abs(n[:, 1:2]) < 0.9, ey, ez)
    u = jnp.cross(ref, n)
    u = u / jnp.linalg.norm(u, axis=-1, keepdims=True)
    return u, jnp.cross(n, u)


def _tilted(n: Float[Array, "6 3"], tilt: Float[Array, "12"]) -> Float[Array, "6 3"]:
    """The axes ``cos α·cos β·n + cos α·sin β·u − sin α·v`` (``tilt = [α_1..α_6, β_1..β_6]``, rad)."""
    u, v = _frame(n)
    a, b = tilt[..., :N_LEGS, None], tilt[..., N_LEGS:, None]
    return jnp.cos(a) * (jnp.cos(b) * n + jnp.sin(b) * u) - jnp.sin(a) * v


def _unit_axes(x: ArrayLike) -> Array:
    if isinstance(x, jax.core.Tracer):
        return x
    a = field_numpy(x, "PSSMechanism", "axes", (N_LEGS, 3))
    norm = np.linalg.norm(a, axis=-1)
    if np.any(np.abs(norm - 1.0) > 1e-6):
        raise ValueError(f"6-PSS axes must be unit vectors (one per leg, in B), got norms {norm.round(9).tolist()}")
    return jnp.asarray(a / norm[:, None])


def _positive(x: ArrayLike, name: str) -> Array:
    return field_array(x, "PSSMechanism", name, (N_LEGS,), positive=True, unit="mm")


def _default_param_set(d: dict[str, Any]) -> str:
    """A geometry file's parameter set when it names none: ``"54"`` with ``axes``, ``"42"``
    with ``rod_lengths``, else the paper's ``"36"``."""
    return "54" if "axes" in d else "42" if "rod_lengths" in d else "36"


def geometry_from_params(params: Float[Array, "36"], v0: ArrayLike = (0.0, 0.0, 0.0)) -> PSSMechanism:
    """A 6-PSS mechanism from the 36-vector of :attr:`PSSMechanism.params` (order ``Ac_1..Ac_6`` then
    ``Bc_1..Bc_6``, each x, y, z); traceable, vmap it over ``params``."""
    p = jnp.asarray(params, dtype=jnp.float64)
    if p.shape[-1:] != (N_PARAMS,):
        raise ValueError(f"params must have a last axis of 36, got shape {p.shape}")
    batch = p.shape[:-1]
    return PSSMechanism(p[..., :18].reshape(*batch, N_LEGS, 3), p[..., 18:].reshape(*batch, N_LEGS, 3), v0)


def rod_lengths(geometry: PSSMechanism) -> Float[Array, "6"]:
    """The rod lengths (mm): the given ones, or ``L_i = |Ac_i + v0 - Bc_i|`` (Wang et al. 2018, §1.2)."""
    if geometry.lengths is not None:
        return geometry.lengths
    return jnp.linalg.norm(geometry.upper + geometry.v0 - geometry.lower, axis=-1)


def _as_float64(x: ArrayLike, name: str, shape: tuple[int, ...]) -> Array:
    return field_array(x, "PSSMechanism", name, shape, unit="mm")


@register_preset("nominal", measured="actual")
def nominal_geometry(v0: ArrayLike = (0.0, 0.0, 0.0)) -> PSSMechanism:
    """The nominal parameters ``u_0`` of Wang et al. (2018), Table 1."""
    return PSSMechanism(NOMINAL_UPPER, NOMINAL_LOWER, v0)


@register_preset("actual")
def actual_geometry(v0: ArrayLike = (0.0, 0.0, 0.0)) -> PSSMechanism:
    """The "true" parameters ``u_a`` of Wang et al. (2018), Table 1, used by the simulation study."""
    return PSSMechanism(ACTUAL_UPPER, ACTUAL_LOWER, v0)


def geometry_from_dict(d: dict[str, Any]) -> PSSMechanism:
    """Inverse of :meth:`PSSMechanism.to_dict`. Accepts either ``upper``/``lower`` (6×3 each) or
    ``params`` (36 numbers, order ``Ac_1..Ac_6, Bc_1..Bc_6``); optional ``v0``, ``axes`` (6×3 unit
    slider axes in B), ``rod_lengths`` (6) and ``param_set`` (``"36"``, ``"42"``, ``"54"``; default
    ``"54"`` with ``axes``, ``"42"`` with ``rod_lengths``, else ``"36"``); lengths in mm."""
    check_file_header(d, PSSMechanism.family)
    check_keys(d, PSSMechanism.family, ("upper", "lower", "params", "v0", "axes", "rod_lengths", "param_set"))
    v0 = d.get("v0", (0.0, 0.0, 0.0))
    param_set = str(d.get("param_set", _default_param_set(d)))
    if param_set not in PARAM_SETS:
        raise ValueError(f"6-PSS geometry 'param_set' must be one of {list(PARAM_SETS)}, got {d['param_set']!r}")
    extra = {"axes": d.get("axes"), "rod_lengths": d.get("rod_lengths"), "param_set": param_set}
    if "params" in d:
        p = np.asarray(d["params"], dtype=np.float64)
        if p.shape != (N_PARAMS,):
            raise ValueError(f"geometry 'params' must hold 36 numbers, got shape {p.shape}")
        g = PSSMechanism(p[:18].reshape(6, 3), p[18:].reshape(6, 3), v0, **extra)
    else:
        missing = [k for k in ("upper", "lower") if k not in d]
        if missing:
            raise ValueError(f"geometry is missing {missing}: give 'upper' and 'lower' (6x3, mm) or 'params' (36)")
        g = PSSMechanism(d["upper"], d["lower"], v0, **extra)
    margin = np.asarray(g.solve_inverse_kinematics(jnp.zeros(6)).margin)
    if np.any(margin < 0):
        raise ValueError(
            f"6-PSS geometry cannot be assembled at the zero pose: legs {(np.flatnonzero(margin < 0) + 1).tolist()} "
            "have rods shorter than their joint's distance from the slider axis (check rod_lengths and axes, mm)"
        )
    return g
