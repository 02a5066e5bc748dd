"""The cables' blocks extrapolated to continuous cables (the continuum share γ of the cabin's
modal model): Richardson's steps and the pairing of modes across segments on a sequence whose
limit is known; at γ = 3/4 the model at N stands for the lumped cables at 2N, at γ = 1 for the
limit of finer and finer cables, each checked against models built at those segments on their
own; the derivative in γ against finite differences; γ = 0 leaves the model at N as it was.
Every test but the first is in the slow tier: each model compiles the lumped statics at three
discretisations (≈ 25 s under the Makefile's -O0), up to 128 segments."""

import jax
import numpy as np
import pytest

import stewart_jax  # noqa: F401
from stewart_jax.cable_robot import CabinVariation, cabin_modal_model, paper_fast_params
from stewart_jax.cable_robot._cabin_modal import cabin_modal_modes, free_response
from stewart_jax.cable_robot._cable_continuum import CraigBampton, continuum_change, segments_of

PARAMS = paper_fast_params()
POS = (0.0, 0.0, 140.0)
N = 8
COUNT = 16
"""The lowest modes compared: the cabin's nine and the first string modes (up to ≈ 0.52 Hz at
N = 8, where a string mode's Ω² moves by a few per cent between N and 2N)."""


@pytest.fixture(scope="module")
def models():
    return {n: cabin_modal_model(PARAMS, POS, n) for n in (N, 2 * N)}


@pytest.fixture(scope="module")
def small():
    return cabin_modal_model(PARAMS, POS, 3)


def _finer(shapes, rng):
    # A finer chain's shapes (one cable, 2m + 1 nodes for the m of ``shapes``): each mode j
    # reappears as column where[j], times sign[j], equal to it at the coarse chain's nodes (the
    # fine chain's even nodes); the new nodes and the extra modes random.
    k = shapes.shape[0]
    kf = 2 * k + 3
    where, sign = rng.permutation(kf)[:k], rng.choice([-1.0, 1.0], k)
    fine = rng.normal(size=(kf // 3, 3, kf))
    fine[1::2][:, :, where] = shapes.reshape(k // 3, 3, k) * sign
    return fine.reshape(kf, kf), where, sign


def _synthetic_levels(n, rng):
    # Blocks at n, 2n and 4n segments whose every entry is X∞ + a/N² + b/N⁴ (N the level's
    # segments), each finer chain's modes permuted and sign-flipped (:func:`_finer`)
    k = 3 * (n - 1)
    limit = {"added_mass": rng.normal(size=(6, 6)), "stiffness": rng.normal(size=(6, 6)),
             "coupling": rng.normal(size=(6, 6 * k)), "omega2": 10.0 + rng.random(6 * k)}
    a, b = ({key: 0.5 * rng.normal(size=v.shape) for key, v in limit.items()} for _ in range(2))
    shapes = [np.linalg.qr(rng.normal(size=(k, k)))[0] for _ in range(6)]
    col, sign = [np.arange(k) for _ in range(6)], [np.ones(k) for _ in range(6)]
    levels = []
    for f in (1, 2, 4):
        x = {key: limit[key] + a[key] / (f * n) ** 2 + b[key] / (f * n) ** 4 for key in limit}
        if f > 1:
            for c in range(6):
                shapes[c], where, flip = _finer(shapes[c], rng)
                col[c], sign[c] = where[col[c]], sign[c] * flip[col[c]]
        kl = shapes[0].shape[0]
        omega2, coupling = 100.0 + rng.random(6 * kl), rng.normal(size=(6, 6 * kl))
        for c in range(6):
            omega2[c * kl + col[c]] = x["omega2"][c * k:(c + 1) * k]
            coupling[:, c * kl + col[c]] = x["coupling"][:, c * k:(c + 1) * k] * sign[c]
        levels.append(CraigBampton(x["added_mass"], coupling, omega2, x["stiffness"], np.stack(shapes)))
    return limit, levels


def test_richardson_and_the_pairing_of_modes_recover_a_known_limit():
    rng = np.random.default_rng(3)
    limit, levels = _synthetic_levels(3, rng)
    change = continuum_change(tuple(levels))
    coarse = levels[0]
    for got, base, want in ((change.omega2, coarse.omega2, limit["omega2"]),
                            (change.coupling, coarse.coupling, limit["coupling"]),
                            (change.added_mass, coarse.added_mass, limit["added_mass"]),
                            (change.stiffness, coarse.stiffness, limit["stiffness"])):
        np.testing.assert_allclose(base + got, want, atol=1e-12)
    # one step (N and 2N alone) leaves the b/N⁴ term: the test's sequence can tell the two apart
    one = continuum_change(tuple(levels[:2]))
    assert np.max(np.abs(coarse.omega2 + one.omega2 - limit["omega2"])) > 1e-4


def _low(model, continuum=0.0, count=COUNT):
    # the lowest modes that move the cabin (share ≥ 1 %), at the lumped cables' mass (μ = 1)
    m = cabin_modal_modes(model, CabinVariation(cable_mass_share=1.0, continuum=continuum))
    f, share = np.asarray(m.frequencies_hz), np.asarray(m.cabin_energy_share)
    return f[(share >= 0.01) & (f > 0)][:count]


@pytest.mark.slow
def test_three_quarters_of_the_continuum_share_stands_for_twice_the_segments(models):
    # γ = 1 − (N/N')² is the model of N' segments to leading order: at γ = 3/4 the model at N
    # against the model at 2N built from its own lumped statics and modes, not from the step.
    # What is left is the 1/N⁴ term of the coarse chain: measured 0.30 of the difference for the
    # swing modes at N = 8 (the farthest), 0.002–0.2 for the others.
    coarse, fine = _low(models[N]), _low(models[2 * N])
    step = _low(models[N], 0.75)
    raw = np.abs(coarse / fine - 1.0)
    err = np.abs(step / fine - 1.0)
    assert np.all(err < 0.4 * raw), err / raw
    assert np.median(err / raw) < 0.15, err / raw


@pytest.mark.slow
def test_the_continuum_share_one_is_the_limit_of_finer_cables(models):
    # The limit of the lumped models' own frequencies at N, 2N and 4N (Richardson's two steps on
    # the frequencies, not on the blocks), against the models at N and 2N carried there by γ = 1
    # (slow: the 4N model). Measured at N = 8: 0.00–0.04 of the lumped model's distance from the
    # limit is left at N, 0.00–0.03 at 2N (there the limit's own error is of the same order).
    f1, f2 = _low(models[N]), _low(models[2 * N])
    f4 = _low(cabin_modal_model(PARAMS, POS, 4 * N))
    limit = (64.0 * f4 - 20.0 * f2 + f1) / 45.0
    raw, raw2 = (np.abs(f / limit - 1.0) for f in (f1, f2))
    err = np.abs(_low(models[N], 1.0) / limit - 1.0)
    err2 = np.abs(_low(models[2 * N], 1.0) / limit - 1.0)
    assert np.all(err < 0.06 * raw), err / raw
    assert np.all(err2 < 0.06 * raw2), err2 / raw2


@pytest.mark.slow
def test_continuum_share_zero_is_the_lumped_model(small):
    m = small
    a = cabin_modal_modes(m, CabinVariation(cable_mass_share=1.0)).frequencies_hz
    b = cabin_modal_modes(m, CabinVariation(cable_mass_share=1.0, continuum=0.0)).frequencies_hz
    np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    assert segments_of(0.0, 3) == 3 and segments_of(0.75, 3) == pytest.approx(6)
    assert segments_of(1.0, 3) == float("inf")


@pytest.mark.slow
def test_the_response_derivative_in_the_continuum_share_is_the_finite_difference(small):
    m = small
    q0 = np.array([0.02, 0.01, 0.005, 1e-4, 1e-4, 2e-4])
    t = np.linspace(0.0, 30.0, 301)

    def response(g):
        var = CabinVariation(cable_mass_share=1.0, node_lag=0.5, continuum=g)
        return free_response(m, var, 0.005, q0, np.zeros(6), t)

    g0, h = 0.4, 1e-6
    jvp = np.asarray(jax.jvp(response, (g0,), (1.0,))[1])
    fd = (np.asarray(response(g0 + h)) - np.asarray(response(g0 - h))) / (2 * h)
    # central difference: O(h² (ω′ t)³) truncation (γ moves a string mode of N = 3 by tens of
    # per cent, a few radians of phase over 30 s per unit γ) and O(ε/h) rounding, both far below
    # 1e-6 of the largest derivative
    np.testing.assert_allclose(jvp, fd, atol=1e-6 * np.max(np.abs(fd)))
    assert np.max(np.abs(fd)) > 1e-5  # γ moves the string modes and the cabin with them
