"""FAST inputs are physical: each test names the class of bad input it stands for. All are refused
before the scenario is compiled (the command returns at once)."""

import time

import numpy as np
import pytest

from stewart_jax._cli import main
from stewart_jax.cable_robot import CableParams, paper_fast_params, run_scenario
from stewart_jax.cable_robot._inputs import (
    MIN_STEPS_PER_PERIOD,
    check_time_step,
    focal_surface_warning,
    highest_mode_bound_hz,
)

PARAMS = paper_fast_params()


def _fast(argv, capsys):
    t0 = time.perf_counter()
    rc = main(["fast", *argv])
    return rc, capsys.readouterr().err, time.perf_counter() - t0


@pytest.mark.parametrize("dt", ["0.1", "0.05", "0.025"])
def test_a_time_step_too_coarse_for_the_forcing_is_refused_before_work(dt, capsys):
    """Class: dt of a few steps per period of the 5 Hz forcing (0.1 s reported an amplitude 8× off)."""
    rc, err, seconds = _fast(["--dt", dt], capsys)
    assert rc == 2 and "too coarse" in err and "5 Hz" in err and seconds < 5, err
    assert f"at least {MIN_STEPS_PER_PERIOD}" in err


def test_a_marginal_time_step_is_warned_with_the_expected_error():
    """The warning's amplitude error is that of a sampled sine's peak, checked here by sampling
    sines of random phase at that step (an independent computation)."""
    dt = 0.005  # 40 steps per period of 5 Hz
    message = check_time_step(dt, 5.0)
    assert message and "40 steps per period" in message
    stated = float(message.split("low by up to ")[1].split("%")[0]) / 100
    t = np.arange(0, 1.0, dt)
    worst = max(1 - np.max(np.sin(2 * np.pi * 5 * t + phase)) for phase in np.linspace(0, 2 * np.pi, 997))
    assert stated == pytest.approx(worst, rel=0.05)
    assert check_time_step(1e-3, 5.0) is None  # the default: 200 steps per period


def test_the_highest_mode_counts_when_it_is_faster_than_the_forcing():
    """Class: a step that resolves the forcing but not a stiffer cabin (cables 100× stiffer)."""
    stiff = paper_fast_params()
    stiff = type(stiff)(**{**{f: getattr(stiff, f) for f in stiff.__dataclass_fields__},
                           "cable": CableParams(EA=1.243e10, rho=13.898, g=-9.8)})
    f_mode = highest_mode_bound_hz(stiff, (0.0, 0.0, 140.0))
    assert f_mode > 5.0
    assert check_time_step(0.015, 5.0) is not None  # 13 steps per forcing period: only warned
    with pytest.raises(ValueError, match="highest natural frequency"):
        check_time_step(0.015, 5.0, f_mode)


def test_the_mode_bound_is_above_the_computed_modes():
    """The straight-cable bound against the cabin's modes on its catenaries (a second method)."""
    import jax
    import jax.numpy as jnp

    from stewart_jax.cable_robot import cabin_modes, solve_attitude

    cabin_modes_jit = jax.jit(cabin_modes)

    position = np.array([0.0, 0.0, 140.0])
    sol = solve_attitude(PARAMS, position, "level")
    modes = cabin_modes_jit(PARAMS, jnp.asarray(position), jnp.asarray(sol.R), sol.statics.static)
    highest = float(np.max(np.asarray(modes.frequencies_hz)))
    assert highest <= highest_mode_bound_hz(PARAMS, position) <= 3 * highest


@pytest.mark.parametrize("kwargs, says", [
    ({"EA": -1.243e8}, "EA must be a positive"), ({"EA": 0.0}, "EA must be a positive"),
    ({"rho": 0.0}, "rho must be a positive"), ({"rho": -13.9}, "rho must be a positive"),
    ({"g": 9.8}, "gravity pointing up"), ({"g": 0.0}, "zero gravity"), ({"EA": float("nan")}, "EA"),
])
def test_unphysical_cable_material_is_refused(kwargs, says):
    """Class: negative or zero EA, density or gravity."""
    with pytest.raises(ValueError, match=says):
        CableParams(**kwargs)


def test_unphysical_cabin_is_refused():
    with pytest.raises(ValueError, match="gravity"):
        paper_fast_params(g=0.0)
    fields = {f: getattr(PARAMS, f) for f in PARAMS.__dataclass_fields__}
    with pytest.raises(ValueError, match="mass m_CB"):
        type(PARAMS)(**{**fields, "m_CB": -25731.0})
    with pytest.raises(ValueError, match="positive definite"):
        type(PARAMS)(**{**fields, "I_CB": -np.asarray(PARAMS.I_CB)})


@pytest.mark.parametrize("position, says", [
    ("0,0,1000", "above the tower tops"),          # 1 km up (was called "below the reflector")
    ("0,0,270", "above the tower tops"),
    ("0,0,-5", "below the reflector's surface"),
    ("0,0,0", "below the reflector's surface"),
    ("400,0,150", "outside the towers' circle"),
    ("260,0,100", "at or below the ground outside the aperture"),
])
def test_a_position_outside_the_workspace_is_named_for_what_it_is(position, says, capsys):
    rc, err, seconds = _fast(["--position", position], capsys)
    assert rc == 2 and says in err and seconds < 5, err


def test_the_library_names_the_position_too():
    with pytest.raises(ValueError, match="above the tower tops"):
        run_scenario(PARAMS, np.array([0.0, 0.0, 1000.0]))
    with pytest.raises(ValueError, match="too coarse"):
        run_scenario(PARAMS, np.array([0.0, 0.0, 140.0]), dt=0.1)


def test_a_position_off_the_focal_surface_is_warned():
    assert focal_surface_warning((0.0, 0.0, 140.0)) is None  # Table 2's centre
    assert "inside the focal surface" in focal_surface_warning((0.0, 0.0, 180.0))


@pytest.mark.parametrize("option", ["--json", "--plot"])
def test_an_output_path_is_checked_before_the_run(option, tmp_path, capsys):
    """Class: an output into a missing folder (was refused only after the run, naming the
    temporary ``.partial`` file)."""
    path = tmp_path / "missing" / "out.json"
    rc, err, seconds = _fast([option, str(path)], capsys)
    assert rc == 2 and str(path) in err and ".partial" not in err and seconds < 5, err



@pytest.mark.parametrize("argv, says", [
    (["--cables", "lumped", "--modes", "--segments", "5000"], "at most 200"),
    (["--cables", "lumped", "--modes", "--segments", "1"], "at least 2"),
])
def test_segments_outside_what_converges_and_fits_are_refused(argv, says, capsys):
    # 5000 segments ran for minutes with no answer; both ends refused before any work (exit 2)
    assert main(["fast", *argv]) == 2
    assert says in capsys.readouterr().err


def test_a_free_decay_too_long_for_memory_says_how_long_it_can_take(monkeypatch):
    # 10⁶ s at the integrator's 1 ms step died allocating 48 GB inside XLA; refused before
    from stewart_jax import _memory
    from stewart_jax.cable_robot import _free_decay as fd

    monkeypatch.setattr(_memory, "available_memory_bytes", lambda: 4_000_000_000)
    with pytest.raises(ValueError, match=r"can simulate up to 5208 s at this step") as e:
        fd.check_steps(10**9, 1e-3)
    assert "384 GB" in str(e.value)
    fd.check_steps(5_000_000, 1e-3)  # 5000 s fits in 2 GB
