"""The discrepancy workflow on the FAST dynamics (Yin, Jiang, Chen, Yao, "Dynamic modeling of a
cable-driven parallel robot with a Stewart platform for use in FAST"): a cabin-held-still model
against the coupled simulation's lower-platform trajectory.

The FAST simulation runs ONCE for the module (four trajectories in one compiled call, 1 s at
2 ms); every data set is subsampled to every 2nd sample (251 rows × x, y, z), so all
``diagnose`` calls share one compiled kernel.
"""

import numpy as np
import pytest

import stewart_jax  # noqa: F401
from stewart_jax.discrepancy import (
    diagnose,
    effect_names,
    fast_model,
    fast_responses,
    simulate_fast_measurement,
)

# The slow tier (make test-all runs it, make test does not): simulated responses of the coupled model, each
# diagnosed (32 s on 2 cores).
pytestmark = pytest.mark.slow

MODEL_NAME = "fast"  # the FAST model's name, the key of its effects
FAST_EFFECTS = ("cabin_coupling", "cable_elasticity", "actuator_gain", "actuator_delay")
SIGMA_UM = 10.0
STRIDE = 2


@pytest.fixture(scope="module")
def responses():
    return fast_responses(duration=1.0, dt=2e-3)


@pytest.fixture(scope="module")
def model(responses):
    return fast_model(responses, sigma_um=SIGMA_UM)


def _run(responses, model, effect, theta=None, seed=0):
    data = simulate_fast_measurement(responses, effect=effect, theta=theta, sigma_um=SIGMA_UM, stride=STRIDE,
                                     offset_mm=(0.3, -0.2, 0.1), seed=seed)
    return diagnose(data, model, seed=seed)


def test_responses_are_trustworthy(responses):
    assert responses.static_ok and responses.n_failed == 0
    assert set(effect_names(MODEL_NAME)) >= set(FAST_EFFECTS)
    # The coupled extra error is the recoil + pitch seen in the FAST README (max |x| ≈ 1.27 mm),
    # and not a pure gain of the plan: ≈ 36 µm RMS is left after the best in-phase fit.
    ex = responses.coupled[:, 0]
    assert 1.2 < np.max(np.abs(ex)) < 1.35
    px = responses.planned[:, 0]
    a = np.stack([px, np.ones_like(px)], 1)
    rest = ex - a @ np.linalg.lstsq(a, ex, rcond=None)[0]
    assert np.sqrt(np.mean(rest**2)) * 1e3 > 3 * SIGMA_UM
    # The free swings are slow (cable modes): no 5 Hz content to confuse with the coupling.
    assert np.max(np.abs(responses.free[0, :, 0])) > 0.2


def test_coupled_simulation_names_cabin_coupling(responses, model):
    rep = _run(responses, model, "cabin_coupling")
    assert rep.detected and rep.detect_p_value < 1e-10
    assert rep.named_effect == "cabin_coupling"
    assert rep.indistinguishable_from == []
    kappa = next(c for c in rep.ranking if c.effect == "cabin_coupling").params[0]
    assert kappa == pytest.approx(1.0, abs=2e-3)
    # The gap: ~0.47 mm before, the noise after.
    assert rep.gap_before > 30 * SIGMA_UM
    assert rep.gap_after < 1.15 * SIGMA_UM
    # An actuator gain error explains the 5 Hz in-phase part too (significant), but not the
    # coupled response's remaining ~36 µm: it is rejected against coupling ∪ gain.
    gain = next(c for c in rep.ranking if c.effect == "actuator_gain")
    assert gain.significant and gain.heldout_rms > 1.8 * SIGMA_UM


def test_cabin_held_still_names_none(responses, model):
    rep = _run(responses, model, "none")
    assert rep.named_effect is None
    assert rep.gap_after == rep.gap_before < 1.15 * SIGMA_UM
    assert not any(c.significant for c in rep.ranking)


def test_hidden_cable_swing_names_cable_elasticity(responses, model):
    v = np.array([0.5, -0.3, 0.2])  # mm/s initial cabin velocity
    rep = _run(responses, model, "cable_elasticity", theta=v)
    assert rep.detected and rep.named_effect == "cable_elasticity"
    assert rep.indistinguishable_from == []
    fitted = np.asarray(next(c for c in rep.ranking if c.effect == "cable_elasticity").params)
    np.testing.assert_allclose(fitted, v, atol=0.05)
    assert rep.gap_before > 3 * SIGMA_UM and rep.gap_after < 1.15 * SIGMA_UM


def test_hidden_actuator_gain_is_not_taken_for_coupling(responses, model):
    rep = _run(responses, model, "actuator_gain", theta=[0.01])
    assert rep.named_effect == "actuator_gain"
    assert rep.gap_after < 1.15 * SIGMA_UM
