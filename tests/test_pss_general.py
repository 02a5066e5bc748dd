"""The generalised 6-PSS: arbitrary slider axes, given rod lengths, the 36/42/54 parameter sets.

Checked against the paper's model (vertical axes must reproduce it to rounding), an independent
plain-NumPy solution of the leg's quadratic, central differences, forward kinematics, the
discrepancy workflow's ``actuator_tilt`` effect (a second implementation of a tilted slider) and
a calibration that needs the larger parameter sets. Public API only.
"""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import stewart_jax as sj
from stewart_jax.calibration import validation_poses
from stewart_jax.discrepancy import get_effect, model_for
from stewart_jax.mechanism import PSSMechanism, inverse_kinematics_soa, load_mechanism, preset, save_mechanism

DEG = np.pi / 180
HALF = np.array([1.0, 1.0, 1.0, DEG, DEG, DEG])  # the paper's travel, ±1 mm and ±1°


def grid(seed, n, scale=1.0):
    return jnp.asarray(np.random.default_rng(seed).uniform(-1, 1, (n, 6)) * HALF * scale)


def general_mechanism(param_set="54", seed=0, tilt_mrad=20.0, dl_mm=0.7):
    """The paper's nominal joints with every slider axis tilted by up to ``tilt_mrad`` and rods
    longer by up to ``dl_mm``."""
    g = sj.nominal_geometry()
    rng = np.random.default_rng(seed)
    axes = np.array([0.0, 0.0, 1.0]) + rng.uniform(-1, 1, (6, 3)) * tilt_mrad * 1e-3
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    lengths = np.asarray(g.rod_lengths) + rng.uniform(0, dl_mm, 6)
    return PSSMechanism(g.upper, g.lower, g.v0, axes=axes, rod_lengths=lengths, param_set=param_set)


def np_rotation(phi, theta, psi):
    c, s = np.cos, np.sin
    rx = np.array([[1, 0, 0], [0, c(phi), -s(phi)], [0, s(phi), c(phi)]])
    ry = np.array([[c(theta), 0, s(theta)], [0, 1, 0], [-s(theta), 0, c(theta)]])
    rz = np.array([[c(psi), -s(psi), 0], [s(psi), c(psi), 0], [0, 0, 1]])
    return rz @ ry @ rx


def np_readings(upper, lower, v0, axes, lengths, pose):
    """The smaller root of ``|w − q·n|² = L²`` by the textbook quadratic formula."""
    w = upper @ np_rotation(*pose[3:]).T + pose[:3] + v0 - lower
    b = np.sum(w * axes, axis=1)
    return b - np.sqrt(lengths**2 - np.sum(w * w, axis=1) + b**2)


@pytest.mark.parametrize("param_set", ["36", "42", "54"])
def test_vertical_axes_reproduce_the_paper_model(param_set):
    """Every parameter set with explicit e_z axes and the zero-pose rod lengths is the paper's
    mechanism: same readings and pose Jacobian to rounding, same 36 leading parameters."""
    g = sj.nominal_geometry()
    gen = PSSMechanism(g.upper, g.lower, g.v0, axes=np.tile([0.0, 0.0, 1.0], (6, 1)), param_set=param_set)
    poses = grid(1, 200)
    q0, _, j0 = g.ik_and_jacobian(poses)
    q1, _, j1 = gen.ik_and_jacobian(poses)
    # the general formula rationalises with |w|² − L² instead of eq. 4's per-axis growth: the
    # two differ in the last bits of ~1 mm strokes and ~200 mm Jacobian entries
    np.testing.assert_allclose(np.asarray(q1), np.asarray(q0), rtol=0, atol=1e-14)
    np.testing.assert_allclose(np.asarray(j1), np.asarray(j0), rtol=0, atol=1e-12)
    assert gen.n_params == int(param_set) and len(gen.param_names) == int(param_set)
    np.testing.assert_array_equal(np.asarray(gen.params[:36]), np.asarray(g.params))


def test_inverse_kinematics_matches_numpy_quadratic():
    m = general_mechanism()
    poses = np.asarray(grid(2, 100))
    ours = np.asarray(m.solve_inverse_kinematics(jnp.asarray(poses)).readings)
    args = [np.asarray(x) for x in (m.upper, m.lower, m.v0, m.slider_axes, m.rod_lengths)]
    ref = np.stack([np_readings(*args, p) for p in poses])
    # the textbook formula subtracts two ~217 mm numbers: ~1e-13 mm of rounding
    np.testing.assert_allclose(ours, ref, rtol=0, atol=1e-11)


def test_tilts_are_the_actuator_tilt_effect():
    """The 54-parameter set's tilts move the slider exactly as the discrepancy workflow's
    ``actuator_tilt`` effect (α about x, then β about y), an independent implementation."""
    g = sj.nominal_geometry()
    theta = np.random.default_rng(3).normal(0, 5e-3, 12)  # rad
    gen = PSSMechanism(g.upper, g.lower, g.v0, tilt=theta * 1e3, param_set="54")
    poses = grid(4, 30)
    model = model_for(g)
    data = sj.calibration.make_calibration_data(np.zeros((30, 6)), poses)
    effect = get_effect("6-pss", "actuator_tilt")
    ref = model.predict(model.base_initial, (effect,), (jnp.asarray(theta),), data, control=True)
    np.testing.assert_allclose(np.asarray(gen.solve_inverse_kinematics(poses).readings), np.asarray(ref),
                               rtol=0, atol=1e-12)


def test_pose_jacobian_matches_central_differences():
    m = general_mechanism()
    poses = grid(5, 20)
    _, _, jac = m.ik_and_jacobian(poses)
    h = np.array([1e-5] * 3 + [1e-7] * 3)
    fd = np.stack(
        [(np.asarray(m.solve_inverse_kinematics(poses + h[k] * np.eye(6)[k]).readings)
          - np.asarray(m.solve_inverse_kinematics(poses - h[k] * np.eye(6)[k]).readings)) / (2 * h[k])
         for k in range(6)], axis=-1)
    np.testing.assert_allclose(np.asarray(jac), fd, rtol=1e-7, atol=1e-6)  # central-difference truncation


def test_parameter_jacobian_matches_central_differences():
    m = general_mechanism("54")  # the 42-parameter set is its first 42 columns
    poses = grid(6, 10)
    jac = np.asarray(m.parameter_jacobian(poses))
    u = np.asarray(m.params)
    h = 1e-6
    steps = jnp.asarray(u + h * np.eye(len(u))), jnp.asarray(u - h * np.eye(len(u)))
    readings = jax.jit(jax.vmap(lambda p: m.with_params(p).solve_inverse_kinematics(poses).readings.reshape(-1)))
    fd = (np.asarray(readings(steps[0])) - np.asarray(readings(steps[1]))).T / (2 * h)
    assert jac.shape == (60, 54)
    # each leg's readings depend on its own parameters only, as leg_parameters declares
    for i, cols in enumerate(m.leg_parameters):
        others = np.setdiff1d(np.arange(54), cols)
        assert np.all(jac[i::6][:, others] == 0) and np.all(np.any(jac[i::6][:, list(cols)] != 0, axis=0))
    np.testing.assert_allclose(jac, fd, rtol=1e-6, atol=1e-7)
    # a rod length acts one-for-one on its own leg's reading, against the slider's direction of
    # the rod: ∂q_i/∂L_i = −L_i / (n·(w − q·n))
    assert np.all(jac[:, 36:42][np.arange(60), np.arange(60) % 6] < -1.0)


def test_forward_kinematics_round_trip():
    m = general_mechanism()
    poses = grid(7, 64)
    q = m.solve_inverse_kinematics(poses).readings
    fk = sj.forward_kinematics(m, q, jnp.zeros_like(poses))
    assert bool(np.all(fk.converged))
    err = np.abs(np.asarray(fk.poses - poses))
    assert err[:, :3].max() < 1e-9 and err[:, 3:].max() < 1e-11


@pytest.mark.parametrize("param_set", ["36", "42", "54"])
def test_params_and_file_round_trip(param_set, tmp_path):
    m = general_mechanism(param_set)
    u = m.params + 0.01 * jnp.arange(m.n_params)
    np.testing.assert_array_equal(np.asarray(m.with_params(u).params), np.asarray(u))
    m2 = m.with_params(u)
    save_mechanism(m2, tmp_path / "g.json")
    back = load_mechanism(tmp_path / "g.json")
    assert back.param_set == param_set
    poses = grid(8, 20)
    np.testing.assert_allclose(np.asarray(back.solve_inverse_kinematics(poses).readings),
                               np.asarray(m2.solve_inverse_kinematics(poses).readings), rtol=0, atol=1e-12)


def test_file_keys_choose_the_parameter_set(tmp_path):
    g = sj.nominal_geometry().to_dict()
    assert "axes" not in g and "rod_lengths" not in g and "param_set" not in g  # the paper's files unchanged
    lengths = np.asarray(sj.nominal_geometry().rod_lengths).tolist()
    cases = [({}, "36"), ({"rod_lengths": lengths}, "42"), ({"axes": np.tile([0, 0, 1.0], (6, 1)).tolist()}, "54"),
             ({"rod_lengths": lengths, "param_set": "36"}, "36")]
    for extra, expected in cases:
        path = tmp_path / "g.json"
        path.write_text(json.dumps({**g, **extra}))
        assert load_mechanism(path).param_set == expected


@pytest.mark.parametrize(
    "change, message",
    [
        ({"axes": [[0, 0, 2.0]] * 6}, "unit vectors"),
        ({"rod_lengths": [10.0] * 6}, "cannot be assembled"),
        ({"rod_lengths": [-1.0] * 6}, "positive"),
        ({"param_set": "48"}, "param_set"),
        ({"axes": [[0, 0, 1.0]] * 5}, "axes"),
    ],
)
def test_bad_generalised_files_name_the_field(change, message, tmp_path):
    path = tmp_path / "g.json"
    path.write_text(json.dumps({**sj.nominal_geometry().to_dict(), **change}))
    with pytest.raises(ValueError, match=message):
        load_mechanism(path)


def test_fast_path_refuses_a_generalised_mechanism():
    with pytest.raises(TypeError, match="solve_inverse_kinematics"):
        inverse_kinematics_soa(general_mechanism(), grid(9, 4).T)


@pytest.mark.slow  # four parameter sets calibrated: 22 s
def test_larger_parameter_sets_calibrate_what_the_paper_model_cannot():
    """Data from a mechanism with tilted sliders and longer rods: the 36-parameter model stays
    far above the noise floor; the 54-parameter model reaches it and commands the true mechanism
    at the noise level."""
    g = sj.nominal_geometry()
    true = general_mechanism("54", seed=11, tilt_mrad=10.0, dl_mm=0.3)
    targets = validation_poses(jax.random.key(10), 48)  # 48 poses: 288 readings for 54 parameters
    sim = sj.simulate_measurements(jax.random.key(12), g, true, targets)
    assert bool(np.all(sim.converged))
    fresh = validation_poses(jax.random.key(13), 40)
    costs, worst = {}, {}
    for ps in ("36", "54"):
        nominal = g.with_param_set(ps)
        problem = sj.calibration_problem(sim.data, nominal)
        res = sj.calibrate(problem, "lm-batched")
        costs[ps] = float(res.cost)
        err = np.asarray(sj.control_error(problem.calibrated(res.params), true, fresh).errors)
        worst[ps] = np.abs(err[:, :3]).max()
    floor = float(sj.calibration_problem(sim.data, true.with_param_set("54")).cost(true.params))
    assert costs["36"] > 100 * floor
    assert costs["54"] <= floor
    assert worst["54"] < 1e-3 < worst["36"]  # mm: < 1 µm with the full model


def test_command_line_param_set_names_the_family_it_needs(tmp_path, capsys):
    from stewart_jax._cli import main

    csv = tmp_path / "m.csv"
    rows = np.random.default_rng(0).uniform(-1, 1, (8, 12))
    csv.write_text("q1,q2,q3,q4,q5,q6,x,y,z,rx,ry,rz\n" + "\n".join(",".join(map(str, r)) for r in rows) + "\n")
    assert main(["calibrate", str(csv), "--geometry", "rubin_m2", "--param-set", "54"]) == 2
    assert "6-UPS, which has one fixed parameter set (42 parameters)" in capsys.readouterr().err
    assert main(["calibrate", str(csv), "--geometry", "nominal", "--param-set", "48"]) == 2
    assert "6-PSS, which has the parameter sets 36, 42, 54" in capsys.readouterr().err


def test_param_set_is_declared_by_every_family():
    """``param_sets``/``with_param_set`` are the mechanism contract: a fixed family refuses any set,
    a family with sets refuses one it lacks and switches to one it has."""
    ups, rus, pss = preset("rubin_m2"), preset("rotary_stewart"), preset("nominal")
    assert ups.param_sets == ()
    with pytest.raises(ValueError, match="one fixed parameter set"):
        ups.with_param_set("42")
    assert rus.with_param_set("48").n_params == 48 and rus.param_sets == ("54", "48")
    with pytest.raises(ValueError, match="6-RUS param_set must be one of"):
        rus.with_param_set("36")
    assert pss.with_param_set("54").n_params == 54


@pytest.mark.parametrize("param_set", ["42", "54"])
def test_discrepancy_model_wraps_a_generalised_mechanism(param_set):
    """The 6-PSS discrepancy model of any parameter set: its base parameters are the mechanism's, its
    base prediction the mechanism's readings (tilted axes, given rod lengths), and the rod lengths'
    thermal expansion is of the given rods."""
    g = general_mechanism(param_set)
    model = model_for(g)
    np.testing.assert_array_equal(model.base_initial, g.params)
    poses = grid(6, 12)
    data = sj.calibration.make_calibration_data(np.zeros((12, 6)), poses, temperature=np.full(12, 30.0))
    np.testing.assert_allclose(model.predict(model.base_initial, (), (), data),
                               g.solve_inverse_kinematics(poses).readings, rtol=0, atol=1e-12)
    alpha = np.full(6, 2e-5)  # 1/K, 10 K above the reference: every rod 2e-4 of its length longer
    longer = PSSMechanism(g.upper, g.lower, g.v0, axes=g.slider_axes, rod_lengths=g.rod_lengths * (1 + 10 * alpha))
    got = model.predict(model.base_initial, (get_effect("6-pss", "thermal_expansion"),), (jnp.asarray(alpha),), data)
    np.testing.assert_allclose(got, longer.solve_inverse_kinematics(poses).readings, rtol=0, atol=1e-11)
