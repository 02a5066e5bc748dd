"""What a calibration's data supports: identifiability, duplicates and goodness of fit.

A least-squares calibration (Wang et al. 2018, "Improved cuckoo calibration method of space
telescope secondary mirror adjusting mechanism", Infrared and Laser Engineering 47(5), §1.2)
always returns numbers; whether they mean anything depends on the data. This module answers the
questions an acceptance record needs:

- **Identifiability.** The numerical rank and condition number of the identification Jacobian
  ``∂q/∂u`` at the calibrated parameters; a parameter is *identifiable* when its unit vector
  lies in the Jacobian's row space (the data constrain it alone, not only in combination), and
  only then gets a standard deviation.
- **Duplicates.** Rows measured at the same pose count as independent measurements in the
  covariance and shrink every standard deviation by √k for k copies; they are reported.
- **Goodness of fit.** With the stated pose noise the stroke residuals of pose j have the
  covariance ``C_j = J_j Σ_P J_jᵀ`` (the residual is driven by the pose noise through the
  kinematic Jacobian). The statistic is the generalised-least-squares residual
  ``χ² = min_δ |W (r − A δ)|²`` (``W`` whitens by ``C_j^{-1/2}``, ``A`` the identification
  Jacobian), which has ``6m − rank`` degrees of freedom when the model and σ are right. A tiny
  p-value means wrong units, a wrong σ or an effect the model lacks: the discrepancy workflow
  (``stewart-jax diagnose``) tells them apart.

  NOTE: the plain whitened sum ``Σ_j r_jᵀ C_j⁻¹ r_j`` at the least-squares solution is *not*
  χ²-distributed: the calibration minimises the unweighted S, whose residual weights the
  legs otherwise than ``C⁻¹`` (measured on 24 poses of the paper's mechanism: 203 on 108 degrees
  of freedom, p ≈ 1e-7, for a correct model and σ). Projecting out what any parameter change can
  absorb makes the statistic independent of which estimator produced ``r`` (to first order).
"""

from __future__ import annotations

from typing import NamedTuple

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Float

from .._checks import to_device
from .._special import regularized_gamma
from .._units import report_factor, report_unit
from ..mechanism._abstract import AbstractMechanism
from ..mechanism._kinematics import ik_and_jacobian
from ._determined import (
    Determination,
    describe_held,
    determine,
    prior_scale,
    refine_in_subspace,
    restricted_covariance,
    total_covariance,
    within_prior,
)
from ._identifiability import KinematicSnapshot, kinematic_snapshot, report_from_arrays
from ._problem import CalibrationData, reading_residuals_compiled

RANK_RTOL = 1e-9
"""Singular values below this fraction of the largest count as zero (the rank)."""
IDENTIFIABLE_TOL = 1e-6
"""A parameter is identifiable when ``1 − |P e_k|² ≤`` this (``P`` the projector on the row space)."""
FIT_P_VALUE = 1e-3
"""The χ² test flags a fit whose p-value is below this."""
GROSS_MISFIT_RATIO = 10.0
"""A fit whose whitened RMS stroke residual exceeds this multiple of the stated noise is a gross
misfit: ``poor_fit`` whatever the χ² test's degrees of freedom and the rank (a correct model
fits at ≈ 1×, below it when the parameters absorb part of the noise)."""
DUPLICATE_ATOL = (1e-6, 1e-9)
"""Poses closer than this (mm, rad) in every component are duplicates."""


class CalibrationAssessment(NamedTuple):
    """What the data of a calibration supports (see the module docstring).

    - ``status``: ``"ok"``, ``"nonfinite"`` (a residual is NaN or infinite), ``"rank_deficient"``
      (some parameters are not identifiable, or were moved along directions the data do not
      determine), ``"partly_determined"`` (those directions held at nominal, each std against the
      truth including the prior's share) or ``"poor_fit"`` (the χ² test fails).
    - ``rank``, ``n_params``, ``condition_number``: of the identification Jacobian.
    - ``identifiable``: ``Bool[np.ndarray, "n"]``.
    - ``param_std``: ``Float[np.ndarray, "n"]`` (the parameters' units), NaN where not identifiable.
    - ``duplicate_rows``: groups of rows (0-based) measured at the same pose.
    - ``nonfinite_rows``: rows whose residual is not finite.
    - ``chi2``, ``dof``, ``p_value``: the goodness-of-fit test; ``rms_ratio`` = ``sqrt(χ²/dof)``,
      ≈ 1 when the stated σ and the model are right; a fit is ``poor_fit`` when χ² is improbably
      large *or* improbably small (p < :data:`FIT_P_VALUE` in either tail: a file in metres fits
      1000× below the noise).
    - ``warnings``: one sentence per problem, each saying what to do.
    - ``param_cov``: ``Float[np.ndarray, "n n"]``, the predicted parameter covariance about the
      truth: the identifiability report's, or, where directions are held at nominal, the data's on
      the determined directions plus the prior's on the held ones (``_determined.total_covariance``;
      ``param_std`` is the square root of its diagonal). NaN where the residuals are not finite.
    """

    status: str
    rank: int
    n_params: int
    condition_number: float
    identifiable: np.ndarray
    param_std: np.ndarray
    duplicate_rows: list[list[int]]
    nonfinite_rows: list[int]
    chi2: float
    dof: int
    p_value: float
    rms_ratio: float
    warnings: list[str]
    param_cov: np.ndarray
    n_determined: int | None = None
    """How many parameter directions the data determine to better than their prior scales
    (``None`` where not judged: a rank-deficient or non-finite fit)."""


def duplicate_rows(poses: Float[np.ndarray, "m 6"]) -> list[list[int]]:
    """Groups (≥ 2 rows, 0-based) of poses equal within :data:`DUPLICATE_ATOL`: in row order, each
    row not yet grouped with every row within the tolerance of it.

    NOTE: O(m log m). Rows within the tolerance of each other (≤ 1 in every component scaled by
    it) project onto a fixed direction u within ‖u‖₁ of each other, so after sorting by that
    projection only the rows in that window are compared exactly; distinct poses of a plan are
    10⁵ or more tolerances apart, so the windows hold the duplicates alone."""
    p = np.asarray(poses, dtype=np.float64)
    tol = np.array([DUPLICATE_ATOL[0]] * 3 + [DUPLICATE_ATOL[1]] * 3)
    u = np.array([0.5377, -0.3459, 0.4203, 0.2871, -0.4486, 0.3705])
    key = (p / tol) @ u
    reach = np.sum(np.abs(u)) * (1.0 + 1e-9) + 1e-9 * np.max(np.abs(key), initial=0.0)
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]
    lo = np.searchsorted(sorted_key, key - reach, side="left")
    hi = np.searchsorted(sorted_key, key + reach, side="right")
    seen = np.zeros(len(p), bool)
    groups = []
    for i in np.flatnonzero(hi - lo > 1):
        if seen[i]:
            continue
        window = order[lo[i]:hi[i]]
        same = np.sort(window[np.all(np.abs(p[window] - p[i]) <= tol, axis=1)])
        if len(same) > 1:
            groups.append(same.tolist())
            seen[same] = True
    return groups


def assess_calibration(
    calibrated: AbstractMechanism,
    data: CalibrationData,
    sigma_um: float = 0.1,
    sigma_arcsec: float = 0.1,
    *,
    nominal: AbstractMechanism | None = None,
) -> CalibrationAssessment:
    """Assess a calibration: ``calibrated`` is the mechanism at the fitted parameters, ``data``
    the measurements it was fitted to, ``sigma_um``/``sigma_arcsec`` the pose noise (µm, ″) the
    data were measured with, ``nominal`` the geometry it started from.

    Directions the data determine no better than the parameters' prior scales (``_determined.py``)
    are ``partly_determined`` when the calibration held them at ``nominal``
    (:func:`hold_undetermined`); a calibration that moved along them, or one assessed without its
    ``nominal``, is ``rank_deficient`` and those parameters get no standard deviation."""
    _check_pose_noise(sigma_um, sigma_arcsec)
    poses = np.asarray(data.poses)
    m, n = poses.shape[0], calibrated.n_params
    warnings: list[str] = []
    snap = kinematic_snapshot(calibrated, poses, sigma_um, sigma_arcsec)
    residuals = np.asarray(data.readings) - snap.readings
    bad = np.flatnonzero(~np.all(np.isfinite(residuals), axis=1)).tolist()
    dups = duplicate_rows(poses)
    if dups:
        warnings.append(_duplicates_warning(dups))
    if bad:
        warnings.append(
            f"rows {[i + 1 for i in bad[:10]]}{' …' if len(bad) > 10 else ''} have non-finite residuals (a NaN "
            "in the data or a pose the calibrated geometry cannot reach): check the units (mm, degrees) and "
            "those rows")
        nan = np.full(n, np.nan)
        return CalibrationAssessment("nonfinite", 0, n, float("inf"), np.zeros(n, bool), nan, dups, bad,
                                     float("nan"), 6 * m - n, float("nan"), float("nan"), warnings,
                                     np.full((n, n), np.nan))
    rep = report_from_arrays(snap.noise, snap.jacobian, rtol=RANK_RTOL)
    wm = _whitened_model(snap, n)
    identifiable, std, cov, text = _identifiable(rep, calibrated.param_names, n)
    if text is not None:
        warnings.append(text)
    held, n_det = False, None
    if rep.rank == n:
        held, n_det, found = _held_directions(calibrated, nominal, wm, poses, sigma_um, sigma_arcsec)
        if found is not None:
            identifiable, std, cov, text = found
            warnings.append(text)
    chi2, dof, p, ratio, gross, poor, fit_warnings = _goodness_of_fit(
        wm, residuals, rep.rank, calibrated.reading_unit, sigma_um, sigma_arcsec)
    warnings += fit_warnings
    # a gross misfit outranks rank deficiency: the numbers are wrong, not only under-determined
    undetermined = rep.rank < n or (not held and not np.all(identifiable))
    status = ("poor_fit" if gross else "rank_deficient" if undetermined
              else "poor_fit" if poor else "partly_determined" if held else "ok")
    return CalibrationAssessment(status, rep.rank, n, float(rep.condition_number), identifiable, std, dups, [],
                                 chi2, dof, p, ratio, warnings, cov, n_det)


def _check_pose_noise(sigma_um: float, sigma_arcsec: float) -> None:
    """Refuse a pose noise that is negative, not finite, or zero in both components."""
    if not (np.isfinite(sigma_um) and np.isfinite(sigma_arcsec) and sigma_um >= 0 and sigma_arcsec >= 0):
        raise ValueError(f"the pose noise must be finite and >= 0, got sigma_um={sigma_um}, "
                         f"sigma_arcsec={sigma_arcsec}")
    if sigma_um == 0 and sigma_arcsec == 0:
        raise ValueError("give the pose noise (sigma_um, sigma_arcsec > 0): the goodness of fit is measured against it")


def _duplicates_warning(dups: list[list[int]]) -> str:
    """The warning for the groups of rows (0-based) measured at the same pose."""
    k = sum(len(g) for g in dups) - len(dups)
    return (f"{k} row(s) repeat an earlier pose (groups, 1-based: {[[i + 1 for i in g] for g in dups[:5]]}"
            f"{' …' if len(dups) > 5 else ''}): repeats count as independent measurements and make every "
            "standard deviation look smaller than the pose set supports")


def _identifiable(rep, names: tuple[str, ...], n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, str | None]:
    """From the identifiability report ``rep`` of the ``n`` parameters ``names``: ``identifiable``
    (``Bool[np.ndarray, "n"]``), ``param_std`` (``Float[np.ndarray, "n"]``, the parameters' units,
    NaN where not identifiable), ``param_cov`` (``Float[np.ndarray, "n n"]``) and the warning
    naming the parameters that are not identifiable alone (``None`` at full rank)."""
    basis = np.asarray(rep.unidentifiable)  # (n − rank, n), the null space
    blind = np.sum(basis**2, axis=0) if basis.size else np.zeros(n)
    identifiable = blind <= IDENTIFIABLE_TOL
    std = np.where(identifiable, np.asarray(rep.param_std), np.nan)
    cov = np.asarray(rep.param_cov)
    text = None
    if rep.rank < n:
        lost = [names[k] for k in np.flatnonzero(~identifiable)]
        text = (f"the data identify {rep.rank} of {n} parameter combinations (condition number "
                f"{rep.condition_number:.3g}); not identifiable alone: {lost[:12]}{' …' if len(lost) > 12 else ''}. "
                "Their values are the starting ones plus an arbitrary share; measure more, and more varied, poses "
                "(stewart_jax.calibration.plan_poses_optimal chooses them)")
    return identifiable, std, cov, text


def _held_directions(calibrated, nominal, wm: _Whitened, poses, sigma_um, sigma_arcsec):
    """At full rank: whether the calibration held the directions the data do not determine at
    ``nominal`` (``False`` without ``nominal``), how many directions the data determine (judged at
    ``nominal`` when given, else at ``calibrated``), and, when some are not determined,
    :func:`_held_report`'s ``identifiable``, ``param_std``, ``param_cov`` and warning (else ``None``).
    ``wm``: the calibrated mechanism's whitened model, whose covariance is reported."""
    n = calibrated.n_params
    if nominal is None:
        det = _determination(wm, calibrated.param_units)
    else:  # the directions hold_undetermined held
        det = _determination(_whitened_model(kinematic_snapshot(nominal, poses, sigma_um, sigma_arcsec), n),
                             nominal.param_units)
    if det.n_determined == n:
        return False, det.n_determined, None
    held = nominal is not None and _is_held(det, np.asarray(calibrated.params) - np.asarray(nominal.params))
    return held, det.n_determined, _held_report(det, wm.jac, wm.noise, calibrated.param_names,
                                                calibrated.param_units, held)


def _goodness_of_fit(wm: _Whitened, residuals, rank: int, reading_unit: str, sigma_um, sigma_arcsec):
    """The fit's tests against the stated pose noise: ``χ²``, its degrees of freedom, the upper
    tail's p-value, ``sqrt(χ²/dof)`` (both NaN without degrees of freedom), whether the fit is a
    gross misfit, whether it is poor (a gross misfit or either tail below :data:`FIT_P_VALUE`),
    and the warnings, in that order. ``residuals``: ``Float[np.ndarray, "m 6"]`` (the readings' unit)."""
    m = residuals.shape[0]
    warnings = []
    chi2, whitened = _gls_chi2(wm, residuals, rank)
    dof = 6 * m - rank
    gross = float(np.sqrt(whitened / (6 * m)))
    rms_reading = report_factor(reading_unit) * float(np.sqrt(np.mean(residuals**2)))
    if gross > GROSS_MISFIT_RATIO:
        warnings.append(
            f"gross misfit: the stroke residuals are {gross:.3g}× the stated noise (σ = {sigma_um} µm, "
            f"{sigma_arcsec}″; RMS {rms_reading:.4g} {report_unit(reading_unit)}), far beyond what any "
            "noise explains. Likely causes: the units (poses in mm and degrees, readings in mm: angles in "
            "radians under a degree header, or a file in metres), the wrong geometry for this mechanism "
            "(--geometry), or the wrong parameter set (--param-set); the calibrated values are not to be used")
    # the two tails: low = P(χ² ≤ observed), p = P(χ² ≥ observed)
    low, p = regularized_gamma(dof / 2.0, chi2 / 2.0) if dof > 0 else (float("nan"), float("nan"))
    ratio = float(np.sqrt(chi2 / dof)) if dof > 0 else float("nan")
    if dof > 0 and p < FIT_P_VALUE:
        warnings.append(
            f"the residuals are {ratio:.3g}× what the stated noise (σ = {sigma_um} µm, {sigma_arcsec}″) explains "
            f"(χ² = {chi2:.4g} on {dof} degrees of freedom, p = {p:.2g}): wrong units (mm and degrees are "
            "expected), a wrong σ, or an effect the model lacks — run `stewart-jax diagnose` to name it")
    if dof > 0 and low < FIT_P_VALUE:
        warnings.append(
            f"the residuals are smaller than the stated noise allows (χ² = {chi2:.4g} on {dof} degrees of freedom, "
            f"p = {low:.2g} of so small a value): σ is overstated — and every reported uncertainty with it — or "
            "the file's lengths are in another unit (a file in metres shrinks every length 1000×)")
    poor = gross > GROSS_MISFIT_RATIO or (dof > 0 and (p < FIT_P_VALUE or low < FIT_P_VALUE))
    return chi2, dof, p, ratio, gross > GROSS_MISFIT_RATIO, poor, warnings


class _Whitened(NamedTuple):
    """The pose model of a :class:`KinematicSnapshot` whitened by the pose noise through ``J_P``:
    the stroke Jacobian ``jac`` ``(m, 6, n)``, the stroke noise covariance ``noise`` ``(m, 6, 6)``
    (with a tiny ridge that keeps a pose whose covariance is singular, one σ zero, whitenable),
    its Cholesky factors ``chol`` ``(m, 6, 6)`` and the whitened Jacobian ``jw`` ``(6m, n)``."""

    jac: np.ndarray
    noise: np.ndarray
    chol: np.ndarray
    jw: np.ndarray


def _whitened_model(snap: KinematicSnapshot, n: int) -> _Whitened:
    m = len(snap.reachable)
    noise = snap.noise + np.eye(6) * 1e-12 * np.trace(snap.noise, axis1=1, axis2=2)[:, None, None] / 6
    jac = snap.jacobian.reshape(m, 6, n)
    chol = np.linalg.cholesky(noise)
    return _Whitened(jac, noise, chol, np.linalg.solve(chol, jac).reshape(6 * m, n))


def _determination(wm: _Whitened, param_units: tuple[str, ...]) -> Determination:
    """The determined directions of a whitened pose model (``_determined.py``)."""
    return within_prior(determine(wm.jw, prior_scale(param_units)), wm.jac, wm.noise)


HELD_TOL = 1e-3
"""A calibration holds a direction at nominal when its update along it is below this many prior scales."""


def _is_held(det: Determination, update: np.ndarray) -> bool:
    return bool(np.all(np.abs(det.held @ (update / det.scale)) <= HELD_TOL))


def _held_report(det, jac, noise, names, units, held: bool):
    """``identifiable``, ``param_std``, ``param_cov`` and the warning of a fit with held directions."""
    share = det.held_share()
    alone = share <= 0.01
    k, n = det.n_determined, len(det.scale)
    where = describe_held(det, names, units)
    scales = "1 mm for a length, 1 mrad for an angle"
    if held:
        cov = total_covariance(det, restricted_covariance(det, jac, noise))
        return alone, np.sqrt(np.maximum(np.diag(cov), 0.0)), cov, (
            f"the data determine {k} of {n} parameter directions to better than the prior scale ({scales}); "
            f"the other {n - k} are held at nominal: {'; '.join(where[:6])}{' …' if len(where) > 6 else ''}. "
            "Each std includes the prior's share on the held directions; measure more varied poses to determine them")
    cov = np.full((n, n), np.nan)
    std = np.full(n, np.nan)
    return np.zeros(n, bool), std, cov, (
        f"the data determine {k} of {n} parameter directions to better than the prior scale ({scales}); "
        f"the calibration moved along the other {n - k}, where its values are arbitrary: {'; '.join(where[:6])}"
        f"{' …' if len(where) > 6 else ''}. Hold them at nominal (stewart_jax.calibration.hold_undetermined; the "
        "command line does) before using the geometry")


def hold_undetermined(
    nominal: AbstractMechanism, data: CalibrationData, params, sigma_um: float = 0.1, sigma_arcsec: float = 0.1
) -> np.ndarray:
    """``params`` with the directions the data do not determine held at ``nominal``'s values
    (``_determined.py``): the least-squares fit of the stroke residual over the determined
    directions, from the projection of ``params``. The determination is made at ``nominal``."""
    poses = np.asarray(data.poses)
    det = _determination(_whitened_model(kinematic_snapshot(nominal, poses, sigma_um, sigma_arcsec), nominal.n_params),
                         nominal.param_units)
    u0 = np.asarray(nominal.params)
    if det.n_determined == nominal.n_params:
        return np.asarray(params)

    def residuals(u):
        return np.asarray(reading_residuals_compiled(to_device(u), data, nominal))

    def jacobian(u):
        return -kinematic_snapshot(nominal.with_params(u), poses, sigma_um, sigma_arcsec).jacobian

    return refine_in_subspace(residuals, jacobian, u0, np.asarray(params), det)


def implied_pose_errors(mechanism: AbstractMechanism, data: CalibrationData) -> Float[np.ndarray, "m 6"]:
    """Per measured pose, how far the pose ``mechanism`` predicts for the readings lies from the
    measured one, to first order: ``δP = J⁻¹·(q' − IK(P'))`` (µm for dx, dy, dz; ″ for φ, θ, ψ).
    With the nominal geometry it estimates the control error before calibration; with the
    calibrated one, what remains (noise included)."""
    from .._units import error_in_report_units

    return np.asarray(error_in_report_units(_implied_pose_errors(mechanism, jnp.asarray(data.poses),
                                                                 jnp.asarray(data.readings))))


@eqx.filter_jit
def _implied_pose_errors(mechanism, poses, readings):
    predicted, _, jac = ik_and_jacobian(mechanism, poses)
    return jnp.linalg.solve(jac, (readings - predicted)[..., None])[..., 0]


def _gls_chi2(wm: _Whitened, residuals, rank) -> tuple[float, float]:
    """``min_δ |W (r − A δ)|²`` (the whitened residual with every parameter direction removed)
    and ``|W r|²`` (the whitened residual itself), in the calibrated mechanism's whitened model."""
    rw = np.linalg.solve(wm.chol, residuals[..., None])[..., 0].reshape(-1)
    u, _, _ = np.linalg.svd(wm.jw, full_matrices=False)
    u = u[:, :rank]
    whitened = float(rw @ rw)
    return max(whitened - float(np.sum((u.T @ rw) ** 2)), 0.0), whitened  # ≥ 0 up to rounding
