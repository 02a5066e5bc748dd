"""A laser tracker's target points as a discrepancy model: the workflow's questions asked of the
points themselves, with the tracker's anisotropic noise.

The mechanism is that of the family's discrepancy model (the 6-PSS of Wang et al. 2018,
"Improved cuckoo calibration method of space telescope secondary mirror adjusting mechanism",
Infrared and Laser Engineering 47(5); 6-UPS strut hexapods), and so are its candidate effects: a
candidate changes how the true mechanism turns poses into readings. Here the readings are the
inputs and the points are the observations: the pose the mechanism reaches for the readings is
solved (forward kinematics through the effects), and each target seen there is predicted in the
tracker's frame, ``p̂_W = R·(T(P)·a_k + d + v0) + t``.

**Rows** are single target measurements (``(pose, target)`` pairs), three observations each (x, y,
z in the tracker's frame, mm), whitened by the tracker's noise (σ along the line of sight, σ per
metre across it: :func:`~stewart_jax.calibration._points.tracker_whitening`). The noise is independent
from point to point and the reached pose is not a parameter (it is solved from the readings), so
the points of one pose are independent given the base parameters, and the workflow's random
train/held-out split of rows is a split of points.

**Base parameters** are the family's (42 for a 6-UPS, 36 for the paper's 6-PSS). The
registration (tracker frame ← B) is held at the base references' rigid fit.

NOTE (why the registration may be held fixed). For a strut hexapod a rigid motion ``G`` of the
base frame is a gauge of the geometry: base joints ``G·b_i`` with the same platform joints,
lengths and readings reach the pose ``G∘P``, so every platform point is predicted by the
registration ``R·G⁻¹`` exactly as before. An error of the references' fit is therefore absorbed
by the base joints, exactly, and neither biases the test nor costs a degree of freedom (measured
on two Rubin camera sessions: the detection p-values with the references' noise and without it
agree to 1e-8). For the 6-PSS the sliders' direction (B's z) breaks the gauge; the part not absorbed is
the stroke times the registration's tilt error (1 mm × 5 µrad = 5 nm for the paper's travel), far
below a tracker's micrometres. For the 6-RUS the crank planes (vertical, at fixed azimuths) break
it too: a rotation error ``ω`` turns each crank end by ``a·ω``, of which the base joint absorbs
the part at one crank angle and the crank zero the part about the motor's axis; what is left
varies as ``a·|ω|·Δα``, e.g. 50 mm × 85 µrad × 0.27 rad ≈ 1 µm for the ``rotary_stewart``
preset with the default targets (four references 176 mm apart, 2.9 m away) over ±15° of crank
(an estimate, not measured): a fifth of the tracker's σ per point, enough to tilt the detection
test with many hundreds of points. More or wider-spaced references shrink it.

NOTE (forward kinematics through the effects). The effects are applied once, to the state at
the starting pose ``P₀`` (forward kinematics of the starting geometry, :func:`point_rows`); the
reached pose is then found by the chord method on the effects' reading model,
``P ← P − J₀⁻¹·(q(P) − q')`` with ``J₀ = ∂q/∂P`` at ``P₀`` (six forward-mode derivatives: rows
are independent). A pose-dependent effect (``gravity_sag``) is thereby evaluated at ``P₀`` rather
than at the reached pose; the two differ by the geometry's correction (≤ a few mm), which changes
the effect by (correction / lever arm) ≈ 1e-3 of itself. Each chord step shrinks the error by
``‖I − J₀⁻¹J‖`` ≈ (correction / lever arm) ≤ 1e-3, so ``NEWTON_STEPS`` = 5 from within millimetres
reach rounding, and so do the derivatives the fits take through the steps. One Jacobian instead
of one per step keeps the fits' compiled programs small. No derivative is taken through ``J₀``
itself (``stop_gradient``): in a step's derivative it multiplies ``q(P) − q'``, which the steps
drive to rounding. Measured on a camera session (180 points, 42 parameters): the fits' Jacobian
moved by 7e-16 of its size, and the diagnosis compiled in 38 s instead of 62 s and ran in 5 s
instead of 10 s (LLVM -O0, loaded 2-core machine).

The open search of terms (``_discovery.py``) is for reading residuals and does not run here.
The tracker-side effect ``tracker_misalignment`` of the pose models is the registration itself
(absorbed, see above) and is not a candidate.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from .._linalg import solve
from .._math import rotation_matrix
from .._units import UM
from ..calibration._points import PointData, TrackerTargets, start_values, tracker_whitening
from ..mechanism._abstract import AbstractMechanism
from ..mechanism._kinematics import forward_kinematics
from ._families import model_for
from ._pose_noise import CONDITION_NAMES, AbstractPoseNoiseModel
from ._registry import AbstractDiscrepancyModel, Effect, effects_for, register_again

NEWTON_STEPS = 5
"""Chord (simplified Newton) steps of the forward kinematics through the effects (see the module's NOTE)."""


class PointRows(NamedTuple):
    """Tracker points as rows of the discrepancy workflow; ``n`` measured points.

    - ``readings``: ``Float[Array, "n 6"]``, the readings of each point's pose (mm; rad for a
      crank).
    - ``poses``: ``Float[Array, "n 6"]``, the starting pose of the forward kinematics (mm, rad).
    - ``body``: ``Float[Array, "n 3"]``, the target's nominal coordinates in A (mm).
    - ``points``: ``Float[Array, "n 3"]``, the measured point in the tracker's frame (mm).
    - ``whitening``: ``Float[Array, "n 3 3"]``, the tracker noise's whitening (1/mm).
    - ``pose``, ``target``: ``Int[Array, "n"]``, the point's pose and target (indices into the
      points file's poses and the targets file's platform targets).
    - ``directions`` (``n 6``), ``temperature`` (``n``), ``time`` (``n``): the pose's conditions,
      or ``None``.
    """

    readings: Float[Array, "n 6"]
    poses: Float[Array, "n 6"]
    body: Float[Array, "n 3"]
    points: Float[Array, "n 3"]
    whitening: Float[Array, "n 3 3"]
    pose: Int[Array, " n"]
    target: Int[Array, " n"]
    directions: Float[Array, "n 6"] | None = None
    temperature: Float[Array, " n"] | None = None
    time: Float[Array, " n"] | None = None

    @property
    def n_poses(self) -> int:
        return int(self.readings.shape[0])

    def take(self, index) -> PointRows:
        idx = np.asarray(index)
        return PointRows(*(None if f is None else f[idx] for f in self))


class PointState(NamedTuple):
    """The family model's state (``inner``: what its effects change) and the targets' coordinates
    in A (``body``, ``Float[Array, "n 3"]``, mm)."""

    inner: Any
    body: Float[Array, "n 3"]


class PointsModel(AbstractDiscrepancyModel):
    """The family's discrepancy model observed through a laser tracker's points.

    **Fields:**

    - ``inner``: the family's pose-noise model (:func:`~stewart_jax.discrepancy.model_for`), which
      supplies the base parameters, the state its effects change and the reading model; its pose
      noise is not used.
    - ``mechanism``: the starting mechanism (its parameter names label the base parameters).
    - ``rotation``, ``translation``: the registration ``p_W = R·p_B + t`` (mm), held fixed.
    - ``v0``: ``Float[Array, "3"]``, A's origin in B at the zero pose (mm).
    """

    inner: AbstractPoseNoiseModel
    mechanism: AbstractMechanism
    rotation: Float[Array, "3 3"]
    translation: Float[Array, "3"]
    v0: Float[Array, "3"]

    output_names = ("x", "y", "z")
    report_unit = "µm"
    report_factor = 1.0 / UM

    @property
    def name(self) -> str:  # the key its effects are registered under
        return points_model_name(self.inner.name)

    @property
    def reading_unit(self) -> str:
        return self.mechanism.reading_unit

    @property
    def base_names(self) -> tuple[str, ...]:
        return self.mechanism.param_names

    @property
    def base_initial(self) -> Float[Array, " p"]:
        return self.inner.base_initial

    @property
    def base_scale(self) -> Float[Array, " p"]:
        return self.inner.base_scale

    def observed(self, data: PointRows) -> Float[Array, "n 3"]:
        return data.points

    def initial_state(self, base: Float[Array, " p"], data: PointRows, control: bool) -> PointState:
        return PointState(self.inner.initial_state(base, data, control), data.body)

    def finish(self, state: PointState, data: PointRows) -> Float[Array, "n 3"]:
        inner = state.inner

        def readings(poses, state=inner):
            return self.inner.finish(state._replace(poses=poses), data)

        # the chord method: the Jacobian at the start, one solve per step, no derivative through
        # the Jacobian (see the module's NOTE)
        start = inner.poses
        frozen = jax.lax.stop_gradient(inner)
        tangents = jnp.broadcast_to(jnp.eye(6)[:, None, :], (6,) + start.shape)
        jac = jnp.moveaxis(jax.vmap(lambda t: jax.jvp(lambda p: readings(p, frozen), (start,), (t,))[1])(tangents),
                           0, -1)
        inverse = _inverse(jac)  # (n, reading, pose component) → (n, component, reading)

        def chord(poses, _):
            return poses - jnp.einsum("nij,nj->ni", inverse, readings(poses) - data.readings), None

        poses, _ = jax.lax.scan(chord, start, None, length=NEWTON_STEPS)
        in_b = jnp.einsum("nij,nj->ni", rotation_matrix(poses[:, 3:]), state.body) + poses[:, :3] + self.v0
        return in_b @ self.rotation.T + self.translation

    def whitener(self, base: Float[Array, " p"], data: PointRows) -> Float[Array, "n 3 3"]:
        return data.whitening

    def columns(self, data: PointRows) -> frozenset[str]:
        return frozenset(c for c in CONDITION_NAMES if getattr(data, c) is not None)

    def n_rows(self, data: PointRows) -> int:
        return int(data.readings.shape[0])

    def take(self, data: PointRows, index) -> PointRows:
        return data.take(index)

    def factors(self, data: PointRows) -> dict[str, np.ndarray]:
        """Per point: the pose's six components at the start (µm, ″), its distance from the
        tracker head (m), the target's index, and the pose's temperature and time."""
        from .._units import ARCSEC

        n = self.n_rows(data)
        p = np.asarray(data.poses)

        def per_point(x):
            return np.broadcast_to(np.asarray(x, dtype=np.float64)[:, None], (n, 3))

        out = {c: per_point(p[:, i] / UM) for i, c in enumerate(("x_um", "y_um", "z_um"))}
        out |= {c: per_point(p[:, 3 + i] / ARCSEC) for i, c in enumerate(("rx_arcsec", "ry_arcsec", "rz_arcsec"))}
        out["distance_m"] = per_point(np.linalg.norm(np.asarray(data.points), axis=1) / 1000.0)
        out["target"] = per_point(np.asarray(data.target))
        if data.temperature is not None:
            out["temperature_C"] = per_point(data.temperature)
        if data.time is not None:
            out["time_s"] = per_point(data.time)
        return out


def _inverse(jac: Float[Array, "n 6 6"]) -> Float[Array, "n 6 6"]:
    """``J⁻¹`` per row: Gaussian elimination with partial pivoting on ``J`` with its columns scaled
    to unit norm (``J = A·D``, ``J⁻¹ = D⁻¹A⁻¹``).

    NOTE: in element-wise operations (:func:`stewart_jax._linalg.solve`) rather than LAPACK's
    ``inv``: with jaxlib 0.10.0 to 0.11.0 a batched LAPACK call can deadlock XLA's CPU thread pool
    (see the NOTE of ``stewart_jax._linalg``); with LAPACK calls on these 6 × 6 matrices inside the
    fits' loops, the discrepancy fits of a points file stalled (0 % CPU, every thread waiting) in
    each of three runs on a loaded 2-core machine."""
    norms = jnp.linalg.norm(jac, axis=-2)  # (n, 6) column norms
    a = jac / norms[:, None, :]
    inv_a = jax.vmap(lambda e: solve(a, jnp.broadcast_to(e, a.shape[:2])), out_axes=-1)(jnp.eye(6))
    return inv_a / norms[:, :, None]


def points_model_name(inner_name: str) -> str:
    """The registry name of the points model over the family model ``inner_name``."""
    return f"{inner_name}-points"


def _mirror(effect: Effect, name: str) -> Effect:
    """Register a family effect under the points model: the same physics applied to the inner state."""

    def apply(theta, data, state):
        return state._replace(inner=effect.apply(theta, data, state.inner))

    return register_again(effect, name, apply)


def _register_effects(inner_name: str) -> None:
    """Mirror every mechanism-side effect of the family model (re-run at each :func:`points_model`,
    so effects registered since are offered too); measurement-side effects act on measured poses,
    which a points file has none of."""
    name = points_model_name(inner_name)
    have = {e.name: e for e in effects_for(name)}
    for e in effects_for(inner_name):
        if e.acts_on == "mechanism" and (e.name not in have or have[e.name].n_params != e.n_params):
            _mirror(e, name)


@eqx.filter_jit
def _forward(mechanism, readings, start):
    fk = forward_kinematics(mechanism, readings, start)
    return fk.poses, fk.converged


def point_rows(
    data: PointData,
    targets: TrackerTargets,
    mechanism: AbstractMechanism,
    *,
    range_um: float,
    across_um_per_m: float,
) -> tuple[PointRows, np.ndarray, np.ndarray]:
    """The rows of a points file for :class:`PointsModel`, and the registration (``rotation``,
    ``translation``: the base references' rigid fit). The starting poses are the forward
    kinematics of ``mechanism`` for each pose's readings (from the per-pose rigid fits where three
    targets or more were seen); a pose where it fails is an error
    naming it."""
    rot, t, start, _ = start_values(data, targets, mechanism)
    poses, ok = _forward(mechanism, jnp.asarray(data.readings), jnp.asarray(start))
    if not np.all(np.asarray(ok)):
        bad = [data.pose_names[j] for j in np.flatnonzero(~np.asarray(ok))]
        raise ValueError(f"forward kinematics of the starting geometry fails at pose(s) {bad[:8]}: readings outside "
                         "its workspace, or a file in other units")
    j = np.asarray(data.pose_index)

    def per_point(x):
        return None if x is None else jnp.asarray(np.asarray(x, dtype=np.float64)[j])

    rows = PointRows(
        readings=per_point(data.readings), poses=per_point(np.asarray(poses)),
        body=jnp.asarray(targets.platform[data.target_index]), points=jnp.asarray(data.points),
        whitening=jnp.asarray(tracker_whitening(data.points, range_um, across_um_per_m)),
        pose=jnp.asarray(j), target=jnp.asarray(data.target_index),
        directions=per_point(data.directions), temperature=per_point(data.temperature), time=per_point(data.time))
    return rows, rot, t


def points_model(mechanism: AbstractMechanism, rotation, translation) -> PointsModel:
    """:class:`PointsModel` of ``mechanism``'s family, starting from ``mechanism``, with the
    registration ``rotation, translation`` (from :func:`point_rows`)."""
    inner = model_for(mechanism)
    if not isinstance(inner, AbstractPoseNoiseModel):
        raise ValueError(f"the {mechanism.family} family's discrepancy model does not read actuator readings; "
                         "a points file needs one that does (6-PSS, 6-UPS, 6-RUS)")
    _register_effects(inner.name)
    return PointsModel(inner, mechanism, jnp.asarray(rotation, jnp.float64), jnp.asarray(translation, jnp.float64),
                       jnp.asarray(mechanism.v0, jnp.float64))
