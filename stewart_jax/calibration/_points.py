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

import json
import os
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.scipy.special import gammainc, gammaincc
from jaxtyping import Array, Float, Int, PRNGKeyArray

from .._math import rotation_matrix
from .._units import READING_UNITS, UM, check_unit
from ..mechanism._abstract import AbstractMechanism
from ..mechanism._kinematics import forward_kinematics
from ._assessment import FIT_P_VALUE, IDENTIFIABLE_TOL, RANK_RTOL, CalibrationAssessment
from ._csv import DIRECTION_COLUMNS, STROKE_COLUMNS, csv_rows, format_degrees, parse_degrees

POINT_COLUMNS = ("pose", "target", *STROKE_COLUMNS, "x", "y", "z")
"""The columns a points file must have (``pose`` = ``ref`` on a base reference's row)."""
REFERENCE_POSE = "ref"
DEFAULT_TRACKER_SIGMA = (5.0, 2.5)
"""σ along the line of sight (µm) and across it (µm per metre of distance), the default noise."""
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

    - ``pose_names``: ``m`` labels (the file's ``pose`` column); ``strokes``: ``Float[ndarray, "m 6"]``.
    - ``pose_index``, ``target_index``: ``Int[ndarray, "n"]``, each platform measurement's pose and
      target (index into :attr:`TrackerTargets.platform`); ``points``: ``Float[ndarray, "n 3"]``.
    - ``reference_index``: ``Int[ndarray, "r"]`` (into :attr:`TrackerTargets.base`);
      ``references``: ``Float[ndarray, "r 3"]``.
    - optional, per pose (the pose CSV's columns ``dir1..dir6``, ``temperature``, ``time``):
      ``directions``: ``Float[ndarray, "m 6"]`` (±1), ``temperature``: ``Float[ndarray, "m"]`` (°C),
      ``time``: ``Float[ndarray, "m"]`` (s).
    """

    pose_names: tuple[str, ...]
    strokes: np.ndarray
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


# ---- files ---------------------------------------------------------------------------------------


def read_targets(path: str | os.PathLike[str]) -> TrackerTargets:
    """Read a targets file ``{"platform_targets": {NAME: [x, y, z]}, "base_references": {NAME: [x, y, z]}}``
    (mm), refusing a missing key, a non-finite or non-3-vector coordinate, and fewer than three
    base references (each error names the entry)."""
    try:
        with open(path, encoding="utf-8") as f:
            d = json.load(f)
    except json.JSONDecodeError as e:
        raise ValueError(f"{path}: not valid JSON ({e.msg} at line {e.lineno})") from None
    if not isinstance(d, dict):
        raise ValueError(f"{path}: expected an object with 'platform_targets' and 'base_references'")
    out = []
    for key in ("platform_targets", "base_references"):
        entries = d.get(key)
        if not isinstance(entries, dict) or not entries:
            raise ValueError(f"{path}: {key!r} must be a non-empty object NAME -> [x, y, z] (mm)")
        names, xyz = [], []
        for name, v in entries.items():
            a = np.asarray(v, dtype=np.float64) if isinstance(v, list) else np.full(1, np.nan)
            if a.shape != (3,) or not np.all(np.isfinite(a)):
                raise ValueError(f"{path}: {key}[{name!r}] must be three finite numbers [x, y, z] (mm), got {v!r}")
            names.append(str(name))
            xyz.append(a)
        out += [tuple(names), np.stack(xyz)]
    if len(out[2]) < 3:
        raise ValueError(f"{path}: {len(out[2])} base reference(s); at least three define the base frame "
                         "in the tracker's frame")
    if np.linalg.matrix_rank(out[3] - out[3].mean(0), tol=1e-6) < 2:
        raise ValueError(f"{path}: the base references are collinear; they cannot define the base frame")
    return TrackerTargets(*out)


def write_targets(path: str | os.PathLike[str], targets: TrackerTargets) -> None:
    """Write ``targets`` as a targets file (atomic; full float64 precision)."""
    from .._files import json_text, write_text_atomic

    d = {"platform_targets": {n: [float(x) for x in p] for n, p in zip(targets.platform_names, targets.platform,
                                                                        strict=True)},
         "base_references": {n: [float(x) for x in p] for n, p in zip(targets.base_names, targets.base, strict=True)}}
    write_text_atomic(path, json_text(d))


def read_points_csv(path: str | os.PathLike[str], targets: TrackerTargets, *, reading_unit: str = "mm") -> PointData:
    """Read a points file (columns ``pose,target,q1..q6,x,y,z``; others ignored) against ``targets``.
    ``reading_unit``: the mechanism's (``"rad"``: ``q1``…``q6`` are crank angles in degrees, as in
    the pose CSV, returned in rad).

    Everything is checked before any work, each error on one line naming the file's line: a
    missing column, a non-numeric cell, a target name missing from the targets file, a repeated
    (pose, target) row, a pose whose readings disagree between its rows, fewer than three base
    references, and coordinates in metres (distances between targets 1000× shorter than their
    nominal ones).

    The pose CSV's optional per-pose columns ``dir1..dir6`` (±1, all six), ``temperature`` (°C) and
    ``time`` (s) are read when present; rows of one pose repeat them, as they repeat the readings.
    """
    angular = check_unit(reading_unit, "reading_unit", READING_UNITS) == "rad"
    rows, header = csv_rows(path)
    missing = [c for c in POINT_COLUMNS if c not in header]
    if missing:
        raise ValueError(f"{path}: missing column(s) {missing}; a points file has {list(POINT_COLUMNS)}")
    col = {c: header.index(c) for c in POINT_COLUMNS}
    dirs = [c for c in DIRECTION_COLUMNS if c in header]
    if dirs and len(dirs) != 6:
        raise ValueError(f"{path}: direction columns must be all of dir1..dir6, found {dirs}")
    conditions = tuple(dirs) + tuple(c for c in ("temperature", "time") if c in header)
    col.update({c: header.index(c) for c in conditions})
    platform = {n: i for i, n in enumerate(targets.platform_names)}
    base = {n: i for i, n in enumerate(targets.base_names)}
    seen: dict[tuple[str, str], int] = {}
    pose_rows: dict[str, tuple[int, np.ndarray]] = {}
    pose_id: dict[str, int] = {}
    pose_names: list[str] = []
    pidx, tidx, pts, ridx, refs, ref_lines, point_lines = [], [], [], [], [], [], []
    for line, r in enumerate(rows[1:], start=2):
        if not any(c.strip() for c in r):
            continue
        if len(r) != len(header):
            raise ValueError(f"{path}, line {line}: {len(r)} cells for {len(header)} columns")
        pose, target = r[col["pose"]].strip(), r[col["target"]].strip()
        if not pose or not target:
            raise ValueError(f"{path}, line {line}: empty 'pose' or 'target' cell")
        xyz = np.array([_number(path, line, c, r[col[c]]) for c in ("x", "y", "z")])
        if (pose, target) in seen:
            raise ValueError(f"{path}, line {line}: duplicate row: pose {pose!r}, target {target!r} was already "
                             f"measured on line {seen[(pose, target)]}")
        seen[(pose, target)] = line
        if pose == REFERENCE_POSE:
            if target not in base:
                raise ValueError(f"{path}, line {line}: base reference {target!r} is not in the targets file's "
                                 f"base_references {list(targets.base_names)}")
            if any(r[col[c]].strip() for c in STROKE_COLUMNS):
                raise ValueError(f"{path}, line {line}: a base reference row ('{REFERENCE_POSE}') has readings; "
                                 "leave q1..q6 empty (is the pose label wrong?)")
            ridx.append(base[target])
            refs.append(xyz)
            ref_lines.append(line)
            continue
        if target not in platform:
            raise ValueError(f"{path}, line {line}: platform target {target!r} is not in the targets file's "
                             f"platform_targets {list(targets.platform_names)}")
        q = np.array([_number(path, line, c, r[col[c]], degrees=angular) for c in STROKE_COLUMNS])
        cond = np.array([_number(path, line, c, r[col[c]]) for c in conditions])
        if dirs and not np.all(np.isin(cond[:6], (-1.0, 1.0))):
            raise ValueError(f"{path}, line {line}: dir1..dir6 must hold +1 or -1")
        if pose in pose_rows:
            first, q0, cond0 = pose_rows[pose]
            if np.max(np.abs(q - q0)) > _READING_ATOL:
                j = int(np.argmax(np.abs(q - q0)))
                unit = "°" if angular else " mm"
                a, b = (np.degrees([q[j], q0[j]]) if angular else (q[j], q0[j]))
                raise ValueError(f"{path}, line {line}: pose {pose!r} has readings that disagree with its row on "
                                 f"line {first} ({STROKE_COLUMNS[j]}: {float(a)!r}{unit} vs {float(b)!r}{unit}); rows "
                                 "of one pose repeat its readings")
            if np.any(cond != cond0):
                worst = conditions[int(np.argmax(cond != cond0))]
                raise ValueError(f"{path}, line {line}: pose {pose!r} has a {worst!r} that disagrees with its row on "
                                 f"line {first}; rows of one pose repeat it")
        else:
            pose_rows[pose] = (line, q, cond)
            pose_id[pose] = len(pose_names)
            pose_names.append(pose)
        pidx.append(pose_id[pose])
        tidx.append(platform[target])
        pts.append(xyz)
        point_lines.append(line)
    if len(set(ridx)) < 3:
        raise ValueError(f"{path}: {len(set(ridx))} base reference(s) measured (rows with pose '{REFERENCE_POSE}'); "
                         "at least three define the base frame in the tracker's frame")
    if not pose_names:
        raise ValueError(f"{path}: no platform target rows")
    refs_a, ridx_a = np.stack(refs), np.asarray(ridx)
    _check_millimetres(path, refs_a, targets.base[ridx_a], ref_lines)
    pts_a, pidx_a, tidx_a = np.stack(pts), np.asarray(pidx), np.asarray(tidx)
    for j in range(len(pose_names)):
        rows_j = np.flatnonzero(pidx_a == j)
        if len(rows_j) >= 2:
            _check_millimetres(path, pts_a[rows_j], targets.platform[tidx_a[rows_j]],
                               [point_lines[i] for i in rows_j])
    strokes = np.stack([pose_rows[p][1] for p in pose_names])
    cond = np.stack([pose_rows[p][2] for p in pose_names])
    k = len(dirs)
    return PointData(tuple(pose_names), strokes, pidx_a, tidx_a, pts_a, ridx_a, refs_a,
                     directions=cond[:, :6] if dirs else None,
                     temperature=cond[:, k] if "temperature" in conditions else None,
                     time=cond[:, conditions.index("time")] if "time" in conditions else None)


def write_points_csv(
    path: str | os.PathLike[str], data: PointData, targets: TrackerTargets, *, reading_unit: str = "mm"
) -> None:
    """Write ``data`` as a points file (base references first; atomic; full precision).
    ``reading_unit``: the mechanism's (``"rad"``: the readings are crank angles, written in degrees
    that :func:`read_points_csv` turns back into exactly the same radians)."""
    from .._files import write_text_atomic

    angular = check_unit(reading_unit, "reading_unit", READING_UNITS) == "rad"
    reading = format_degrees if angular else (lambda x: repr(float(x)))

    extra_names, extra = [], []
    if data.directions is not None:
        extra_names += list(DIRECTION_COLUMNS)
        extra.append(np.asarray(data.directions, dtype=np.float64))
    for name, column in (("temperature", data.temperature), ("time", data.time)):
        if column is not None:
            extra_names.append(name)
            extra.append(np.asarray(column, dtype=np.float64)[:, None])
    per_pose = np.concatenate(extra, axis=1) if extra else np.zeros((data.n_poses, 0))
    lines = [",".join(POINT_COLUMNS + tuple(extra_names))]
    for i, p in zip(data.reference_index, data.references, strict=True):
        lines.append(",".join([REFERENCE_POSE, targets.base_names[i]] + [""] * 6 + [repr(float(x)) for x in p]
                              + [""] * len(extra_names)))
    for j, k, p in zip(data.pose_index, data.target_index, data.points, strict=True):
        lines.append(",".join([data.pose_names[j], targets.platform_names[k]]
                              + [reading(x) for x in data.strokes[j]] + [repr(float(x)) for x in p]
                              + [repr(float(x)) for x in per_pose[j]]))
    write_text_atomic(path, "\n".join(lines) + "\n")


def _number(path, line, column, cell, degrees: bool = False) -> float:
    """A cell's number (``degrees``: a degree cell, returned in rad by :func:`parse_degrees`)."""
    try:
        x = parse_degrees(cell) if degrees else float(cell)
    except (ValueError, ArithmeticError):
        raise ValueError(f"{path}, line {line}, column {column!r}: {cell!r} is not a number") from None
    if not np.isfinite(x):
        raise ValueError(f"{path}, line {line}, column {column!r}: {cell!r} is not finite")
    return x


def _check_millimetres(path, measured, nominal, lines) -> None:
    """Distances between measured points against their nominal ones: 1000× shorter is metres."""
    i, j = np.triu_indices(len(measured), 1)
    dn = np.linalg.norm(nominal[i] - nominal[j], axis=1)
    dm = np.linalg.norm(measured[i] - measured[j], axis=1)
    ok = dn > 1.0
    if not np.any(ok):
        return
    ratio = float(np.median(dm[ok] / dn[ok]))
    if ratio < 0.01:
        raise ValueError(f"{path}, lines {lines[0]}–{lines[-1]}: the measured distances between these targets are "
                         f"{ratio:.3g}× their nominal ones — the tracker file is in metres; the points file is "
                         "in mm")


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
        return mechanism.with_params(u).solve_inverse_kinematics(poses).strokes

    @jax.custom_jvp
    def reached(u, strokes, start):
        sol = forward_kinematics(mechanism.with_params(u), strokes, start)
        return jnp.where(sol.converged[:, None], sol.poses, jnp.nan)

    @reached.defjvp
    def _jvp(primals, tangents):
        u, strokes, start = primals
        du, dq, _ = tangents
        poses = reached(u, strokes, start)
        jp = jax.vmap(jax.jacfwd(lambda p: ik(u, p[None])[0]))(poses)  # (m, 6, 6) ∂IK/∂P
        _, dik = jax.jvp(lambda v: ik(v, poses), (u,), (du,))
        return poses, jnp.linalg.solve(jp, (dq - dik)[..., None])[..., 0]

    return reached


class _PointProblem(eqx.Module):
    """The whitened residual of ``y = [u (n), registration correction (6)]`` (see the module docstring)."""

    strokes: Float[Array, "m 6"]
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
        poses = _reached_poses(mechanism)(y[:n], self.strokes, self.start)
        p = poses[self.pose_index]
        in_b = jnp.einsum("nij,nj->ni", rotation_matrix(p[:, 3:]), self.body) + p[:, :3] + mechanism.v0
        return in_b @ rot.T + t, self.ref_body @ rot.T + t, poses

    def jacobian(self, y, mechanism: AbstractMechanism):
        """``∂r/∂y`` (rows as :meth:`residuals`): the chain ``W·∂p̂/∂P·∂P/∂u`` with
        ``∂P/∂u = −(∂IK/∂P)⁻¹·∂IK/∂u`` per pose, and ``W·∂p̂/∂ρ`` for the registration."""
        n = mechanism.n_params
        u, reg = y[:n], y[n:]
        m = mechanism.with_params(u)
        poses = _reached_poses(mechanism)(u, self.strokes, self.start)
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
    fk = forward_kinematics(nominal, jnp.asarray(data.strokes))
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
        strokes=f(_padded(data.strokes, m)), start=f(_padded(poses, m)),
        pose_index=f(_padded(data.pose_index, n_pts)),
        body=f(_padded(targets.platform[data.target_index], n_pts)), points=f(_padded(data.points, n_pts)),
        w_points=f(_padded(tracker_whitening(data.points, range_um, across_um_per_m), n_pts)),
        ref_body=f(targets.base[data.reference_index]), references=f(data.references),
        w_refs=f(tracker_whitening(data.references, range_um, across_um_per_m)),
        rot0=f(rot0), t0=f(t0))


@eqx.filter_jit
def _solve(problem: _PointProblem, nominal: AbstractMechanism, y0, max_steps: int, initial_damping: float):
    from ..optimise._batched_lm import BatchedLevenbergMarquardt

    solver = BatchedLevenbergMarquardt(max_steps=max_steps, initial_damping=initial_damping)
    res = solver.run(lambda y, p: p.residuals(y, nominal), y0, args=problem,
                     jac=lambda y, p: p.jacobian(y, nominal))
    pts, _, poses = problem.predicted(nominal, res.params)
    rot, t = problem.registration(res.params)
    return res, problem.jacobian(res.params, nominal), problem.residuals(res.params, nominal), pts, poses, rot, t


def calibrate_points(
    data: PointData,
    targets: TrackerTargets,
    nominal: AbstractMechanism,
    *,
    range_um: float = DEFAULT_TRACKER_SIGMA[0],
    across_um_per_m: float = DEFAULT_TRACKER_SIGMA[1],
    max_steps: int = 100,
) -> PointCalibration:
    """Calibrate ``nominal``'s parameters and the tracker registration from target points.

    The whitened residual of every platform point and base reference (module docstring) is
    minimised by the Levenberg–Marquardt, from the starts of :func:`start_values`. Poses with one
    or two targets are used. Raises ``ValueError`` when the points are fewer than the unknowns.
    """
    from ..optimise._result import status_name

    n = nominal.n_params
    n_obs = 3 * (len(data.points) + len(data.references))
    if n_obs < n + 6:
        raise ValueError(f"{len(data.points)} points and {len(data.references)} references give {n_obs} residuals "
                         f"for {n + 6} unknowns ({n} parameters + 6 of the registration)")
    starts = start_values(data, targets, nominal)
    problem = _problem(data, targets, nominal, range_um, across_um_per_m, starts)
    y0 = jnp.concatenate([nominal.params, jnp.zeros(6)])
    res, jac, r, pts, poses, rot, t = _solve(problem, nominal, y0, max_steps, _INITIAL_DAMPING)
    y = np.asarray(res.params)
    n_pts, n_pad = len(data.points), problem.points.shape[0]
    rows = np.concatenate([np.arange(3 * n_pts), 3 * n_pad + np.arange(3 * len(data.references))])
    r = np.asarray(r)[rows]
    names = (*nominal.param_names, "reg_x", "reg_y", "reg_z", "reg_rx", "reg_ry", "reg_rz")
    assessment = _assess(np.asarray(jac)[rows], r, names)
    return PointCalibration(
        mechanism=nominal.with_params(jnp.asarray(y[:n])), params=y[:n], rotation=np.asarray(rot),
        translation=np.asarray(t), poses=np.asarray(poses)[: data.n_poses], start_poses=starts[2],
        fitted=starts[3], status=status_name(res.status), n_steps=int(res.n_evaluations), chi2=float(r @ r),
        assessment=assessment, residuals_um=(data.points - np.asarray(pts)[:n_pts]) / UM)


def _assess(jac: np.ndarray, r: np.ndarray, names: tuple[str, ...]) -> CalibrationAssessment:
    """χ², rank, identifiability and covariance of a whitened least-squares fit."""
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
    inv = np.where(np.arange(len(s)) < rank, 1.0 / np.where(s > 0, s, 1.0) ** 2, 0.0)
    cov = (vt.T * inv) @ vt
    std = np.where(identifiable, np.sqrt(np.maximum(np.diag(cov), 0.0)), np.nan)
    chi2 = float(r @ r)
    dof = m_rows - rank
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
    poor = dof > 0 and (p < FIT_P_VALUE or low < FIT_P_VALUE)
    status = "rank_deficient" if rank < n else "poor_fit" if poor else "ok"
    return CalibrationAssessment(status, rank, n, cond, identifiable, std, [], [], chi2, dof, p, ratio, warnings, cov)


def implied_point_pose_errors(
    mechanism: AbstractMechanism, data: PointData, targets: TrackerTargets, rotation, translation
) -> Float[np.ndarray, "k 6"]:
    """At each pose where a rigid fit exists (≥ 3 targets), ``mechanism``'s pose for the readings
    minus the rigid-fit pose in B under the registration ``rotation, translation`` (µm, ″): what
    :func:`~stewart_jax.calibration._assessment.implied_pose_errors` is for pose data."""
    from .._units import error_in_report_units

    rigid, fitted = rigid_poses(data, targets, np.asarray(rotation), np.asarray(translation),
                                np.asarray(mechanism.v0))
    fk = forward_kinematics(mechanism, jnp.asarray(data.strokes[fitted]), jnp.asarray(rigid[fitted]))
    return np.asarray(error_in_report_units(np.asarray(fk.poses) - rigid[fitted]))


# ---- simulation ----------------------------------------------------------------------------------


def default_registration(mechanism: AbstractMechanism) -> tuple[np.ndarray, np.ndarray]:
    """A tracker placement for simulations: the platform's zero-pose centre 2.9 m from the head
    (2.5 m, 1.2 m, −0.9 m in the tracker's frame), the frame turned by (0.3°, −0.2°, 115°) from B."""
    rot = np.asarray(rotation_matrix(jnp.radians(jnp.array([0.3, -0.2, 115.0]))))
    centre = np.array([2500.0, 1200.0, -900.0])
    return rot, centre - rot @ np.asarray(mechanism.v0)


def default_targets(mechanism: AbstractMechanism) -> TrackerTargets:
    """Targets for simulations: six on the platform (two rings of three at its joints' radius and
    mean height, one ring 10 % inside and 20 mm higher) and four on the base (on a circle 10 %
    outside its joints, one 50 mm up)."""
    joints = np.asarray(mechanism.moving_joints(jnp.zeros(6))) - np.asarray(mechanism.v0)
    fixed = mechanism.fixed_joints()
    lower = np.asarray(mechanism.moving_joints(jnp.zeros(6)) if fixed is None else fixed)
    radius = float(np.mean(np.linalg.norm(joints[:, :2], axis=-1)))
    height = float(np.mean(joints[:, 2]))
    ang = np.radians([90.0, 210.0, 330.0])
    ring = np.stack([np.cos(ang), np.sin(ang), np.zeros(3)], -1)
    platform = np.concatenate([ring * radius + [0, 0, height], np.roll(ring, 1, 0) @ _rz(60) * 0.9 * radius
                               + [0, 0, height + 20.0]])
    b_radius = 1.1 * float(np.mean(np.linalg.norm(lower[:, :2], axis=-1)))
    b_height = float(np.mean(lower[:, 2]))
    bang = np.radians([0.0, 90.0, 180.0, 270.0])
    base = np.stack([b_radius * np.cos(bang), b_radius * np.sin(bang), np.full(4, b_height) + [0, 0, 0, 50.0]], -1)
    return TrackerTargets(tuple(f"P{i + 1}" for i in range(6)), platform, tuple(f"B{i + 1}" for i in range(4)), base)


def _rz(deg: float) -> np.ndarray:
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, s, 0], [-s, c, 0], [0, 0, 1.0]])


class SimulatedPoints(NamedTuple):
    """A simulated tracker run: ``data`` (:class:`PointData`), the poses the true mechanism
    reached (``true_poses``, mm, rad), the commanded ``targets`` and the true registration."""

    data: PointData
    true_poses: np.ndarray
    commanded: np.ndarray
    rotation: np.ndarray
    translation: np.ndarray


def simulate_points(
    key: PRNGKeyArray,
    nominal: AbstractMechanism,
    true: AbstractMechanism,
    targets: TrackerTargets,
    commanded: Float[Array, "m 6"],
    *,
    range_um: float = DEFAULT_TRACKER_SIGMA[0],
    across_um_per_m: float = DEFAULT_TRACKER_SIGMA[1],
    registration: tuple[np.ndarray, np.ndarray] | None = None,
    visible: float = 0.7,
) -> SimulatedPoints:
    """Readings ``q = IK(P0, nominal)``, reached poses ``FK(q, true)``, and each platform target seen
    with probability ``visible`` (at least one per pose) at its true position in the tracker's frame
    plus the anisotropic tracker noise; every base reference measured once the same way."""
    if not 0 < visible <= 1:
        raise ValueError(f"visible must be a probability in (0, 1], got {visible}")
    rot, t = default_registration(nominal) if registration is None else registration
    q = np.asarray(nominal.solve_inverse_kinematics(jnp.asarray(commanded)).strokes)
    fk = forward_kinematics(true, jnp.asarray(q), jnp.asarray(commanded))
    if not np.all(np.asarray(fk.converged)):
        raise ValueError("forward kinematics of the true mechanism failed at a commanded pose")
    poses = np.asarray(fk.poses)
    k_vis, k_pts, k_refs = jax.random.split(key, 3)
    m, k = len(poses), len(targets.platform)
    seen = np.asarray(jax.random.uniform(k_vis, (m, k))) < visible
    seen[np.arange(m), np.asarray(jax.random.randint(k_vis, (m,), 0, k))] = True
    pidx, tidx = np.nonzero(seen)
    rots = np.asarray(rotation_matrix(jnp.asarray(poses[pidx, 3:])))
    in_b = np.einsum("nij,nj->ni", rots, targets.platform[tidx]) + poses[pidx, :3] + np.asarray(true.v0)
    exact = in_b @ rot.T + t
    refs_exact = targets.base @ rot.T + t
    noisy = exact + _tracker_noise(k_pts, exact, range_um, across_um_per_m)
    refs = refs_exact + _tracker_noise(k_refs, refs_exact, range_um, across_um_per_m)
    data = PointData(tuple(str(j + 1) for j in range(m)), q, pidx, tidx, noisy, np.arange(len(targets.base)), refs)
    return SimulatedPoints(data, poses, np.asarray(commanded), rot, t)


def _tracker_noise(key, points, range_um, across_um_per_m) -> np.ndarray:
    chol = np.linalg.cholesky(tracker_covariance(points, range_um, across_um_per_m))
    z = np.asarray(jax.random.normal(key, points.shape, dtype=jnp.float64))
    return np.einsum("nij,nj->ni", chol, z)
