"""Multi-channel matrix pencil (ESPRIT): the modes of a free-decay record, in time linear in
its length.

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

NOTE (cost): the left singular vectors are those of the ``Lp × Lp`` Gram matrix ``H Hᵀ``,
accumulated in ``O(n (Lp)²)``; with the lags bounded (:func:`record_modes` caps them) the whole
identification is linear in the record's length. Averaging blocks of ``k`` samples first keeps
the poles (the block mean of ``Σ a z^j`` is ``Σ a' (z^k)^j``), so a record sampled far above its
modes is decimated before the pencil, and the poles are read back at the block step.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

MAX_LAGS = 120
"""Most Hankel lags :func:`record_modes` uses (the pencil's cost is ``O(n (lags · channels)²)``)."""


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
    gram = np.zeros((L * p, L * p))
    for start in range(0, cols, 4096):  # H Hᵀ by blocks of columns: O(n (Lp)²) time, O((Lp)²) memory
        stop = min(cols, start + 4096)
        block = np.concatenate([y[lag + start:lag + stop].T for lag in range(L)])
        gram += block @ block.T
    w, U = np.linalg.eigh(gram)
    w, U = w[::-1], U[:, ::-1]
    sv = np.sqrt(np.maximum(w, 0.0))
    r = int(np.sum(sv > rtol * sv[0])) if order is None else int(order)
    r = max(1, min(r, (L - 1) * p, cols))
    Ur = U[:, :r]
    z = np.linalg.eigvals(np.linalg.lstsq(Ur[:-p], Ur[p:], rcond=None)[0])
    # amplitudes: least squares of the record on the fitted poles (decaying powers, no overflow)
    V = z[None, :] ** np.arange(n)[:, None]
    A = np.linalg.lstsq(V, y.astype(complex), rcond=None)[0]
    s = np.log(z) / dt
    keep = s.imag >= 0
    f = s.imag[keep] / (2 * np.pi)
    zeta = -s.real[keep] / np.abs(s[keep])
    amp = np.max(np.abs(A[keep]), axis=1) * np.where(s.imag[keep] > 0, 2.0, 1.0)
    o = np.argsort(f)
    return PencilModes(f[o], zeta[o], amp[o], sv)


def record_modes(y: np.ndarray, dt: float, max_frequency_hz: float, order: int) -> PencilModes:
    """The ``order // 2`` leading modes of a record ``y`` (``(n, p)``, every ``dt`` s) below
    ``max_frequency_hz``: blocks of samples averaged to about 4 samples per period of that
    frequency, then :func:`matrix_pencil` with at most :data:`MAX_LAGS` lags spanning at least two
    of its periods; frequencies above it, or with ``|ζ| ≥ 0.5``, are dropped."""
    y = np.asarray(y, float)
    if not (np.isfinite(max_frequency_hz) and max_frequency_hz > 0):
        raise ValueError(f"max_frequency_hz must be a positive frequency, got {max_frequency_hz}")
    k = max(1, int(1.0 / (4.0 * max_frequency_hz * dt)))
    n = (y.shape[0] // k) * k
    yd = y[:n].reshape(n // k, k, -1).mean(axis=1)
    lags = int(min(MAX_LAGS, max(8, yd.shape[0] // 3)))
    out = matrix_pencil(yd, k * dt, order=order, lags=lags)
    ok = (out.frequency_hz > 0) & (out.frequency_hz < max_frequency_hz) & (np.abs(out.damping_ratio) < 0.5)
    return PencilModes(out.frequency_hz[ok], out.damping_ratio[ok], out.amplitude[ok], out.singular_values)
