"""Compensation campaigns measured as a laser tracker's target points: the points file of the
points calibration with the telescope's attitude on each row, turned into pose offsets.

Kabsch W., 1976, "A solution for the best rotation to relate two sets of vectors" (Acta Cryst.
A32): the tracker frame is registered to the hexapod's base frame by the rigid fit of the base
references, and each attitude's optic pose is the rigid fit of its platform targets (the start
values of the points calibration, :mod:`stewart_jax.calibration`). The pose the readings command
is the forward kinematics of the geometry; the correction at the attitude is the commanded pose
minus the measured one, in the controller's units (µm, degrees, ``Rx(u)·Ry(v)·Rz(w)``).

NOTE: the correction is the difference of the two positions in the controller's coordinates,
the first-order inverse of the measured displacement; the second-order term (angle × translation)
is below 0.01 µm at the published tables' sizes (0.04° × 3 mm).
"""

from __future__ import annotations

import os

import jax
import jax.numpy as jnp
import numpy as np

from .._math import rotation_matrix
from ..calibration._csv import csv_rows
from ..calibration._points import REFERENCE_POSE, PointData, TrackerTargets, start_values, tracker_covariance
from ..calibration._points_io import read_points_csv
from ..mechanism._abstract import AbstractMechanism
from ..mechanism._kinematics import forward_kinematics
from ._apply import offsets_to_poses, poses_to_offsets
from ._campaign import ATTITUDE_COLUMNS, Campaign, attitude_grid, check_campaign
from ._table import CompensationTable


def points_campaign(data: PointData, targets: TrackerTargets, mechanism: AbstractMechanism,
                    attitudes: dict[str, np.ndarray]) -> tuple[Campaign, tuple[str, ...]]:
    """The campaign of a points run: per pose (``attitudes``: per-pose arrays under
    ``elevation_deg``, ``rotation_deg`` and optionally ``azimuth_deg``, ``temperature_degC``),
    the correction = commanded − measured position (µm, deg). Poses with fewer than three
    targets seen cannot give a pose and are left out; their names are returned."""
    _, _, poses, fitted = start_values(data, targets, mechanism)
    fk = forward_kinematics(mechanism, jnp.asarray(data.readings))
    ok = fitted & np.asarray(fk.converged)
    if not ok.any():
        raise ValueError("no pose of the points campaign has three targets seen (and converged forward "
                         "kinematics): none gives a pose offset")
    correction = (np.asarray(poses_to_offsets(np.asarray(fk.poses)[ok]))
                  - np.asarray(poses_to_offsets(poses[ok])))
    n = len(ok)
    get = {c: np.asarray(attitudes.get(c, np.zeros(n)), dtype=np.float64)[ok] for c in ATTITUDE_COLUMNS}
    camp = Campaign(get["elevation_deg"], get["rotation_deg"], get["azimuth_deg"], get["temperature_degC"],
                    correction, "azimuth_deg" in attitudes, "temperature_degC" in attitudes)
    check_campaign(camp, "points campaign")
    return camp, tuple(p for p, k in zip(data.pose_names, ok, strict=True) if not k)


def read_points_campaign(path: str | os.PathLike[str], targets: TrackerTargets,
                         mechanism: AbstractMechanism) -> tuple[Campaign, tuple[str, ...]]:
    """A points file (``pose, target, q1..q6, x, y, z`` in the tracker's frame, mm; base
    references on rows ``ref``) whose platform rows also carry ``elevation_deg, rotation_deg``
    [``azimuth_deg, temperature_degC``], equal on the rows of one pose: :func:`points_campaign`."""
    data = read_points_csv(path, targets, reading_unit=mechanism.reading_unit)
    rows, header = csv_rows(path)
    cols = [c for c in ATTITUDE_COLUMNS if c in header]
    for need in ATTITUDE_COLUMNS[:2]:
        if need not in cols:
            raise ValueError(f"{path}: a points campaign needs the column {need!r} on every platform row")
    per_pose: dict[str, np.ndarray] = {}
    for line, r in enumerate(rows[1:], start=2):
        if not any(c.strip() for c in r) or r[header.index("pose")].strip() == REFERENCE_POSE:
            continue
        try:
            values = np.array([float(r[header.index(c)]) for c in cols])
        except ValueError:
            raise ValueError(f"{path}, line {line}: a missing or non-numeric attitude ({', '.join(cols)})") from None
        pose = r[header.index("pose")].strip()
        if pose in per_pose and np.any(per_pose[pose] != values):
            raise ValueError(f"{path}, line {line}: pose {pose!r} has an attitude that disagrees with its other "
                             "rows; rows of one pose repeat it")
        per_pose[pose] = values
    att = np.stack([per_pose[p] for p in data.pose_names])
    return points_campaign(data, targets, mechanism, {c: att[:, j] for j, c in enumerate(cols)})


def simulate_points_campaign(
    key: jax.Array,
    truth: CompensationTable,
    mechanism: AbstractMechanism,
    targets: TrackerTargets,
    registration: tuple[np.ndarray, np.ndarray],
    elevations_deg,
    rotations_deg,
    temperatures_degC=None,
    *,
    range_um: float = 5.0,
    across_um_per_m: float = 2.5,
) -> tuple[PointData, dict[str, np.ndarray]]:
    """A points campaign: at every attitude of the grid the hexapod reads zero, the optic sits at
    the negative of the truth's correction, and every platform target and base reference is
    measured with the tracker's anisotropic noise (σ ``range_um`` along the line of sight,
    ``across_um_per_m`` per metre across it), the tracker at ``registration`` = ``(R, t)``
    (``p_tracker = R·p_base + t``). Returns the points and the per-pose attitudes."""
    e, r, t = attitude_grid(elevations_deg, rotations_deg, temperatures_degC)
    error = offsets_to_poses(-np.asarray(truth.offsets(e, r, 0.0, t)))
    rot, tr = (np.asarray(x, dtype=np.float64) for x in registration)
    m, k = len(e), len(targets.platform)
    v0 = np.asarray(mechanism.v0)
    body = np.einsum("mij,kj->mki", np.asarray(rotation_matrix(error[:, 3:])), targets.platform)
    exact = (body + np.asarray(error[:, None, :3]) + v0) @ rot.T + tr
    refs = targets.base @ rot.T + tr
    pts = np.concatenate([exact.reshape(-1, 3), refs])
    chol = np.linalg.cholesky(tracker_covariance(pts, range_um, across_um_per_m))
    noisy = pts + np.einsum("nij,nj->ni", chol, np.asarray(jax.random.normal(key, pts.shape, dtype=jnp.float64)))
    data = PointData(tuple(str(j + 1) for j in range(m)), np.zeros((m, 6)), np.repeat(np.arange(m), k),
                     np.tile(np.arange(k), m), noisy[: m * k], np.arange(len(targets.base)), noisy[m * k:])
    att = {"elevation_deg": e, "rotation_deg": r}
    if temperatures_degC is not None:
        att["temperature_degC"] = t
    return data, att


def points_campaign_csv(data: PointData, targets: TrackerTargets, attitudes: dict[str, np.ndarray]) -> str:
    """A points file with the attitude columns (readings in mm; base references first)."""
    cols = [c for c in ATTITUDE_COLUMNS if c in attitudes]
    lines = [",".join(["pose", "target", *(f"q{i}" for i in range(1, 7)), "x", "y", "z", *cols])]
    for i, p in zip(data.reference_index, data.references, strict=True):
        lines.append(",".join([REFERENCE_POSE, targets.base_names[i]] + [""] * 6 + [repr(float(x)) for x in p]
                              + [""] * len(cols)))
    for j, k, p in zip(data.pose_index, data.target_index, data.points, strict=True):
        lines.append(",".join([data.pose_names[j], targets.platform_names[k]]
                              + [repr(float(x)) for x in data.readings[j]] + [repr(float(x)) for x in p]
                              + [repr(float(attitudes[c][j])) for c in cols]))
    return "\n".join(lines) + "\n"
