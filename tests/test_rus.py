"""The 6-RUS rotary hexapod: what the registry-driven tests (``test_mechanism.py``,
``test_workspace.py``, ``test_any_hexapod.py``, ``test_batched_lm.py``, ``test_population_cost.py``)
do not check — the crank readings against Eisele's (2019) closed form written independently in
NumPy, the preset against the published design, the crank limits, the units through the command
line and the report, and the discrepancy workflow with the family's own effects.

One hidden-effect data set is diagnosed with one set of candidates throughout, so that the
in-memory diagnosis and the command line's share one set of compiled kernels.
"""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from _numpy_reference import rotation

import stewart_jax as sj
from stewart_jax import discrepancy as dc
from stewart_jax._cli import main
from stewart_jax.mechanism import RUSMechanism, preset

CANDIDATES = ("gear_ratio", "crank_offset", "backlash")
SEED = 7


@pytest.fixture(scope="module")
def rotary():
    return preset("rotary_stewart")


def eisele_crank_angles(m, poses):
    """Eisele's closed form (his ``update``/``getServoAngles``): with ``l`` the rod vector from the
    motor to the platform joint, ``g = |l|² − s² + a²``, ``e = 2a·l_z``, ``f = 2a·(cos β·l_x + sin β·l_y)``,
    ``sin α = g·e/(e² + f²) − f·sqrt(1 − g²/(e² + f²))/sqrt(e² + f²)``; here ``α`` from the crank
    end's height and horizontal reach, so that it is not limited to ±90°."""
    base, platform, v0 = (np.asarray(x) for x in (m.base, m.platform, m.v0))
    a, s, beta = np.asarray(m.crank_lengths), np.asarray(m.rod_lengths), np.asarray(m.azimuth)
    out = []
    for p in poses:
        q = platform @ rotation(p[3:]).T + p[:3] + v0
        lv = q - base
        g = np.sum(lv * lv, -1) - s**2 + a**2
        e = 2 * a * lv[:, 2]
        f = 2 * a * (np.cos(beta) * lv[:, 0] + np.sin(beta) * lv[:, 1])
        sq = e**2 + f**2
        sin_a = g * e / sq - f * np.sqrt(1 - g**2 / sq) / np.sqrt(sq)
        cos_a = g * f / sq + e * np.sqrt(1 - g**2 / sq) / np.sqrt(sq)
        out.append(np.arctan2(sin_a, cos_a))
    return np.array(out)


def travel_poses(m, n, seed=0):
    return np.random.default_rng(seed).uniform(-1, 1, (n, 6)) * np.asarray(m.travel_half_widths)


# ---------------------------------------------------------------- the mechanism


def test_preset_is_eiseles_published_design(rotary):
    """``stewart.js``'s ``initCircular`` defaults, recomputed here: base radius 80 mm, platform
    radius 50 mm, 20 mm between the motors and between the joints of a pair, horns 50 mm, rods
    130 mm, home height ``sqrt(s² + a² − Δx² − Δy²)``."""
    for i in range(6):
        pm, sep = (-1) ** i, 20.0 / 80.0
        phi_b = (i + i % 2) * np.pi / 3 + pm * sep / 2
        phi_p = (1 + i - i % 2) * np.pi / 3 - pm * sep / 2
        np.testing.assert_allclose(rotary.base[i], [80 * np.cos(phi_b), 80 * np.sin(phi_b), 0], atol=1e-12)
        np.testing.assert_allclose(rotary.platform[i], [50 * np.cos(phi_p), 50 * np.sin(phi_p), 0], atol=1e-12)
        np.testing.assert_allclose(np.cos(rotary.azimuth[i] - phi_b - np.pi / 2), (-1) ** (i % 2), atol=1e-15)
    d = np.asarray(rotary.platform[0, :2] - rotary.base[0, :2])
    assert float(rotary.v0[2]) == pytest.approx(np.sqrt(130**2 + 50**2 - d @ d), rel=1e-15)
    assert rotary.param_units == ("mm",) * 48 + ("rad",) * 6 and rotary.reading_unit == "rad"


def test_readings_are_eiseles_crank_angles(rotary):
    poses = travel_poses(rotary, 40)
    q = np.asarray(rotary.solve_inverse_kinematics(jnp.asarray(poses)).readings)
    ref = eisele_crank_angles(rotary, poses) - np.asarray(rotary.crank_zero)
    np.testing.assert_allclose(q, ref, rtol=0, atol=1e-13)  # rad; two formulas, rounding ~1e-15
    np.testing.assert_array_equal(rotary.solve_inverse_kinematics(jnp.zeros(6)).readings, np.zeros(6))
    # and the leg itself: the crank end lies one rod length from the platform joint
    alpha = q + np.asarray(rotary.crank_zero)
    u = np.stack([np.cos(rotary.azimuth), np.sin(rotary.azimuth), np.zeros(6)], -1)
    ends = (np.asarray(rotary.base) + np.asarray(rotary.crank_lengths)[:, None]
            * (np.cos(alpha)[..., None] * u + np.sin(alpha)[..., None] * np.array([0.0, 0.0, 1.0])))
    joints = np.asarray(rotary.moving_joints(jnp.asarray(poses)))
    np.testing.assert_allclose(np.linalg.norm(joints - ends, axis=-1), 130.0, rtol=0, atol=1e-11)


def test_crank_limits_and_rod_reach_bound_the_workspace(rotary):
    free = RUSMechanism(rotary.base, rotary.platform, rotary.v0, rotary.crank_lengths, rotary.rod_lengths,
                        rotary.azimuth)
    down = jnp.array([0.0, 0.0, -62.0, 0.0, 0.0, 0.0])  # cranks beyond −90°, still assembled
    assert bool(free.solve_inverse_kinematics(down).reachable)
    sol = rotary.solve_inverse_kinematics(down)
    alpha = np.asarray(sol.readings + rotary.crank_zero)
    assert not bool(sol.reachable) and np.all(alpha < -np.pi / 2)
    np.testing.assert_allclose(sol.margin, 50.0 * (alpha + np.pi / 2), rtol=1e-12)  # the arc beyond, mm
    up = jnp.array([0.0, 0.0, 50.0, 0.0, 0.0, 0.0])  # the rods cannot reach the cranks' circles
    assert not bool(free.solve_inverse_kinematics(up).reachable)


def test_sizes_and_labels_follow_each_parameters_unit(rotary):
    # a perturbation σ "0.5" is 0.5 mm on a length and 0.5 mrad on an angle, in the parameter's unit
    true = sj.calibration.perturbed(rotary, jax.random.key(0), 0.5)
    d = np.asarray(true.params - rotary.params)
    assert 0.25 < d[:48].std() < 0.75 and 2.5e-4 < d[48:].std() < 7.5e-4  # 48 and 6 draws: wide margins
    nine = sj.calibration.make_calibration_data(np.zeros((9, 6)), np.zeros((9, 6)))  # 54 residuals, 54 parameters
    box = sj.calibration_problem(nine, rotary, 2.0, 3.0)
    np.testing.assert_allclose(np.asarray(box.upper - rotary.params), [2.0] * 48 + [3e-3] * 6, rtol=1e-12)
    np.testing.assert_array_equal(preset("nominal").with_param_set("54").natural_scales(2.0)[-12:], 2.0)  # mrad


def test_geometry_file_round_trip_and_bad_files(rotary, tmp_path):
    d = rotary.to_dict()
    assert d["mechanism"] == "6-RUS" and "crank_zero_rad" in d and d["travel"]["rx_deg"] == pytest.approx(5.0)
    del d["crank_azimuths_rad"]
    d["crank_azimuths_deg"] = np.degrees(rotary.azimuth).tolist()
    back = RUSMechanism.from_dict(d)
    np.testing.assert_allclose(back.azimuth, rotary.azimuth, rtol=0, atol=1e-15)
    with pytest.raises(ValueError, match="crank_azimuths_rad or crank_azimuths_deg"):
        RUSMechanism.from_dict({k: v for k, v in d.items() if k != "crank_azimuths_deg"})
    with pytest.raises(ValueError, match="crank_lengths must be positive"):
        RUSMechanism.from_dict({**d, "crank_lengths": [50.0] * 5 + [0.0]})
    with pytest.raises(ValueError, match="zero pose is not reachable"):  # the generic checks, at every file load
        sj.mechanism.mechanism_from_dict({**d, "rod_lengths": [60.0] * 6})


# ---------------------------------------------------------------- the command line, units in every output


@pytest.mark.slow  # a diagnosis or the whole command line: 20-35 s
def test_simulate_calibrate_report_export_through_the_command_line(rotary, tmp_path, capsys):
    geo, csv, true_json = tmp_path / "rus.json", tmp_path / "rus.csv", tmp_path / "true.json"
    cal, report, out_geo = tmp_path / "cal.json", tmp_path / "report.md", tmp_path / "cal_geo.json"
    assert main(["export", "rotary_stewart", "--out", str(geo)]) == 0
    assert main(["simulate", "--geometry", str(geo), "--plan", "plan120", "--seed", "2", "--out", str(csv),
                 "--out-true", str(true_json)]) == 0
    header = csv.read_text().splitlines()[0].split(",")
    q_deg = np.array([float(c) for c in csv.read_text().splitlines()[5].split(",")[:6]])
    assert header[:6] == [f"q{i}" for i in range(1, 7)] and np.max(np.abs(q_deg)) > 1.0  # degrees, not rad
    assert main(["calibrate", str(csv), "--geometry", str(geo), "--json", str(cal), "--report", str(report),
                 "--holdout", "0", "--out-geometry", str(out_geo)]) == 0
    res = json.loads(cal.read_text())
    assert res["status"] == "success" and res["data_status"] == "ok" and len(res["params"]) == 54
    assert res["param_units"] == ["mm"] * 48 + ["rad"] * 6 and "rms_residual_um" not in res
    assert 0 < res["rms_residual_urad"] < 10 and res["half_width_mrad"] == res["half_width_mm"] == 10.0
    text = report.read_text()
    assert "rad²" in text and "| crank_zero1 | rad |" in text and "µrad |" in text
    assert not any("crank_zero" in line and "µm" in line for line in text.splitlines())
    nominal, true, calibrated = (np.asarray(sj.load_mechanism(p).params) for p in (geo, true_json, out_geo))
    # the true mechanism is the nominal one perturbed by 0.5 mm and 0.5 mrad (σ); the calibration
    # recovers both kinds of parameter to a few hundredths of that (predicted std ~10 µm, ~20 µrad)
    for part in (slice(0, 48), slice(48, 54)):
        after, before = (float(np.sqrt(np.mean((x - true)[part] ** 2))) for x in (calibrated, nominal))
        assert after < 0.1 * before, (part, after, before)
    capsys.readouterr()


# ---------------------------------------------------------------- the discrepancy workflow


@pytest.fixture(scope="module")
def rows(rotary):
    rng = np.random.default_rng(0)
    poses = travel_poses(rotary, 8, 1)
    cond = dc.random_conditions(rng, 8)
    return sj.calibration.make_calibration_data(np.zeros((8, 6)), poses, cond.directions, cond.temperature, cond.time)


def test_model_wraps_the_mechanism_and_its_effects_match_independent_physics(rotary, rows):
    model = dc.model_for(rotary)
    assert model.name == "6-rus" and model.report_unit == "µrad"
    np.testing.assert_array_equal(model.predict(model.base_initial, (), (), rows),
                                  rotary.solve_inverse_kinematics(rows.poses).readings)
    poses, zero = np.asarray(rows.poses), np.asarray(rotary.crank_zero)
    alpha = eisele_crank_angles(rotary, poses)
    k = np.array([3e-4, -2e-4, 1e-4, 5e-4, -4e-4, 2e-4])
    thermal = np.array([12e-6, 23e-6, 1e-6, 12e-6, 17e-6, 5e-6])
    hot = np.asarray(rows.temperature)[:, None] - 20.0  # the effects' reference, 20 °C
    expected = {
        "gear_ratio": (alpha - zero) / (1 + k),
        "crank_offset": alpha - zero + k,
        "backlash": alpha - zero + 0.5 * k * np.asarray(rows.directions),
        "drift": alpha - zero + k * np.asarray(rows.time)[:, None],
    }
    for name, ref in expected.items():
        theta = thermal if name == "thermal_expansion" else k
        got = model.predict(model.base_initial, (dc.get_effect("6-rus", name),), (jnp.asarray(theta),), rows)
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-13, err_msg=name)
    longer = np.stack([eisele_crank_angles(RUSMechanism(rotary.base, rotary.platform, rotary.v0, rotary.crank_lengths,
                                                        rotary.rod_lengths * (1 + thermal * hot[j]), rotary.azimuth),
                                           poses[j:j + 1])[0] for j in range(len(poses))])
    got = model.predict(model.base_initial, (dc.get_effect("6-rus", "thermal_expansion"),), (jnp.asarray(thermal),),
                        rows)
    np.testing.assert_allclose(got, longer - zero, rtol=0, atol=1e-13)


@pytest.fixture(scope="module")
def simulated(rotary):
    return {eff: dc.simulate_hidden_effect(SEED, eff, 5.0, n_random=30, plan=False, geometry=rotary)
            for eff in ("gear_ratio", None)}


@pytest.fixture(scope="module")
def hidden(simulated):
    return simulated["gear_ratio"]


@pytest.fixture(scope="module")
def report(rotary, hidden):
    return dc.diagnose(hidden.data, dc.model_for(rotary), seed=SEED, effects=CANDIDATES)


@pytest.mark.slow  # a diagnosis or the whole command line: 20-35 s
def test_gear_ratio_is_named_and_the_absorbed_encoder_offset_is_not(report):
    d = report.to_dict()
    assert d["detected"] and d["named_effect"] == "gear_ratio" and d["gap_after"] < 0.6 * d["gap_before"]
    # the 54-parameter set calibrates the crank zeros: an encoder offset is absorbed, never named
    assert "crank_offset" in d["absorbed"]


@pytest.mark.slow  # a diagnosis or the whole command line: 20-35 s
def test_nothing_hidden_nothing_named(rotary, simulated):
    # (the detection test alone false-alarms at α = 5 %; naming also needs a candidate that explains
    # the gap, as the 6-PSS and 6-UPS tests of the same seed assert)
    d = dc.diagnose(simulated[None].data, dc.model_for(rotary), seed=SEED, effects=CANDIDATES).to_dict()
    assert d["named_effect"] is None and not d["explained"]


@pytest.mark.slow  # a diagnosis or the whole command line: 20-35 s
def test_cli_diagnoses_a_rotary_geometry_file_and_keeps_its_units(rotary, tmp_path, hidden, report):
    geo, csv, out, model_json = (tmp_path / n for n in ("rus.json", "d.csv", "r.json", "m.json"))
    sj.save_mechanism(rotary, geo)
    dc.write_hidden_csv(csv, hidden)
    assert main(["diagnose", str(csv), "--geometry", str(geo), "--json", str(out), "--seed", str(SEED),
                 "--effects", ",".join(CANDIDATES), "--out-model", str(model_json),
                 "--sigma-reading-urad", "0"]) == 0
    res = json.loads(out.read_text())
    assert res["named_effect"] == "gear_ratio" and res["settings"]["family"] == "6-RUS"
    fm = dc.load_fitted_model(model_json)
    saved = json.loads(model_json.read_text())
    assert "sigma_reading_urad" in saved and "sigma_stroke_um" not in saved and fm.model.name == "6-rus"
    data = sj.read_csv(csv, reading_unit="rad")  # crank angles in degrees in the file, exactly back
    np.testing.assert_array_equal(data.readings, hidden.data.readings)
    np.testing.assert_allclose(fm.predict(data), report.fitted.predict(data), rtol=0, atol=1e-12)
    assert main(["diagnose", str(csv), "--geometry", str(geo), "--sigma-stroke-um", "1"]) == 2
