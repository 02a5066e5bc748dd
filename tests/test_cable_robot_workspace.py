"""Tension-feasible workspace and cabin attitude of the FAST feed support (beyond Yin J., Jiang
P., Chen M., Yao R., *Dynamic modeling of a cable-driven parallel robot with a Stewart platform
for use in FAST*): statics checked against closed forms and independent integrations, the
physical branch, and the attitude searches against brute-force neighbours."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import minimize_scalar

import stewart_jax  # noqa: F401
from stewart_jax.cable_robot import (
    WORKSPACE_STATUS,
    cabin_statics,
    focal_surface_point,
    paper_fast_params,
    smallest_feasible_tilt,
    static_equilibrium,
    workspace_map,
)

# Private building blocks tested against closed forms and brute force: the reflector's geometry,
# the assembly's centre of mass, the compiled statics (assess, cabin_statics' fast form), the
# attitudes solve_attitude dispatches to (with their own search settings) and rotation helpers.
from stewart_jax.cable_robot._attitude import (
    max_min_tension_attitude,
    rotation_from_vector,
    tilt_angle,
    towards_centre_attitude,
)
from stewart_jax.cable_robot._system import anchor_positions
from stewart_jax.cable_robot._workspace import assembly_centre_of_mass, assess, reflector_clearance, zenith_angle

static_equilibrium_jit = jax.jit(static_equilibrium)

PARAMS = paper_fast_params()
M_TOTAL = 25731.0 + 2371.0 + 6 * (165.34 + 60.12)  # Table 1: cabin, lower platform, legs
G = 9.8


def focal(x):
    return np.array([x, 0.0, 300.0 - np.sqrt(160.0**2 - x**2)])


@pytest.fixture(scope="module")
def level_map():
    xs = [0.0, 30.0, 60.0, 90.0]
    return xs, workspace_map(PARAMS, np.stack([focal(x) for x in xs]))


def test_focal_surface_passes_through_table2_positions():
    for pos in [(0.0, 0.0, 140.0), (30.0, 0.0, 142.8), (60.0, 0.0, 151.7), (90.0, 0.0, 167.7)]:
        z = np.arcsin(pos[0] / 160.0)
        np.testing.assert_allclose(focal_surface_point(z, 0.0), pos, atol=0.05)  # Table 2 rounds to 0.1 m
        np.testing.assert_allclose(zenith_angle(np.asarray(pos)), z, atol=2e-4)


def test_reflector_clearance_closed_form():
    # vertex, a point above it, a point on the sphere, the rim plane outside the aperture
    z_rim = 300.0 - np.sqrt(300.0**2 - 250.0**2)
    p = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 10.0],
                  [300 * np.sin(0.5), 0.0, 300 - 300 * np.cos(0.5)], [260.0, 0.0, 200.0]])
    np.testing.assert_allclose(reflector_clearance(p), [0.0, 10.0, 0.0, 200.0 - z_rim], atol=1e-9)


def test_centre_symmetric_tensions_and_weight(level_map):
    _, m = level_map
    t = np.asarray(m.tension_n[0])
    assert bool(m.feasible[0]) and WORKSPACE_STATUS[int(m.status[0])] == "feasible"
    # the cables carry the whole weight, equally to well below 1 % (3-fold symmetry; the
    # products of inertia do not enter the statics, the legs' layout is chiral)
    force = np.asarray(m.static.force[0])
    np.testing.assert_allclose(-force[:, 2].sum(), M_TOTAL * G, rtol=1e-12)
    assert np.ptp(t) / t.mean() < 1e-2
    # closed form for six alike cables: vertical share M g / 6 each
    np.testing.assert_allclose(-force[:, 2], M_TOTAL * G / 6, rtol=1e-2)


def test_moment_about_true_centre_of_mass_vanishes(level_map):
    xs, m = level_map
    for k in range(3):
        # independent: moment of the cable forces about the centre of mass from Table 1 masses
        pos = focal(xs[k])
        mass, com = assembly_centre_of_mass(PARAMS, jnp.asarray(pos), jnp.eye(3))
        np.testing.assert_allclose(float(mass), M_TOTAL, rtol=1e-14)
        arm = anchor_positions() + pos - np.asarray(com)
        moment = -np.cross(arm, np.asarray(m.static.force[k])).sum(0)
        assert np.max(np.abs(moment)) < 1e-6 * M_TOTAL * G * 6.5


def test_lowest_point_and_minimum_tension_by_integration(level_map):
    # [60, 0, 151.7]: cable 5 dips below its anchor; integrate eqs. 6-10 and compare the
    # lowest point and least tension with the closed form.
    _, m = level_map
    F, s0 = np.asarray(m.static.force[2][4]), float(m.static.s0[2][4])
    w = 13.898 * G

    def rhs(s, r):
        t = F + np.array([0.0, 0.0, -w * s])
        k = np.linalg.norm(t)
        return -t / k * (1.0 + k / 1.243e8)

    sol = solve_ivp(rhs, (0.0, s0), np.zeros(3), method="DOP853", rtol=1e-12, atol=1e-12,
                    dense_output=True)
    s = np.linspace(0.0, s0, 20001)
    z = sol.sol(s)[2]
    k = np.argmin(z)
    s_low = minimize_scalar(lambda v: sol.sol(v)[2], bounds=(s[k - 1], s[k + 1]), method="bounded",
                            options={"xatol": 1e-9}).x
    lowest = anchor_positions()[4] + focal(60.0) + sol.sol(s_low)
    np.testing.assert_allclose(np.asarray(m.lowest_point_m[2][4]), lowest, atol=1e-3)
    tension = np.linalg.norm(F[None, :] + np.outer(-w * s, [0, 0, 1]), axis=1)
    np.testing.assert_allclose(float(m.min_tension_n[2][4]), tension.min(), rtol=1e-8)
    assert z.min() < 0  # the dip is real


def test_level_feasibility_along_the_focal_surface(level_map):
    _, m = level_map
    assert [bool(f) for f in m.feasible] == [True, True, True, False]
    assert WORKSPACE_STATUS[int(m.status[3])] == "no_equilibrium"


def test_kilometre_loop_root_is_rejected():
    # Follow the level cabin's root outwards along the focal surface by continuation (warm
    # started 24x24 solves): past x = 66 m cable 5 sags onto the reflector, and the same
    # branch goes on to roots with a cable over a kilometre long. They satisfy the equations
    # but are not physical: feasibility rejects them.
    st = static_equilibrium_jit(PARAMS, jnp.asarray(focal(64.0)), jnp.eye(3))
    for x in np.arange(65.0, 80.01, 1.0):
        st = static_equilibrium_jit(PARAMS, jnp.asarray(focal(x)), jnp.eye(3),
                                    start=(st.force, st.s0))
        assert bool(st.converged), x
        if float(st.s0[4]) > 1000.0:
            break
    assert float(st.s0[4]) > 1000.0
    assert np.max(np.abs(np.asarray(st.residual[:18]))) < 1e-8
    cs = assess(PARAMS, focal(x), jnp.eye(3), static=st)
    assert bool(cs.converged) and not bool(cs.feasible) and not bool(cs.short_branch)
    assert WORKSPACE_STATUS[int(cs.status)] == "loop_branch"
    assert float(cs.clearance_m[4]) < -100.0  # hundreds of metres under the reflector
    # the default start stays on the physical branch where it is feasible
    st60 = static_equilibrium_jit(PARAMS, jnp.asarray(focal(60.0)), jnp.eye(3))
    assert float(st60.s0[4]) < 1.2 * np.linalg.norm(
        [300 * np.cos(4 * np.pi / 3), 300 * np.sin(4 * np.pi / 3), 270.0]
        - (anchor_positions()[4] + focal(60.0)))


def test_towards_centre_attitude_closed_form():
    pos = focal(90.0)
    R = np.asarray(towards_centre_attitude(pos))
    u = (np.array([0.0, 0.0, 300.0]) - pos) / 160.0
    np.testing.assert_allclose(R @ [0.0, 0.0, 1.0], u, atol=1e-12)
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(float(tilt_angle(R)), np.arcsin(90.0 / 160.0), rtol=1e-12)


def test_smallest_tilt_makes_the_fourth_position_feasible():
    sol = smallest_feasible_tilt(PARAMS, focal(90.0), n_axes=12, n_fan=4, tol=1e-4)
    assert sol.found and bool(sol.statics.feasible)
    assert 0.0 < sol.tilt_rad < np.deg2rad(10.0)
    # 1 % less tilt about the same axis is infeasible: the search sits on the boundary
    less = assess(PARAMS, focal(90.0), rotation_from_vector(0.99 * np.asarray(sol.rotation_vector)))
    assert not bool(less.feasible)


def test_max_min_tension_beats_its_neighbours():
    pos = focal(30.0)
    sol = max_min_tension_attitude(PARAMS, pos, max_iterations=60)
    best = float(np.min(sol.statics.min_tension_n))
    level = workspace_map(PARAMS, pos[None])
    assert best > float(np.min(level.min_tension_n)) + 20e3  # > 20 kN better than level
    rng = np.random.default_rng(1)
    d = rng.normal(size=(6, 3))
    d *= np.deg2rad(0.5) / np.linalg.norm(d, axis=1, keepdims=True)
    phi = np.asarray(sol.rotation_vector) + d
    nb = workspace_map(PARAMS, np.repeat(pos[None], 6, 0), np.asarray(rotation_from_vector(phi)))
    # neighbours 0.5 deg away do no better (to 0.5 kN: the search stops at 1e-5 rad steps
    # where ties between cables make the surface a ridge)
    assert np.all(np.min(np.asarray(nb.min_tension_n), axis=1) <= best + 500.0)


def test_bad_inputs_are_rejected():
    with pytest.raises(ValueError, match="positions"):
        workspace_map(PARAMS, np.zeros((2, 2)))
    with pytest.raises(ValueError, match="position"):
        cabin_statics(PARAMS, [0.0, np.nan, 140.0])


def test_cli_reports_infeasible_position_before_simulating(tmp_path, capsys):
    # Table 2's fourth position with a level cabin: refused with a clear message and strict
    # JSON (null where there is no number), without running the scenario.
    import json

    from stewart_jax._cli import build_parser, main

    out = tmp_path / "o.json"
    assert main(["fast", "--position", "90,0,167.7", "--json", str(out)]) == 1
    assert "no equilibrium" in capsys.readouterr().err

    def reject(c):
        raise ValueError(c)

    data = json.loads(out.read_text(), parse_constant=reject)
    assert data["workspace_status"] == "no_equilibrium" and data["tensions_n"] == [None] * 6
    assert data["attitude"]["kind"] == "level" and "axes" not in data
    assert main(["fast", "--position", "0,0,-1"]) == 2  # below the reflector
    assert "below" in capsys.readouterr().err
    args = build_parser().parse_args(["fast", "--attitude", "auto", "--modes"])
    assert args.attitude == "auto" and args.modes
