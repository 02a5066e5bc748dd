"""The multi-channel matrix pencil of the MoorDyn benchmark against records with known modes."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from _pencil import matrix_pencil  # noqa: E402


def _record(freq_hz, zeta, amp, phase, t):
    w = 2 * np.pi * np.asarray(freq_hz)
    wd = w * np.sqrt(1 - np.asarray(zeta) ** 2)
    env = np.exp(-np.asarray(zeta) * w * t[:, None])
    return (env * np.cos(wd * t[:, None] + phase)) @ amp


def test_pencil_recovers_close_modes_from_several_channels():
    # two modes 0.05 % apart (fewer than one beat in the record) with different shapes, and a third
    f = np.array([0.1490, 0.14907, 0.31])
    zeta = np.array([0.0, 0.004, 0.02])
    # undamped natural frequencies; the damped ones the pencil sees are f sqrt(1 - ζ²)
    fd = f * np.sqrt(1 - zeta**2)
    t = np.arange(3000) * 0.02
    amp = np.array([[1.0, 0.2, 0.0], [0.1, -1.0, 0.3], [0.5, 0.5, -1.0]])
    y = _record(f, zeta, amp, np.array([0.3, 1.1, -0.4]), t)
    out = matrix_pencil(y, 0.02, order=6, lags=200)
    np.testing.assert_allclose(out.frequency_hz, fd, rtol=1e-8)
    np.testing.assert_allclose(out.damping_ratio, zeta, atol=1e-8)


def test_pencil_with_noise_finds_the_frequency_to_its_cramer_rao_order():
    rng = np.random.default_rng(0)
    t = np.arange(2000) * 0.05
    errs = []
    for _ in range(20):
        y = _record([0.2], [0.01], np.array([[1.0, 0.5]]), np.array([rng.uniform(0, 6)]), t)
        y = y + 1e-3 * rng.standard_normal(y.shape)
        out = matrix_pencil(y, 0.05, order=2, lags=40)
        errs.append(abs(out.frequency_hz[0] - 0.2 * np.sqrt(1 - 1e-4)) / 0.2)
    # single-mode Cramér–Rao bound on f with SNR 1e3 over ~100 s: ~1e-5 relative
    assert sum(e < 1e-4 for e in errs) >= 19


def test_pencil_rejects_bad_records():
    with pytest.raises(ValueError, match="finite"):
        matrix_pencil(np.array([1.0, np.nan, 2.0, 3.0]), 0.1)
    with pytest.raises(ValueError, match="dt"):
        matrix_pencil(np.ones(20), -1.0)
