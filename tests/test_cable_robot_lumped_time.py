"""Time response of the FAST cabin on lumped-mass cables: a free decay in one mode against the
damped oscillator's closed form, a harmonic forced response against the frequency response
function of the linearised system (K, M, modal damping), the batch over positions against
single runs, and the refused inputs."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import stewart_jax  # noqa: F401
from stewart_jax.cable_robot import lumped_modes, modal_summary, paper_fast_params, simulate_lumped

# The slow tier (make test-all runs it, make test does not): lumped-mass time integration, shared by every test
# here (35 s on 2 cores).
pytestmark = pytest.mark.slow

PARAMS = paper_fast_params()
N = 8


@pytest.fixture(scope="module")
def centre():
    return lumped_modes(PARAMS, [0.0, 0.0, 140.0], N)


def test_free_decay_matches_the_damped_oscillator(centre):
    k = modal_summary(centre).dominant["heave"][0]
    w = 2 * np.pi * float(centre.frequencies_hz[k])
    phi = np.asarray(centre.shapes[:, k])
    eps = 1e-3 / np.max(np.abs(phi[:3]))  # 1 mm at the cabin: the nonlinear forces stay linear
    zeta, dt = 0.02, 0.005
    tr = simulate_lumped(PARAMS, centre, dt, 6000, displacement=eps * phi, damping_ratio=zeta)
    t = np.asarray(tr.time)
    wd = w * np.sqrt(1 - zeta**2)
    exact = eps * np.exp(-zeta * w * t) * (np.cos(wd * t) + zeta / np.sqrt(1 - zeta**2) * np.sin(wd * t))
    # every cabin coordinate moves in the mode's shape
    for c in range(6):
        if abs(phi[c]) > 1e-3 * np.max(np.abs(phi[:6])):
            np.testing.assert_allclose(np.asarray(tr.cabin[:, c]) / phi[c], exact, rtol=0, atol=2e-3 * eps)


def test_harmonic_force_matches_the_frequency_response(centre):
    zeta, dt, n = 0.2, 0.005, 10000
    omega = 2 * np.pi * 0.5
    t = np.arange(n + 1) * dt
    F0 = 1e4  # N on the heave coordinate
    f = np.zeros((n + 1, 6))
    f[:, 2] = F0 * np.sin(omega * t)
    tr = simulate_lumped(PARAMS, centre, dt, n, force=f, damping_ratio=zeta)
    z = np.asarray(tr.cabin[:, 2])
    tail = t > 35.0  # transients decay at ≥ ζ·2π·0.1 Hz: e^-4.4 by then
    A = np.stack([np.sin(omega * t[tail]), np.cos(omega * t[tail])], 1)
    coef = np.linalg.lstsq(A, z[tail], rcond=None)[0]
    phi = np.asarray(centre.shapes)
    w = 2 * np.pi * np.asarray(centre.frequencies_hz)
    H = np.sum(phi[2] ** 2 / (w**2 - omega**2 + 2j * zeta * w * omega))
    np.testing.assert_allclose(coef[0] + 1j * coef[1], F0 * H, rtol=2e-2)  # F0 sin Ωt → Im(F0 H e^{iΩt})


def test_batch_over_positions_equals_single_runs(centre):
    other = lumped_modes(PARAMS, [30.0, 0.0, 142.8], N)
    stack = jax.tree.map(lambda a, b: jnp.stack([a, b]), centre, other)
    rng = np.random.default_rng(1)
    v0 = rng.normal(size=(2, centre.frequencies_hz.shape[0])) * 1e-3
    batch = simulate_lumped(PARAMS, stack, 0.005, 400, velocity=v0, damping_ratio=0.01)
    for i, m in enumerate((centre, other)):
        one = simulate_lumped(PARAMS, m, 0.005, 400, velocity=v0[i], damping_ratio=0.01)
        np.testing.assert_allclose(np.asarray(batch.cabin[i]), np.asarray(one.cabin), rtol=0, atol=1e-12)


def test_bad_input(centre):
    f_max = float(centre.frequencies_hz[-1])
    with pytest.raises(ValueError, match="stability limit"):
        simulate_lumped(PARAMS, centre, 2.0 / (2 * np.pi * f_max), 10)
    with pytest.raises(ValueError, match="damping_ratio"):
        simulate_lumped(PARAMS, centre, 0.005, 10, damping_ratio=-0.1)
    with pytest.raises(ValueError, match="force must have shape"):
        simulate_lumped(PARAMS, centre, 0.005, 10, force=np.zeros((10, 6)))
    with pytest.raises(ValueError, match="n_steps"):
        simulate_lumped(PARAMS, centre, 0.005, 0)
