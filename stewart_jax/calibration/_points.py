"""Calibration from a laser tracker's own measurements: target points in the tracker's frame.

Wang H., Cao X. et al., "Improved cuckoo calibration method of space telescope secondary mirror
adjusting mechanism", Infrared and Laser Engineering 47(5), 2018, §4, measure the platform's pose
with a laser tracker and calibrate from poses (the rigid fit of the measured targets). Here the
tracker's points themselves are the observations, so that poses where fewer than three targets
were seen still count and the tracker's anisotropic noise is weighted where it arises.

The model. The tracker frame W is registered to the base frame B by ``p_W = R·p_B + t`` (6
parameters); a target ``a_k`` fixed in the platform frame A is predicted at

    ``p̂_W = R·(T(P)·a_k + d + v0) + t``,   with  ``P = FK(q, u)``,

the pose the mechanism with parameters ``u`` reaches for the readings ``q`` (Wang et al. eq. 5–6
solved by Newton), and a base reference ``b_r`` (fixed in B) at ``p̂_W = R·b_r + t``. The unknowns
are ``u`` and the registration; the reached poses are eliminated by forward kinematics, which is
the joint estimate of (``u``, registration, every pose) when the readings are exact (the reading
noise is not modelled: encoders resolve far below a tracker's micrometres).

NOTE (the block structure). Holding the poses as unknowns gives an arrow-shaped normal matrix
(one 6×6 block per pose, coupled to the global parameters); eliminating them by forward kinematics
is that matrix's Schur complement taken exactly at every iterate, so each Levenberg–Marquardt step
solves only ``n + 6`` normal equations however many poses there are. The pose derivatives come
from the implicit function theorem, ``∂P/∂u = −(∂IK/∂P)⁻¹·∂IK/∂u`` (a 6×6 solve per pose), not by
differentiating Newton's iterations. The solver is :class:`~stewart_jax.optimise.BatchedLevenbergMarquardt`.

Noise. The tracker's error is anisotropic (its published maximum permissible error has the form
``range + across·distance``): σ along the line of sight is ``range_um``, across it
``across_um_per_m`` per metre of distance from the tracker head (the tracker frame's origin). Each
residual is whitened by its point's ``W = diag(1/σ_∥, 1/σ_⊥, 1/σ_⊥)·[u; v₁; v₂]`` (``u`` the
measured line of sight), so the cost is the χ² of the fit, with ``3·(points + references) − rank``
degrees of freedom, and the identifiability, the parameter covariance ``(J_WᵀJ_W)⁺`` and the χ²
test all come from the whitened Jacobian ``J_W``.
"""

from __future__ import annotations

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.scipy.special import gammainc, gammaincc
from jaxtyping import Array, Float, Int

from .._math import rotation_matrix
from .._units import UM
from ..mechanism._abstract import AbstractMechanism
from ..mechanism._kinematics import forward_kinematics
from ._assessment import FIT_P_VALUE, IDENTIFIABLE_TOL, RANK_RTOL, CalibrationAssessment
from ._csv import STROKE_COLUMNS
from ._determined import (
    Determination,
    describe_held,
    determine,
    prior_scale,
    restricted_covariance,
    total_covariance,
)

POINT_COLUMNS = ("pose", "target", *STROKE_COLUMNS, "x", "y", "z")
"""The columns a points file must have (``pose`` = ``ref`` on a base reference's row)."""
REFERENCE_POSE = "ref"
DEFAULT_TRACKER_SIGMA = (5.0, 2.5)
"""σ along the line of sight (µm) and across it (µm per metre of distance), the default noise."""
POINTS_DETERMINED_STD = 0.5
"""A direction of ``[u, registration]`` is determined from points when the data's std along it is at
most this many prior scales (``_determined.py``), and a held one keeps that std about the truth.

NOTE: a prior scale (1 mm, 1 mrad) is a tolerance, about two standard deviations of the as-built
spread (``--perturb-mm`` simulates σ = 0.5 mm); a direction fitted is off by the data's σ along
it, one held at nominal by the spread's, so half a prior scale is where fitting starts to pay.
Measured against an independent maximum-likelihood fit of the same points, every parameter free
(``benchmarks/tracker_points_ml.py``, 20 seeds per family): the RMS validation control error is
0.84–1.01× the reference's per component on the Rubin camera hexapod, whose χ² ends lower by about
the number of held directions (what fitting them to noise gives). At one and two prior scales
(``calibrate_points(determined_std=...)``) the library is closer to that reference and its
parameters further from the truth, and no more accurate in mean square. The pose route keeps one prior
scale (:data:`~stewart_jax.calibration._determined.DETERMINED_STD`): it has not been measured
against such a reference at half."""
_READING_ATOL = 1e-9
"""Rows of one pose whose readings differ by more than this (mm, or rad for crank angles) disagree."""


class TrackerTargets(NamedTuple):
    """Nominal target coordinates (mm), the contents of a targets file.

    - ``platform_names``: ``k`` names; ``platform``: ``Float[ndarray, "k 3"]``, in frame A.
    - ``base_names``: ``r ≥ 3`` names; ``base``: ``Float[ndarray, "r 3"]``, in frame B (they
      define B in the tracker's frame).
    """

    platform_names: tuple[str, ...]
    platform: np.ndarray
    base_names: tuple[str, ...]
    base: np.ndarray


class PointData(NamedTuple):
    """Tracker measurements of ``m`` poses (mm, tracker frame, its head at the origin).

    - ``pose_names``: ``m`` labels (the file's ``pose`` column); ``readings``: ``Float[ndarray, "m 6"]``.
    - ``pose_index``, ``target_index``: ``Int[ndarray, "n"]``, each platform measurement's pose and
      target (index into :attr:`TrackerTargets.platform`); ``points``: ``Float[ndarray, "n 3"]``.
    - ``reference_index``: ``Int[ndarray, "r"]`` (into :attr:`TrackerTargets.base`);
      ``references``: ``Float[ndarray, "r 3"]``.
    - optional, per pose (the pose CSV's columns ``dir1..dir6``, ``temperature``, ``time``):
      ``directions``: ``Float[ndarray, "m 6"]`` (±1), ``temperature``: ``Float[ndarray, "m"]`` (°C),
      ``time``: ``Float[ndarray, "m"]`` (s).
    """

    pose_names: tuple[str, ...]
    readings: np.ndarray
    pose_index: np.ndarray
    target_index: np.ndarray
    points: np.ndarray
    reference_index: np.ndarray
    references: np.ndarray
    directions: np.ndarray | None = None
    temperature: np.ndarray | None = None
    time: np.ndarray | None = None

    @property
    def n_poses(self) -> int:
        return len(self.pose_names)

    def targets_per_pose(self) -> np.ndarray:
        """``Int[ndarray, "m"]``: how many targets were seen at each pose."""
        return np.bincount(self.pose_index, minlength=self.n_poses)


# ---- noise ---------------------------------------------------------------------------------------


def tracker_whitening(
    points: Float[np.ndarray, "n 3"], range_um: float, across_um_per_m: float
) -> Float[np.ndarray, "n 3 3"]:
    """Per point, ``W`` with ``W·Σ·Wᵀ = I`` for the tracker noise ``Σ`` (σ_∥ = ``range_um`` along
    the line of sight from the origin, σ_⊥ = ``across_um_per_m`` per metre of distance across it)."""
    if not (np.isfinite(range_um) and np.isfinite(across_um_per_m) and range_um > 0 and across_um_per_m > 0):
        raise ValueError(f"the tracker noise must be positive: range {range_um} µm, across {across_um_per_m} µm/m")
    p = np.asarray(points, dtype=np.float64)
    dist = np.linalg.norm(p, axis=1)
    if np.any(dist < 1.0):
        raise ValueError("a measured point lies within 1 mm of the tracker head (the frame's origin): the tracker's "
                         "line of sight is undefined there; are the coordinates in the tracker's frame?")
    u = p / dist[:, None]
    helper = np.where(np.abs(u[:, :1]) < 0.9, np.array([1.0, 0, 0]), np.array([0, 1.0, 0]))
    v1 = np.cross(u, helper)
    v1 /= np.linalg.norm(v1, axis=1, keepdims=True)
    v2 = np.cross(u, v1)
    s_par = range_um * UM
    s_perp = across_um_per_m * UM * dist / 1000.0
    return np.stack([u / s_par, v1 / s_perp[:, None], v2 / s_perp[:, None]], axis=1)


def tracker_covariance(points: Float[np.ndarray, "n 3"], range_um: float, across_um_per_m: float) -> np.ndarray:
    """``Float[ndarray, "n 3 3"]``: each point's noise covariance (mm²), the inverse of ``WᵀW``."""
    w = tracker_whitening(points, range_um, across_um_per_m)
    return np.linalg.inv(np.einsum("nki,nkj->nij", w, w))


# ---- the model -----------------------------------------------------------------------------------


def _reached_poses(mechanism: AbstractMechanism):
    """``P(u) = FK(q, u)`` from fixed starts, with the implicit-function derivative in ``u``."""

    def ik(u, poses):
        return mechanism.with_params(u).solve_inverse_kinematics(poses).readings

    @jax.custom_jvp
    def reached(u, readings, start):
        sol = forward_kinematics(mechanism.with_params(u), readings, start)
        return jnp.where(sol.converged[:, None], sol.poses, jnp.nan)

    @reached.defjvp
    def _jvp(primals, tangents):
        u, readings, start = primals
        du, dq, _ = tangents
        poses = reached(u, readings, start)
        jp = jax.vmap(jax.jacfwd(lambda p: ik(u, p[None])[0]))(poses)  # (m, 6, 6) ∂IK/∂P
        _, dik = jax.jvp(lambda v: ik(v, poses), (u,), (du,))
        return poses, jnp.linalg.solve(jp, (dq - dik)[..., None])[..., 0]

    return reached


class _PointProblem(eqx.Module):
    """The whitened residual of ``y = [u (n), registration correction (6)]`` (see the module docstring)."""

    readings: Float[Array, "m 6"]
    start: Float[Array, "m 6"]
    pose_index: Int[Array, " n"]
    body: Float[Array, "n 3"]
    points: Float[Array, "n 3"]
    w_points: Float[Array, "n 3 3"]
    ref_body: Float[Array, "r 3"]
    references: Float[Array, "r 3"]
    w_refs: Float[Array, "r 3 3"]
    rot0: Float[Array, "3 3"]
    t0: Float[Array, "3"]

    def registration(self, y):
        reg = y[-6:]
        return self.rot0 @ rotation_matrix(reg[3:]), self.t0 + reg[:3]

    def predicted(self, mechanism: AbstractMechanism, y):
        """Predicted platform points, reference points (tracker frame, mm) and reached poses."""
        n = mechanism.n_params
        rot, t = self.registration(y)
        poses = _reached_poses(mechanism)(y[:n], self.readings, self.start)
        p = poses[self.pose_index]
        in_b = jnp.einsum("nij,nj->ni", rotation_matrix(p[:, 3:]), self.body) + p[:, :3] + mechanism.v0
        return in_b @ rot.T + t, self.ref_body @ rot.T + t, poses

    def jacobian(self, y, mechanism: AbstractMechanism):
        """``∂r/∂y`` (rows as :meth:`residuals`): the chain ``W·∂p̂/∂P·∂P/∂u`` with
        ``∂P/∂u = −(∂IK/∂P)⁻¹·∂IK/∂u`` per pose, and ``W·∂p̂/∂ρ`` for the registration."""
        n = mechanism.n_params
        u, reg = y[:n], y[n:]
        m = mechanism.with_params(u)
        poses = _reached_poses(mechanism)(u, self.readings, self.start)
        _, _, jp = m.ik_and_jacobian(poses)  # (m, 6, 6)
        ju = m.parameter_jacobian(poses).reshape(poses.shape[0], 6, n)
        dpose_du = -jnp.linalg.solve(jp, ju)  # (m, 6, n)

        def point(pose, reg, a):
            rot = self.rot0 @ rotation_matrix(reg[3:])
            return rot @ (rotation_matrix(pose[3:]) @ a + pose[:3] + m.v0) + self.t0 + reg[:3]

        p = poses[self.pose_index]
        d_pose, d_reg = jax.vmap(jax.jacfwd(point, argnums=(0, 1)), in_axes=(0, None, 0))(p, reg, self.body)
        d_u = jnp.einsum("nij,njk->nik", d_pose, dpose_du[self.pose_index])
        j_points = -jnp.einsum("nij,njk->nik", self.w_points, jnp.concatenate([d_u, d_reg], axis=-1))

        def ref(reg, b):
            return self.rot0 @ rotation_matrix(reg[3:]) @ b + self.t0 + reg[:3]

        d_ref = jax.vmap(jax.jacfwd(ref), in_axes=(None, 0))(reg, self.ref_body)
        j_refs = -jnp.einsum("nij,njk->nik", self.w_refs, d_ref)
        j_refs = jnp.concatenate([jnp.zeros(j_refs.shape[:2] + (n,)), j_refs], axis=-1)
        return jnp.concatenate([j_points.reshape(-1, n + 6), j_refs.reshape(-1, n + 6)])

    def residuals(self, y, mechanism: AbstractMechanism):
        pts, refs, _ = self.predicted(mechanism, y)
        r1 = jnp.einsum("nij,nj->ni", self.w_points, self.points - pts)
        r2 = jnp.einsum("nij,nj->ni", self.w_refs, self.references - refs)
        return jnp.concatenate([r1.reshape(-1), r2.reshape(-1)])


def start_values(data: PointData, targets: TrackerTargets, nominal: AbstractMechanism):
    """The starts: the registration from the base references' rigid fit, and each pose from the
    rigid fit of its targets (≥ 3 seen), else from forward kinematics of ``nominal``.

    Returns ``(rot0, t0, poses (m, 6), fitted (m,) bool)``."""
    rot0, t0 = _kabsch(targets.base[data.reference_index], data.references)
    fk = forward_kinematics(nominal, jnp.asarray(data.readings))
    rigid, fitted = rigid_poses(data, targets, rot0, t0, np.asarray(nominal.v0))
    poses = np.where(fitted[:, None], rigid, np.asarray(fk.poses))
    return rot0, t0, poses, fitted


def rigid_poses(data: PointData, targets: TrackerTargets, rot, t, v0) -> tuple[np.ndarray, np.ndarray]:
    """Per pose, the rigid fit (Kabsch) of its targets mapped into B by the registration ``rot, t``
    (``(m, 6)``, NaN where fewer than three targets were seen) and which poses have one."""
    counts = np.bincount(data.pose_index, minlength=data.n_poses)
    fitted = counts >= 3
    poses = np.full((data.n_poses, 6), np.nan)
    in_b = (data.points - t) @ rot  # Rᵀ·(p − t)
    body = targets.platform[data.target_index]
    order = np.argsort(data.pose_index, kind="stable")
    first = np.concatenate([[0], np.cumsum(counts)[:-1]])
    for c in np.unique(counts[fitted]):  # the poses that saw c targets, in one batched fit
        js = np.flatnonzero(counts == c)
        rows = order[first[js, None] + np.arange(c)]
        r, d = _kabsch_batch(body[rows], in_b[rows])
        angles = np.stack([np.arctan2(r[:, 2, 1], r[:, 2, 2]), -np.arcsin(np.clip(r[:, 2, 0], -1.0, 1.0)),
                           np.arctan2(r[:, 1, 0], r[:, 0, 0])], axis=-1)  # euler_angles, in NumPy
        poses[js] = np.concatenate([d - v0, angles], axis=-1)
    return poses, fitted


def _kabsch_batch(body: np.ndarray, measured: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_kabsch` of ``k`` point sets of equal size at once (``(k, c, 3)`` each)."""
    cb, cm = body.mean(1), measured.mean(1)
    u, _, vt = np.linalg.svd(np.einsum("kci,kcj->kij", body - cb[:, None], measured - cm[:, None]))
    v, ut = np.swapaxes(vt, 1, 2), np.swapaxes(u, 1, 2)
    d = np.sign(np.linalg.det(v @ ut))
    rot = v @ (np.eye(3) * np.stack([np.ones_like(d), np.ones_like(d), d], -1)[:, None, :]) @ ut
    return rot, cm - np.einsum("kij,kj->ki", rot, cb)


def _kabsch(body: np.ndarray, measured: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~stewart_jax.calibration._simulation.rigid_fit` in NumPy (one small SVD per pose, no dispatch)."""
    cb, cm = body.mean(0), measured.mean(0)
    u, _, vt = np.linalg.svd((body - cb).T @ (measured - cm))
    d = np.sign(np.linalg.det(vt.T @ u.T))
    rot = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    return rot, cm - rot @ cb


class PointCalibration(NamedTuple):
    """The result of :func:`calibrate_points`.

    - ``mechanism``: the calibrated mechanism; ``params``: its parameters.
    - ``rotation``, ``translation``: the registration ``p_W = R·p_B + t`` (mm).
    - ``poses``: ``Float[ndarray, "m 6"]``, the reached poses ``FK(q, u)`` (mm, rad);
      ``start_poses`` the starts (rigid fits where ``fitted``, else nominal forward kinematics).
    - ``status``: the solver's status name; ``n_steps``: its residual-and-Jacobian evaluations.
    - ``chi2``: the whitened cost at the solution; ``assessment``: a
      :class:`CalibrationAssessment` of the point model (χ², rank, identifiability, parameter
      covariance with the registration's six parameters last, ``n + 6`` of them).
    - ``residuals_um``: ``Float[ndarray, "n 3"]``, measured minus predicted platform points (µm).
    - ``determination``: the directions of ``[u, registration]`` the points determine to better than
      :data:`POINTS_DETERMINED_STD` prior scales, and those held at nominal (``_determined.py``).
    """

    mechanism: AbstractMechanism
    params: np.ndarray
    rotation: np.ndarray
    translation: np.ndarray
    poses: np.ndarray
    start_poses: np.ndarray
    fitted: np.ndarray
    status: str
    n_steps: int
    chi2: float
    assessment: CalibrationAssessment
    residuals_um: np.ndarray
    determination: Determination | None = None


_PAD_POINTS, _PAD_POSES = 64, 32
_INITIAL_DAMPING = 1e-12
"""The Levenberg–Marquardt's initial damping μ₀ (relative to ``diag JᵀJ``) for the point model.

NOTE: from the nominal geometry the point model is nearly linear in the parameters (a joint
moved by a millimetre moves the points by as much, to 1e-3 of itself), so Gauss–Newton's step is
the right first step. The solver's default μ₀ = 1e-3 falls at most 3× per accepted step and took
20–23 evaluations to reach the Gauss–Newton regime; from μ₀ = 1e-12 (its floor) the same fits end
in 5–8 evaluations at the same χ² (to 1e-11 relative; rubin_camera, rubin_m2 and fast_stewart,
120 poses, parameters moved by σ = 0.5 mm). A step that fails is rejected and μ raised as usual."""


def _padded(x: np.ndarray, size: int, fill: float = 0.0) -> np.ndarray:
    pad = np.full((size - len(x),) + x.shape[1:], fill, dtype=x.dtype)
    return np.concatenate([x, pad])


def _problem(data, targets, nominal, range_um, across_um_per_m, starts) -> _PointProblem:
    """The problem, its points padded to a multiple of 64 and its poses to a multiple of 32.

    NOTE: padding keeps the compiled solve's shapes the same for data sets of similar size (a
    new shape recompiles the whole LM). A padded point has a zero whitening matrix, so its
    residual and Jacobian rows are zero; a padded pose has zero readings, starts at the zero pose
    and carries no point. :func:`calibrate_points` drops both before any statistic."""
    rot0, t0, poses, _ = starts
    n_pts = -(-len(data.points) // _PAD_POINTS) * _PAD_POINTS
    m = -(-data.n_poses // _PAD_POSES) * _PAD_POSES
    f = jnp.asarray
    return _PointProblem(
        readings=f(_padded(data.readings, m)), start=f(_padded(poses, m)),
        pose_index=f(_padded(data.pose_index, n_pts)),
        body=f(_padded(targets.platform[data.target_index], n_pts)), points=f(_padded(data.points, n_pts)),
        w_points=f(_padded(tracker_whitening(data.points, range_um, across_um_per_m), n_pts)),
        ref_body=f(targets.base[data.reference_index]), references=f(data.references),
        w_refs=f(tracker_whitening(data.references, range_um, across_um_per_m)),
        rot0=f(rot0), t0=f(t0))


@eqx.filter_jit
def _jacobian_at(problem: _PointProblem, nominal: AbstractMechanism, y):
    return problem.jacobian(y, nominal)


@eqx.filter_jit
def _solve(problem: _PointProblem, nominal: AbstractMechanism, y0, basis, max_steps: int, initial_damping: float):
    """The fit over ``y = y0 + basis·a`` (the determined directions; ``_determined.py``)."""
    from ..optimise._batched_lm import BatchedLevenbergMarquardt

    solver = BatchedLevenbergMarquardt(max_steps=max_steps, initial_damping=initial_damping)
    res = solver.run(lambda a, p: p.residuals(y0 + basis @ a, nominal), jnp.zeros(basis.shape[1]), args=problem,
                     jac=lambda a, p: p.jacobian(y0 + basis @ a, nominal) @ basis)
    y = y0 + basis @ res.params
    pts, _, poses = problem.predicted(nominal, y)
    rot, t = problem.registration(y)
    return res, y, problem.jacobian(y, nominal), problem.residuals(y, nominal), pts, poses, rot, t


def calibrate_points(
    data: PointData,
    targets: TrackerTargets,
    nominal: AbstractMechanism,
    *,
    range_um: float = DEFAULT_TRACKER_SIGMA[0],
    across_um_per_m: float = DEFAULT_TRACKER_SIGMA[1],
    max_steps: int = 100,
    determined_std: float = POINTS_DETERMINED_STD,
) -> PointCalibration:
    """Calibrate ``nominal``'s parameters and the tracker registration from target points.

    The whitened residual of every platform point and base reference (module docstring) is
    minimised by the Levenberg–Marquardt, from the starts of :func:`start_values`, in the directions
    whose data std is at most ``determined_std`` prior scales; the others are held at nominal. Poses
    with one or two targets are used. Raises ``ValueError`` when the points are fewer than the
    unknowns, or ``determined_std`` is not a positive, finite number (a large one holds no direction
    the data constrain at all).
    """
    from ..optimise._result import status_name

    n = nominal.n_params
    if not (np.isfinite(determined_std) and determined_std > 0):
        raise ValueError(f"determined_std must be a positive, finite number of prior scales, got {determined_std}")
    n_obs = 3 * (len(data.points) + len(data.references))
    if n_obs < n + 6:
        raise ValueError(f"{len(data.points)} points and {len(data.references)} references give {n_obs} residuals "
                         f"for {n + 6} unknowns ({n} parameters + 6 of the registration)")
    starts = start_values(data, targets, nominal)
    problem = _problem(data, targets, nominal, range_um, across_um_per_m, starts)
    y0 = jnp.concatenate([nominal.params, jnp.zeros(6)])
    n_pts, n_pad = len(data.points), problem.points.shape[0]
    rows = np.concatenate([np.arange(3 * n_pts), 3 * n_pad + np.arange(3 * len(data.references))])
    det = determine(np.asarray(_jacobian_at(problem, nominal, y0))[rows], prior_scale(nominal.param_units, 6),
                    determined_std)
    res, y, jac, r, pts, poses, rot, t = _solve(problem, nominal, y0, jnp.asarray(det.step_basis), max_steps,
                                                _INITIAL_DAMPING)
    y = np.asarray(y)
    r = np.asarray(r)[rows]
    names = (*nominal.param_names, "reg_x", "reg_y", "reg_z", "reg_rx", "reg_ry", "reg_rz")
    assessment = _assess(np.asarray(jac)[rows], r, names, det)
    return PointCalibration(
        mechanism=nominal.with_params(jnp.asarray(y[:n])), params=y[:n], rotation=np.asarray(rot),
        translation=np.asarray(t), poses=np.asarray(poses)[: data.n_poses], start_poses=starts[2],
        fitted=starts[3], status=status_name(res.status), n_steps=int(res.n_evaluations), chi2=float(r @ r),
        assessment=assessment, residuals_um=(data.points - np.asarray(pts)[:n_pts]) / UM, determination=det)


def _assess(jac: np.ndarray, r: np.ndarray, names: tuple[str, ...], det: Determination) -> CalibrationAssessment:
    """χ², rank, identifiability and covariance of a whitened least-squares fit whose update was
    restricted to ``det``'s determined directions."""
    m_rows, n = jac.shape
    warnings: list[str] = []
    if not (np.all(np.isfinite(jac)) and np.all(np.isfinite(r))):
        warnings.append("non-finite residuals at the solution: forward kinematics failed at a pose (a reading "
                        "outside the workspace, or a file in other units)")
        nan = np.full(n, np.nan)
        return CalibrationAssessment("nonfinite", 0, n, float("inf"), np.zeros(n, bool), nan, [], [], float("nan"),
                                     m_rows - n, float("nan"), float("nan"), warnings, np.full((n, n), np.nan))
    norms = np.linalg.norm(jac, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    s_scaled = np.linalg.svd(jac / norms, compute_uv=False)
    _, s, vt = np.linalg.svd(jac, full_matrices=False)
    rank = int(np.sum(s > RANK_RTOL * s[0]))
    null = vt[rank:]
    identifiable = np.sum(null**2, axis=0) <= IDENTIFIABLE_TOL
    cov = total_covariance(det, restricted_covariance(det, jac[:, None, :]))
    std = np.where(identifiable, np.sqrt(np.maximum(np.diag(cov), 0.0)), np.nan)
    if rank == n:
        identifiable = det.held_share() <= 0.01
    chi2 = float(r @ r)
    dof = m_rows - det.n_determined
    p = float(gammaincc(dof / 2.0, chi2 / 2.0)) if dof > 0 else float("nan")
    low = float(gammainc(dof / 2.0, chi2 / 2.0)) if dof > 0 else float("nan")
    ratio = float(np.sqrt(chi2 / dof)) if dof > 0 else float("nan")
    cond = float(s_scaled[0] / s_scaled[-1]) if s_scaled[-1] > 0 else float("inf")
    if rank < n:
        lost = [names[k] for k in np.flatnonzero(~identifiable)]
        warnings.append(f"the points identify {rank} of {n} unknowns (parameters and registration; condition number "
                        f"{cond:.3g}); not identifiable alone: {lost[:12]}{' …' if len(lost) > 12 else ''}. Measure "
                        "more, and more varied, poses and targets")
    if dof > 0 and p < FIT_P_VALUE:
        warnings.append(f"the point residuals are {ratio:.3g}× what the stated tracker noise explains (χ² = {chi2:.4g} "
                        f"on {dof} degrees of freedom, p = {p:.2g}): wrong units (mm), a wrong σ, a target's "
                        "coordinates off, or an effect the model lacks")
    if dof > 0 and low < FIT_P_VALUE:
        warnings.append(f"the point residuals are smaller than the stated tracker noise allows (χ² = {chi2:.4g} on "
                        f"{dof} degrees of freedom, p = {low:.2g}): the noise is overstated, and every reported "
                        "uncertainty with it")
    if rank == n and det.n_determined < n:
        held = describe_held(det, names, ())
        warnings.append(f"the points determine {det.n_determined} of {n} directions of the parameters and "
                        "registration to better than half the prior scale (0.5 mm for a length, 0.5 mrad for an angle: "
                        "the as-built spread); the "
                        f"other {n - det.n_determined} are held at nominal: {'; '.join(held[:6])}"
                        f"{' …' if len(held) > 6 else ''}. Each std includes the prior's share on the held "
                        "directions; measure more varied poses to determine them")
    poor = dof > 0 and (p < FIT_P_VALUE or low < FIT_P_VALUE)
    status = ("rank_deficient" if rank < n else "poor_fit" if poor
              else "partly_determined" if det.n_determined < n else "ok")
    return CalibrationAssessment(status, rank, n, cond, identifiable, std, [], [], chi2, dof, p, ratio, warnings, cov,
                                 det.n_determined)


def implied_point_pose_errors(
    mechanism: AbstractMechanism, data: PointData, targets: TrackerTargets, rotation, translation
) -> Float[np.ndarray, "k 6"]:
    """At each pose where a rigid fit exists (≥ 3 targets), ``mechanism``'s pose for the readings
    minus the rigid-fit pose in B under the registration ``rotation, translation`` (µm, ″): what
    :func:`~stewart_jax.calibration._assessment.implied_pose_errors` is for pose data."""
    from .._units import error_in_report_units

    rigid, fitted = rigid_poses(data, targets, np.asarray(rotation), np.asarray(translation),
                                np.asarray(mechanism.v0))
    fk = forward_kinematics(mechanism, jnp.asarray(data.readings[fitted]), jnp.asarray(rigid[fitted]))
    return np.asarray(error_in_report_units(np.asarray(fk.poses) - rigid[fitted]))
