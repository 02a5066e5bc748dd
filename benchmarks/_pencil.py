"""Multi-channel matrix pencil (ESPRIT) for free-decay records.

Hua Y., Sarkar T. K., *Matrix pencil method for estimating parameters of exponentially
damped/undamped sinusoids in noise*, IEEE Trans. Acoust., Speech, Signal Process. 38(5) (1990)
814–824; Roy R., Kailath T., *ESPRIT — estimation of signal parameters via rotational invariance
techniques*, IEEE Trans. Acoust., Speech, Signal Process. 37(7) (1989) 984–995.

A record ``y[k, c] = Σ_m a_m,c z_m^k`` (``p`` channels sampled every ``dt``) fills the block
Hankel matrix ``H`` (``L`` lags × ``p`` channels rows, ``n − L + 1`` columns). Its ``r`` leading
left singular vectors ``U`` span the signal space; rows shifted by one lag span the same space
times the poles (shift invariance), so the eigenvalues of ``U₁⁺ U₂`` (``U₁``: ``U`` without its
last lag, ``U₂``: without its first) are the ``z_m``. Then ``s_m = log(z_m)/dt``,
``f_m = |Im s_m|/2π`` and ``ζ_m = −Re s_m/|s_m|``. A mode shared by every channel is found once,
however many channels see it, and modes of nearly equal frequency but different shapes separate.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class PencilModes(NamedTuple):
    """Fitted modes, ascending in frequency, one per conjugate pair (numpy).

    ``frequency_hz``, ``damping_ratio``: ``(r,)``; ``amplitude``: ``(r,)``, the largest
    channel amplitude of the pair (units of the record); ``singular_values``: of the Hankel matrix.
    """

    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    amplitude: np.ndarray
    singular_values: np.ndarray


def matrix_pencil(y: np.ndarray, dt: float, order: int | None = None, lags: int | None = None,
                  rtol: float = 1e-9) -> PencilModes:
    """Poles of ``y`` (``(n,)`` or ``(n, p)``, sampled every ``dt`` s) by the multi-channel
    matrix pencil; ``order`` poles (counting each conjugate), or as many singular values as
    exceed ``rtol`` times the largest; ``lags`` Hankel block rows (``n/3`` by default)."""
    y = np.asarray(y, float)
    if y.ndim == 1:
        y = y[:, None]
    if y.ndim != 2 or not np.all(np.isfinite(y)):
        raise ValueError(f"the record must be a finite (n,) or (n, channels) array, got shape {y.shape}")
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive sampling interval in s, got {dt}")
    n, p = y.shape
    L = n // 3 if lags is None else int(lags)
    if not 2 <= L <= n - 2:
        raise ValueError(f"lags must lie in [2, n - 2] = [2, {n - 2}], got {L}")
    cols = n - L + 1
    H = np.empty((L * p, cols))
    for lag in range(L):
        H[lag * p:(lag + 1) * p] = y[lag:lag + cols].T
    U, sv, _ = np.linalg.svd(H, full_matrices=False)
    r = int(np.sum(sv > rtol * sv[0])) if order is None else int(order)
    r = max(1, min(r, (L - 1) * p, cols))
    Ur = U[:, :r]
    z = np.linalg.eigvals(np.linalg.lstsq(Ur[:-p], Ur[p:], rcond=None)[0])
    # amplitudes: least squares of the record on the fitted poles
    V = z[None, :] ** np.arange(n)[:, None]
    A = np.linalg.lstsq(V, y.astype(complex), rcond=None)[0]
    s = np.log(z) / dt
    keep = s.imag >= 0
    f = s.imag[keep] / (2 * np.pi)
    zeta = -s.real[keep] / np.abs(s[keep])
    amp = np.max(np.abs(A[keep]), axis=1) * np.where(s.imag[keep] > 0, 2.0, 1.0)
    o = np.argsort(f)
    return PencilModes(f[o], zeta[o], amp[o], sv)
