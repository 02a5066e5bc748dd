"""What the data determine, judged against the parameters' prior scales, and the calibration that
holds the rest at nominal.

Hansen P. C., "The truncated SVD as a method for regularization", BIT 27(4), 1987 (the
truncated-SVD, minimum-norm solution); Hollerbach J. M. & Wampler C. W., "The calibration index
and taxonomy for robot kinematic calibration methods", Int. J. Robotics Research 15(6), 1996
(scaling the identification Jacobian's columns by each parameter's a-priori scale before judging
what the data identify).

The whitened identification Jacobian ``J_W`` (each residual divided by its noise) is scaled by the
parameters' prior scales ``s`` (how far an as-built value may plausibly lie from its nominal one:
:data:`PRIOR_SCALE`, 1 mm for a length, 1 mrad for an angle): ``J_S = J_W·diag(s)``, with singular
values ``σ_i`` and right singular vectors ``v_i``. Along ``v_i`` the data alone give a standard
deviation of ``1/σ_i`` prior scales. A direction with ``1/σ_i >`` :data:`DETERMINED_STD` is one the
data determine no better than the prior: it is *undetermined*, whatever its numerical rank.

The calibration holds the undetermined directions at nominal: its update is restricted to the span
of ``diag(s)·v_i`` over the determined directions (the truncated-SVD solution in the scaled metric,
the minimum-norm update). Its covariance is ``diag(s)·V_k·Σ_k⁻²·V_kᵀ·diag(s)`` (for a weighted
fit; the sandwich of :func:`restricted_covariance` for an unweighted one), so that no parameter's
data standard deviation exceeds ``DETERMINED_STD·s_k``. Against the truth the held part of a
parameter keeps its prior uncertainty, ``(t·s_k)²·Σ_held v_ik²`` (``t`` the threshold), which
:func:`total_covariance` and :func:`total_std` add.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import NamedTuple

import numpy as np
from jaxtyping import Float

PRIOR_SCALE = {"mm": 1.0, "rad": 1e-3}
"""A parameter's prior scale per unit: how far an as-built length (mm) or angle (rad) may lie from
its nominal value, 1 mm and 1 mrad (machining and assembly tolerances of telescope hexapods)."""
DETERMINED_STD = 1.0
"""A direction is determined when the data's standard deviation along it is at most this many
prior scales."""


def prior_scale(units: Sequence[str], registration: int = 0) -> np.ndarray:
    """``(n + registration,)``: each parameter's prior scale in its unit (:data:`PRIOR_SCALE`), then
    ``registration`` entries of a tracker registration (three mm, three rad)."""
    unknown = sorted({u for u in units} - set(PRIOR_SCALE))
    if unknown:
        raise ValueError(f"no prior scale for parameter unit(s) {unknown}; known: {sorted(PRIOR_SCALE)}")
    reg = [PRIOR_SCALE["mm"]] * 3 + [PRIOR_SCALE["rad"]] * 3
    return np.array([PRIOR_SCALE[u] for u in units] + reg[:registration], dtype=np.float64)


class Determination(NamedTuple):
    """See the module docstring.

    - ``scale``: ``(n,)`` the prior scales; ``singular_values``: ``(n,)`` of ``J_S``, descending.
    - ``determined``: ``(k, n)`` the determined directions ``v_i`` (orthonormal, scaled units).
    - ``held``: ``(n − k, n)`` the undetermined ones, held at nominal.
    - ``threshold``: the largest data std of a determined direction, in prior scales
      (:func:`determine`'s); also the std a held direction keeps about the truth (:func:`total_std`).
    """

    scale: np.ndarray
    singular_values: np.ndarray
    determined: np.ndarray
    held: np.ndarray
    threshold: float

    @property
    def n_determined(self) -> int:
        return len(self.determined)

    @property
    def step_basis(self) -> np.ndarray:
        """``(n, k)``: the update's basis in the parameters' units, ``diag(s)·V_k``."""
        return self.scale[:, None] * self.determined.T

    def held_share(self) -> np.ndarray:
        """``(n,)``: the share (0…1) of each parameter's scaled unit vector in the held directions."""
        return np.sum(self.held**2, axis=0) if len(self.held) else np.zeros(len(self.scale))

    def coordinates(self, update: np.ndarray) -> np.ndarray:
        """``(k,)``: the determined coordinates of a parameter update (orthogonal projection in
        the scaled metric)."""
        return self.determined @ (np.asarray(update) / self.scale)


def determine(jw: Float[np.ndarray, "rows n"], scale: Float[np.ndarray, " n"],
              threshold: float = DETERMINED_STD) -> Determination:
    """The determined and held directions of a whitened Jacobian ``jw`` (module docstring): a
    direction is determined when the data's std along it is at most ``threshold`` prior scales."""
    js = np.asarray(jw) * scale
    _, sv, vt = np.linalg.svd(js, full_matrices=False)
    if len(sv) < len(scale):  # fewer rows than unknowns: the rest is not seen at all
        sv = np.concatenate([sv, np.zeros(len(scale) - len(sv))])
        _, _, vt = np.linalg.svd(js, full_matrices=True)
    k = int(np.sum(sv * threshold >= 1.0))
    return Determination(np.asarray(scale, dtype=np.float64), sv, vt[:k], vt[k:], float(threshold))


def within_prior(det: Determination, jac: Float[np.ndarray, "m 6 n"], noise_cov: Float[np.ndarray, "m 6 6"]):
    """``det`` with its weakest determined directions moved to the held ones until no parameter's
    standard deviation about the truth (:func:`total_std`) under an *unweighted* estimator (the
    sandwich of :func:`restricted_covariance`) exceeds ``det.threshold`` prior scales.

    NOTE: the determination is made on the whitened (weighted) problem, whose covariance bounds
    the weighted estimator's; an unweighted fit can be less precise along the same directions."""
    while det.n_determined:
        std = total_std(det, restricted_covariance(det, jac, noise_cov))
        if np.all(std <= det.threshold * det.scale * (1 + 1e-9)):
            break
        k = det.n_determined - 1
        det = det._replace(determined=det.determined[:k], held=np.concatenate([det.determined[k:], det.held]))
    return det


def restricted_covariance(
    det: Determination,
    jac: Float[np.ndarray, "m 6 n"],
    noise_cov: Float[np.ndarray, "m 6 6"] | None = None,
) -> np.ndarray:
    """``(n, n)`` covariance of the estimate restricted to the determined directions (parameters'
    units). ``jac``: the Jacobian of the residuals the estimator minimises, in blocks of rows;
    ``noise_cov``: their noise covariance per block (``None``: ``jac`` is whitened, the GLS case).

    The unweighted case is the sandwich ``(AᵀA)⁻¹·AᵀCA·(AᵀA)⁻¹`` with ``A = jac·diag(s)·V_k``,
    accumulated block by block (memory linear in the rows)."""
    b = det.step_basis
    if b.shape[1] == 0:
        return np.zeros((len(det.scale),) * 2)
    a = np.asarray(jac) @ b
    flat = a.reshape(-1, b.shape[1])
    inv = np.linalg.pinv(flat.T @ flat, hermitian=True)
    if noise_cov is None:
        cov_a = inv
    else:
        meat = flat.T @ (np.asarray(noise_cov) @ a).reshape(flat.shape)
        cov_a = inv @ meat @ inv
    cov = b @ cov_a @ b.T
    return 0.5 * (cov + cov.T)


def total_covariance(det: Determination, cov: np.ndarray) -> np.ndarray:
    """``(n, n)``: the covariance about the truth, the data's ``cov`` (on the determined directions)
    plus the prior's on the held ones, ``t²·diag(s)·V_heldᵀ·V_held·diag(s)`` (``t`` the
    determination's ``threshold``: a held direction keeps the spread the threshold stands for).

    NOTE: a prediction made from the data's covariance alone (a control error at a pose) omits what
    holding a direction at nominal costs there; this one includes it."""
    held = det.scale[:, None] * det.held.T  # (n, n − k); no columns when nothing is held
    return np.asarray(cov) + det.threshold**2 * (held @ held.T)


def total_std(det: Determination, cov: np.ndarray) -> np.ndarray:
    """``(n,)``: each parameter's standard deviation about the truth, the square root of the
    diagonal of :func:`total_covariance`."""
    return np.sqrt(np.maximum(np.diag(total_covariance(det, cov)), 0.0))


def refine_in_subspace(
    residuals: Callable[[np.ndarray], np.ndarray],
    jacobian: Callable[[np.ndarray], np.ndarray],
    nominal: np.ndarray,
    start: np.ndarray,
    det: Determination,
    steps: int = 6,
) -> np.ndarray:
    """Least squares over ``y = nominal + diag(s)·V_k·a`` (the held directions at nominal), by
    Gauss–Newton with step halving from the projection of ``start``.

    ``residuals(y)`` → ``(rows,)``, ``jacobian(y)`` → ``(rows, n)`` (``∂r/∂y``), in the metric the
    estimator minimises. Returns the parameters.

    NOTE: a fit that drifted along held directions leaves a residual that the projection alone
    does not minimise (the model is not linear over the drift, and an unweighted fit's metric is not
    the scaled one); a few Gauss–Newton steps in the ``k`` determined coordinates finish it.
    """
    b = det.step_basis
    y0 = np.asarray(nominal, dtype=np.float64)
    a = det.coordinates(np.asarray(start) - y0)
    y = y0 + b @ a
    if b.shape[1] == 0:
        return y
    r = np.asarray(residuals(y))
    cost = float(r @ r) if np.all(np.isfinite(r)) else np.inf
    for _ in range(steps):
        jb = np.asarray(jacobian(y)) @ b
        da = -np.linalg.lstsq(jb, r, rcond=None)[0]
        t = 1.0
        while t > 1e-3:
            trial = y0 + b @ (a + t * da)
            r_t = np.asarray(residuals(trial))
            c_t = float(r_t @ r_t) if np.all(np.isfinite(r_t)) else np.inf
            if c_t <= cost:
                break
            t *= 0.5
        else:
            break
        done = cost - c_t <= 1e-12 * max(cost, 1e-300)
        a, y, r, cost = a + t * da, trial, r_t, c_t
        if done:
            break
    return y


def describe_held(det: Determination, names: Sequence[str], units: Sequence[str], top: int = 3) -> list[str]:
    """One phrase per held direction: its largest components (e.g. ``0.62·L1 + 0.41·p1_z``) and
    the data's standard deviation along it in prior scales."""
    out = []
    sv = det.singular_values[det.n_determined:]
    for v, s in zip(det.held, sv, strict=True):
        order = np.argsort(-np.abs(v))[:top]
        terms = " ".join(f"{v[i]:+.2f}·{names[i]}" for i in order)
        std = "unbounded" if s <= 0 else f"{1.0 / s:.3g}"
        out.append(f"({terms}; data std {std} prior scales)")
    return out
