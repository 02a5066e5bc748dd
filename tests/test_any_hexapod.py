"""The pipeline for any mechanism family: travel-scaled plans, tracker, perturbed truths, and the
command line end to end for a strut hexapod given as a geometry file."""

import json

import jax
import numpy as np
import pytest

import stewart_jax as sj
from stewart_jax._cli import main
from stewart_jax.calibration import perturbed, reachable_travel, tracker_for
from stewart_jax.mechanism import preset, presets


def test_paper_travel_and_plans_are_unchanged():
    g = sj.nominal_geometry()
    half = reachable_travel(g)
    np.testing.assert_array_equal(half, [1.0, 1.0, 1.0] + [np.deg2rad(1.0)] * 3)
    key = jax.random.key(4)
    np.testing.assert_array_equal(sj.plan_poses("plan120", key, half), sj.plan_poses("plan120", key))
    np.testing.assert_array_equal(sj.plan_poses("paper8", key, half), sj.plan_poses("paper8", key))
    # the documented layout for the paper's mechanism: r = 100 mm, 90 mm above A's origin, at 90°, 210°, 330°
    ang = np.deg2rad([90.0, 210.0, 330.0])
    balls = np.stack([100.0 * np.cos(ang), 100.0 * np.sin(ang), np.full(3, 90.0)], -1)
    np.testing.assert_array_equal(tracker_for(g).balls, balls)


@pytest.mark.parametrize("name", presets())
def test_reachable_travel_is_reachable_and_inside_the_published_one(name):
    m = preset(name)
    half = reachable_travel(m)
    published = m.travel_half_widths
    if published is None:  # truly optional: the paper's ±1 mm / ±1° box stands in
        published = np.array([1.0] * 3 + [np.deg2rad(1.0)] * 3)
    assert np.all(half <= published + 1e-15) and np.all(half > 0)
    plan = sj.plan_poses("plan120", jax.random.key(0), half)
    assert bool(np.all(np.asarray(m.solve_inverse_kinematics(plan).reachable)))
    poses = sj.calibration.random_poses(jax.random.key(0), 256, half=half)
    assert bool(np.all(np.asarray(m.solve_inverse_kinematics(poses).reachable)))
    # the bisection stops at the edge: 1 % more travel leaves some corner unreachable, unless the
    # whole published travel was reachable
    if np.any(half < published):
        corners = np.array(np.meshgrid(*[[-1.0, 1.0]] * 6)).reshape(6, -1).T * half * 1.01
        assert not bool(np.all(np.asarray(m.solve_inverse_kinematics(corners).reachable)))


def test_perturbed_truth_statistics():
    m = preset("rubin_m2")
    assert np.array_equal(perturbed(m, jax.random.key(0), 0.0).params, m.params)
    d = np.asarray(perturbed(m, jax.random.key(1), 0.5).params - m.params)
    # 42 draws of N(0, 0.25): the sample σ lies within 0.3–0.7 with probability > 1 − 1e-6
    assert 0.3 < d.std() < 0.7
    with pytest.raises(ValueError, match="sigma_mm"):
        perturbed(m, jax.random.key(0), -1.0)


@pytest.mark.slow  # simulate, calibrate, report and export through the command line: 20 s
def test_strut_hexapod_file_through_the_command_line(tmp_path, capsys):
    geo, csv, true_json = tmp_path / "m2.json", tmp_path / "m2.csv", tmp_path / "true.json"
    cal_json, out_geo, hexkins = tmp_path / "cal.json", tmp_path / "cal_geo.json", tmp_path / "m2.hal"
    assert main(["export", "rubin_m2", "--out", str(geo)]) == 0
    assert main(["simulate", "--geometry", str(geo), "--plan", "plan120", "--tracker", "--seed", "3",
                 "--out", str(csv), "--out-true", str(true_json)]) == 0
    assert main(["calibrate", str(csv), "--geometry", str(geo), "--method", "lm-batched", "--sigma-um", "3",
                 "--json", str(cal_json), "--out-geometry", str(out_geo)]) == 0
    res = json.loads(cal_json.read_text())
    assert res["status"] == "success" and len(res["params"]) == 42
    nominal, true, calibrated = (sj.load_mechanism(p) for p in (geo, true_json, out_geo))
    assert calibrated.family == "6-UPS"
    np.testing.assert_array_equal(calibrated.params, res["params"])
    # the calibrated model commands the true mechanism far better than the nominal one, at
    # poses it was not calibrated on
    val = sj.calibration.validation_poses(jax.random.key(9), 42, half=reachable_travel(nominal))
    before = np.abs(np.asarray(sj.control_error(nominal, true, val).errors)).max()
    after = np.abs(np.asarray(sj.control_error(calibrated, true, val).errors)).max()
    assert after < 0.05 * before, (before, after)
    assert main(["export", str(out_geo), "--format", "genhexkins", "--out", str(hexkins)]) == 0
    assert hexkins.read_text().count("setp genhexkins.") == 36
    capsys.readouterr()
    # diagnose on a strut hexapod file: tests/test_discrepancy_ups.py
    assert main(["export", "nominal", "--format", "genhexkins"]) == 2
    assert "genhexkins models struts" in capsys.readouterr().err
