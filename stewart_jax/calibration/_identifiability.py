"""Identifiability of the calibration parameters from a pose set.

Hollerbach J. M., Wampler C. W., "The calibration index and taxonomy for robot kinematic
calibration methods", Int. J. Robotics Research 15(6), 1996 (scaled identification Jacobian,
its singular values, unidentifiable combinations); observability indices O1 of Borm J.-H. &
Menq C.-H., Int. J. Robotics Research 10(1), 1991 (geometric mean of the singular values),
O2 of Driels M. R. & Pathre U. S., IEEE Trans. Robotics and Automation 6(2), 1990 (inverse
condition number), O3 (minimum singular value) and O4 (noise amplification index σ_min²/σ_max)
of Nahvi A. & Hollerbach J. M., Proc. IEEE ICRA 1996.

The identification Jacobian is ``J = ∂IK(P'_j, u)/∂u`` stacked over poses (6m × n, the
negative of ∂E/∂u of Wang et al. 2018, eq. 8). The residual noise comes from the pose measurement:
``e_j = q'_j − IK(P'_j, u)`` with ``P'_j = P_j + δP_j`` gives ``δe_j = −J_P,j·δP_j``, so each
pose's six residuals have covariance ``C_j = J_P,j·Σ_P·J_P,jᵀ`` (``J_P`` the kinematic
Jacobian). The unweighted least-squares estimate of the paper then has the sandwich covariance
``(JᵀJ)⁺·Jᵀ·C·J·(JᵀJ)⁺``, which is ``σ²(JᵀJ)⁻¹`` for i.i.d. stroke noise.
"""

from __future__ import annotations

from typing import NamedTuple

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._checks import to_device
from ..mechanism._abstract import AbstractMechanism
from ..mechanism._kinematics import ik_and_jacobian
from ._problem import ARCSEC, UM


@eqx.filter_jit
def identification_jacobian(geometry: AbstractMechanism, poses: Float[Array, "m 6"]) -> Float[Array, "6m n"]:
    """``∂IK(P_j, u)/∂u`` at ``u = geometry.params``, stacked over the poses (reading unit per
    parameter unit); one compiled program per family and pose count, shared by the report, the
    χ² and the predicted control error."""
    return geometry.parameter_jacobian(poses)


def pose_noise_covariance(sigma_um: float, sigma_arcsec: float) -> Float[Array, "6 6"]:
    """Diagonal covariance of a measured pose (mm², rad²)."""
    return jnp.diag(jnp.array([(sigma_um * UM) ** 2] * 3 + [(sigma_arcsec * ARCSEC) ** 2] * 3))


def reading_noise_covariance(
    geometry: AbstractMechanism, poses: Float[Array, "m 6"], pose_cov: Float[Array, "6 6"]
) -> Float[Array, "m 6 6"]:
    """``C_j = J_P,j·Σ_P·J_P,jᵀ``: covariance of the six stroke residuals of each pose."""
    jp = ik_and_jacobian(geometry, poses)[2]
    return jp @ pose_cov @ jnp.swapaxes(jp, -1, -2)


class KinematicSnapshot(NamedTuple):
    """What the assessments need of a mechanism at a pose set, as NumPy arrays, from one compiled
    program per mechanism type and shape (:func:`kinematic_snapshot`)."""

    readings: np.ndarray  # (m, 6) the inverse kinematics (reading unit)
    reachable: np.ndarray  # (m,) bool: every leg assembles at the pose
    noise: np.ndarray  # (m, 6, 6) the stroke noise covariance C_j (reading unit²)
    jacobian: np.ndarray  # (6m, n) the identification Jacobian ∂IK/∂u
    pose_jacobian: np.ndarray  # (m, 6, 6) the kinematic Jacobian J_P = ∂IK/∂P


def kinematic_snapshot(
    geometry: AbstractMechanism, poses: Float[Array, "m 6"], sigma_um: float = 0.1, sigma_arcsec: float = 0.1
) -> KinematicSnapshot:
    """Readings, reachability, stroke noise covariance, identification and kinematic Jacobians at
    ``poses``.

    NOTE: one program serves the command line's reachability check, the determination at the
    nominal geometry, the assessment of the calibrated one and the predicted control error (the
    noise levels are arguments of it, not constants): a warm ``calibrate`` traces and lowers it
    once instead of four programs."""
    out = _kinematic_snapshot(geometry, to_device(np.asarray(poses, np.float64)), np.asarray(sigma_um, np.float64),
                              np.asarray(sigma_arcsec, np.float64))
    return KinematicSnapshot(*(np.asarray(x) for x in out))


def noise_and_jacobian(
    geometry: AbstractMechanism, poses: Float[Array, "m 6"], sigma_um: float, sigma_arcsec: float
) -> tuple[Float[np.ndarray, "m 6 6"], Float[np.ndarray, "6m n"]]:
    """The stroke noise covariance and the identification Jacobian at ``poses``, as NumPy arrays
    (:func:`kinematic_snapshot`)."""
    snap = kinematic_snapshot(geometry, poses, sigma_um, sigma_arcsec)
    return snap.noise, snap.jacobian


@eqx.filter_jit
def _kinematic_snapshot(geometry, poses, sigma_um, sigma_arcsec):
    sol = geometry.solve_inverse_kinematics(poses)
    jp = ik_and_jacobian(geometry, poses)[2]
    cov = jp @ pose_noise_covariance(sigma_um, sigma_arcsec) @ jnp.swapaxes(jp, -1, -2)
    return sol.readings, sol.reachable, cov, identification_jacobian(geometry, poses), jp


class IdentifiabilityReport(NamedTuple):
    """See :func:`identifiability_report`. Lengths in mm, angles in rad unless named."""

    singular_values: np.ndarray
    """Singular values of the column-scaled Jacobian, descending (dimensionless)."""
    condition_number: float
    rank: int
    """Numerical rank at ``rtol`` relative to the largest singular value."""
    unidentifiable: np.ndarray
    """``(n − rank, n)``: parameter combinations (unit vectors in the parameters' units) the poses
    cannot see."""
    observability: dict[str, float]
    """O1 (Borm & Menq), O2 (Driels & Pathre), O3 and O4 (Nahvi & Hollerbach)."""
    param_cov: np.ndarray
    """``(n, n)`` predicted covariance of the least-squares estimate (the parameters' units, e.g.
    mm² or mm·rad), on the identifiable subspace (pseudo-inverse)."""
    param_std: np.ndarray
    """``(n,)`` square roots of the diagonal of ``param_cov`` (each parameter's unit)."""


def identifiability_report(
    geometry: AbstractMechanism,
    poses: Float[Array, "m 6"],
    sigma_um: float = 0.1,
    sigma_arcsec: float = 0.1,
    rtol: float = 1e-9,
) -> IdentifiabilityReport:
    """Singular values, condition number, observability indices, unidentifiable
    combinations and the predicted parameter covariance of a pose set.

    The Jacobian's columns are scaled to unit norm before the SVD (Hollerbach & Wampler's
    recommendation when parameters share a unit and no prior scale is known), so the
    singular values and indices do not depend on how far each joint is from the origin.
    The observability indices use the ``n`` (36 for the 6-PSS) scaled singular values: O1 =
    (Π σ_i)^(1/n)/√(6m), O2 = σ_min/σ_max, O3 = σ_min, O4 = σ_min²/σ_max.
    """
    return report_from_arrays(*noise_and_jacobian(geometry, poses, sigma_um, sigma_arcsec), rtol)


def report_from_arrays(C: np.ndarray, J: np.ndarray, rtol: float = 1e-9) -> IdentifiabilityReport:
    """:func:`identifiability_report` from the stroke noise covariance ``C`` ``(m, 6, 6)`` and the
    identification Jacobian ``J`` ``(6m, n)`` already at hand (a :class:`KinematicSnapshot`'s)."""
    norms = np.linalg.norm(J, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    s = np.linalg.svd(J / norms, compute_uv=False)
    _, s_raw, vt = np.linalg.svd(J, full_matrices=False)  # vt is n × n either way (J is tall)
    rank = int(np.sum(s_raw > rtol * s_raw[0]))
    n = J.shape[1]
    smin = s[-1]
    observability = {
        "O1": float(np.exp(np.mean(np.log(np.maximum(s, 1e-300)))) / np.sqrt(J.shape[0])),
        "O2": float(smin / s[0]),
        "O3": float(smin),
        "O4": float(smin**2 / s[0]),
    }
    # NOTE: the readings' covariance is block diagonal (one 6 × 6 block per pose), so
    # Jᵀ C J = Σ_j J_jᵀ C_j J_j is formed block by block: memory n × n plus the Jacobian, linear
    # in the poses (the dense 6m × 6m matrix is 27 GiB at 10⁴ poses).
    m = C.shape[0]
    Jb = J.reshape(m, 6, n)
    JtCJ = np.einsum("mkn,mkl,mlp->np", Jb, C, Jb, optimize=True)
    JtJ_pinv = np.linalg.pinv(J.T @ J, rcond=rtol**2, hermitian=True)
    cov = JtJ_pinv @ JtCJ @ JtJ_pinv
    cov = 0.5 * (cov + cov.T)
    return IdentifiabilityReport(
        singular_values=s,
        condition_number=float(s[0] / smin) if smin > 0 else float("inf"),
        rank=rank,
        unidentifiable=vt[rank:n],
        observability=observability,
        param_cov=cov,
        param_std=np.sqrt(np.maximum(np.diag(cov), 0.0)),
    )


def control_error_sensitivity(
    calibrated: AbstractMechanism, targets: Float[Array, "k 6"]
) -> Float[np.ndarray, "k 6 n"]:
    """``∂P_reached/∂u_cal`` at each target: how an error in the calibrated parameters moves
    the pose the true mechanism reaches when commanded with ``IK(P, u_cal)``.

    To first order ``δP = J_P⁻¹·G_u·δu`` with ``G_u = ∂IK(P, u)/∂u`` and ``J_P = ∂IK/∂P``.
    """
    snap = kinematic_snapshot(calibrated, targets)
    return np.linalg.solve(snap.pose_jacobian, snap.jacobian.reshape(len(snap.reachable), 6, -1))


def predicted_control_error_std(
    calibrated: AbstractMechanism, targets: Float[Array, "n 6"], param_cov: np.ndarray
) -> np.ndarray:
    """``(n, 6)`` predicted standard deviation of the control error at each target, in µm
    (dx, dy, dz) and ″ (φ, θ, ψ): the Cramér–Rao floor of an unbiased estimator propagated
    through :func:`control_error_sensitivity`."""
    M = control_error_sensitivity(calibrated, targets)
    var = np.sum((M @ param_cov) * M, axis=-1)
    std = np.sqrt(np.maximum(var, 0.0))
    return np.concatenate([std[:, :3] / UM, std[:, 3:] / ARCSEC], axis=-1)


class PosePlan(NamedTuple):
    """A pose plan chosen by :func:`plan_poses_optimal`.

    - ``poses``: ``(m, 6)`` chosen poses (mm, rad).
    - ``index``: ``(m,)`` their indices in the candidate set.
    - ``criterion``: the criterion's value at the end (``log det`` of the scaled information
      matrix for ``"O1"``, its smallest eigenvalue for ``"O3"``).
    - ``history``: criterion after the greedy phase and after each exchange sweep.
    """

    poses: np.ndarray
    index: np.ndarray
    criterion: float
    history: list[float]


def _criterion(info: np.ndarray, kind: str) -> float:
    if kind == "O1":
        sign, logdet = np.linalg.slogdet(info)
        return float(logdet) if sign > 0 else -np.inf
    return float(np.linalg.eigvalsh(info)[0])


def plan_poses_optimal(
    geometry: AbstractMechanism,
    candidates: Float[Array, "k 6"],
    m: int,
    criterion: str = "O1",
    exchange_sweeps: int = 2,
) -> PosePlan:
    """Choose ``m`` of the ``candidates`` to maximise an observability index of the scaled
    identification Jacobian: ``"O1"`` (Borm & Menq; D-optimal: maximise ``log det JᵀJ``, which
    is ``2n·log O1`` up to a constant) or ``"O3"`` (Nahvi & Hollerbach; E-optimal: maximise the
    smallest singular value).

    Greedy construction followed by Fedorov-style exchange sweeps. For O1 each candidate's
    gain is the rank-6 update ``log det(I₆ + J_k A⁻¹ J_kᵀ)``, evaluated for all candidates in
    one batched computation; the exchange phase swaps a chosen pose for the candidate that
    most increases the criterion, until no swap helps or the sweeps run out.

    NOTE: the Jacobian columns are scaled once, by their norms over the whole candidate set,
    so that the criterion compares plans on a common scale. A small ridge ``1e-9·I`` makes the
    first greedy steps (fewer than n/6 poses, rank < n) well defined.
    """
    if criterion not in ("O1", "O3"):
        raise ValueError(f"criterion must be 'O1' or 'O3', got {criterion!r}")
    cand = np.asarray(candidates, dtype=np.float64)
    n = geometry.n_params
    if m * 6 < n or m > len(cand):
        raise ValueError(
            f"m must satisfy {-(-n // 6)} ≤ m ≤ {len(cand)} ({n} parameters, 6 residuals per pose), got {m}"
        )
    J = np.asarray(identification_jacobian(geometry, jnp.asarray(cand))).reshape(len(cand), 6, n)
    scale = np.linalg.norm(J.reshape(-1, n), axis=0)
    J = J / np.where(scale > 0, scale, 1.0)
    Jt = np.swapaxes(J, 1, 2)
    per_pose = Jt @ J
    ridge = 1e-9 * np.eye(n)

    def gains(info):
        if criterion == "O1":
            ainv = np.linalg.inv(info)
            small = np.eye(6) + (J @ ainv) @ Jt
            return np.linalg.slogdet(small)[1]
        return np.linalg.eigvalsh(info[None] + per_pose)[:, 0]

    chosen: list[int] = []
    info = ridge.copy()
    for _ in range(m):
        g = gains(info)
        g[chosen] = -np.inf
        k = int(np.argmax(g))
        chosen.append(k)
        info = info + per_pose[k]
    history = [_criterion(info - ridge, criterion)]
    for _ in range(exchange_sweeps):
        improved = False
        for pos in range(m):
            base = info - per_pose[chosen[pos]]
            g = gains(base)
            g[chosen] = -np.inf
            k = int(np.argmax(g))
            if _criterion(base + per_pose[k] - ridge, criterion) > _criterion(info - ridge, criterion) + 1e-12:
                chosen[pos] = k
                info = base + per_pose[k]
                improved = True
        history.append(_criterion(info - ridge, criterion))
        if not improved:
            break
    idx = np.array(chosen)
    return PosePlan(cand[idx], idx, history[-1], history)


def calibration_uncertainty(
    calibrated: AbstractMechanism,
    poses: Float[Array, "m 6"],
    sigma_um: float = 0.1,
    sigma_arcsec: float = 0.1,
    evaluation_poses: Float[Array, "n 6"] | None = None,
) -> dict[str, np.ndarray | float | int]:
    """Uncertainty of a least-squares calibration from ``poses`` measured with pose noise
    σ = ``sigma_um`` µm / ``sigma_arcsec`` ″, linearised at the calibrated geometry.

    Returns ``param_std`` (n, each parameter's unit), ``rank`` and ``condition_number`` of the identification
    Jacobian, and ``control_error_std`` ``(n, 6)`` (µm, ″) — the predicted standard deviation of
    the control error at ``evaluation_poses`` (default: the calibration poses); ±2 of it is the
    ~95 % band of an unbiased calibration.
    """
    rep = identifiability_report(calibrated, poses, sigma_um, sigma_arcsec)
    ev = poses if evaluation_poses is None else evaluation_poses
    return {
        "param_std": rep.param_std,
        "rank": rep.rank,
        "condition_number": rep.condition_number,
        "control_error_std": predicted_control_error_std(calibrated, ev, rep.param_cov),
    }
