"""Geometry files checked like the CSVs, written files with ordinary permissions, and gross misfits
never called fine.

Each test names the class of bad input it stands for. Most bad input is refused at load, before
any compilation of the kinematics; export applies exactly the checks simulate does.
"""

import copy
import json
import os
import stat
import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import stewart_jax as sj
from stewart_jax._cli import main
from stewart_jax._files import write_text_atomic
from stewart_jax.calibration import assess_calibration
from stewart_jax.mechanism import load_mechanism, mechanism_from_dict, preset, presets

# ---- written files keep ordinary permissions ------------------------------------------------------


@pytest.mark.parametrize("umask", [0o022, 0o077, 0o002])
def test_a_new_file_gets_the_umask_mode(tmp_path, umask):
    """Class: a new output file (an export a controller reads as another user)."""
    old = os.umask(umask)
    try:
        write_text_atomic(tmp_path / "new.txt", "x\n")
        with open(tmp_path / "plain.txt", "w") as f:  # what open() gives: the reference
            f.write("x\n")
    finally:
        os.umask(old)
    mode = stat.S_IMODE(os.stat(tmp_path / "new.txt").st_mode)
    assert mode == 0o666 & ~umask == stat.S_IMODE(os.stat(tmp_path / "plain.txt").st_mode)
    assert sorted(os.listdir(tmp_path)) == ["new.txt", "plain.txt"]  # no temporary file left


@pytest.mark.parametrize("mode", [0o644, 0o640, 0o600, 0o664])
def test_an_overwritten_file_keeps_its_mode(tmp_path, mode):
    """Class: an existing output file overwritten (a HAL file chmod-ed for the controller)."""
    path = tmp_path / "old.txt"
    path.write_text("old\n")
    os.chmod(path, mode)
    write_text_atomic(path, "new\n")
    assert path.read_text() == "new\n" and stat.S_IMODE(os.stat(path).st_mode) == mode


def test_cli_outputs_are_readable_by_others(tmp_path):
    old = os.umask(0o022)
    try:
        assert main(["export", "rubin_m2", "--format", "genhexkins", "--out", str(tmp_path / "hexapod.hal")]) == 0
    finally:
        os.umask(old)
    assert stat.S_IMODE(os.stat(tmp_path / "hexapod.hal").st_mode) == 0o644


# ---- geometry files ---------------------------------------------------------------------------------

M2 = preset("rubin_m2").to_dict()
CAMERA = preset("rubin_camera").to_dict()
PSS = preset("nominal").to_dict()


def _edit(d, **changes):
    d = copy.deepcopy(d)
    for k, v in changes.items():
        if v is None:
            d.pop(k, None)
        else:
            d[k] = v
    return d


def _renamed(d, old, new):
    d = copy.deepcopy(d)
    d[new] = d.pop(old)
    return d


def _zero_length(d):
    d = copy.deepcopy(d)
    d["platform"][2] = [b - v for b, v in zip(d["base"][2], d["v0"], strict=True)]
    return _edit(d, lengths0=None)


def _duplicate_leg(d, key_a="base", key_b="platform", extra=("lengths0",)):
    d = copy.deepcopy(d)
    d[key_a][3], d[key_b][3] = d[key_a][1], d[key_b][1]
    for k in extra:
        if k in d:
            d[k][3] = d[k][1]
    return d


def _ring(radius, z, offset_deg):
    a = np.deg2rad(np.arange(6) * 60.0 + offset_deg)
    return np.stack([radius * np.cos(a), radius * np.sin(a), np.full(6, z)], axis=-1).tolist()


def _collinear_base(d):
    d = _edit(d, lengths0=None)
    d["base"] = [[100.0 * i, 0.0, 700.0] for i in range(6)]
    return d


BAD_GEOMETRIES = {
    # class: a misspelt key (silently dropping the limits it meant), with a suggestion
    "misspelt key": (_renamed(CAMERA, "stroke_limits", "strok_limits"), "did you mean 'stroke_limits'"),
    "misspelt 6-PSS key": (_renamed(PSS, "upper", "uper"), "did you mean 'upper'"),
    "unknown key": (_edit(M2, colour="red"), "unknown key(s) 'colour'"),
    # class: physically impossible values, named with the leg and the value
    "negative zero-reading length": (_edit(M2, lengths0=[-480.0] + M2["lengths0"][1:]), "strut(s) [1] have [-480.0]"),
    "zero zero-reading length": (_edit(M2, lengths0=M2["lengths0"][:4] + [0.0, M2["lengths0"][5]]), "strut(s) [5]"),
    "zero-length strut": (_zero_length(M2), "strut 3 has zero length"),
    "negative 6-PSS rod length": (_edit(PSS, rod_lengths=[200.0] * 5 + [-200.0]), "leg(s) [6] have [-200.0]"),
    "two identical legs": (_duplicate_leg(M2), "legs 2 and 4 are the same leg"),
    "two identical 6-PSS legs": (_duplicate_leg(PSS, "upper", "lower", ()), "legs 2 and 4 are the same leg"),
    # class: degenerate layouts, named by their cause
    "all struts horizontal": (_edit(M2, base=_ring(1500.0, 0.0, 0.0), platform=_ring(900.0, 0.0, 30.0),
                                    v0=[0.0, 0.0, 0.0], lengths0=None), "every strut is horizontal"),
    "base joints on one line": (_collinear_base(M2), "six base joints lie on one line"),
    "zero pose outside the limits": (_edit(CAMERA, lengths0=[x - 100.0 for x in CAMERA["lengths0"]]),
                                     "zero pose is not reachable: legs [1, 2, 3, 4, 5, 6]"),
    "6-PSS rods through one point": (_edit(PSS, upper=[[0.0, 0.0, 0.0]] * 6), "cannot hold the platform"),
}


@pytest.mark.parametrize("name", list(BAD_GEOMETRIES))
def test_bad_geometry_files_are_refused_at_load_naming_the_cause(name, tmp_path):
    d, says = BAD_GEOMETRIES[name]
    path = tmp_path / "g.json"
    path.write_text(json.dumps(d))
    with pytest.raises(ValueError) as e:
        load_mechanism(path)
    assert says in str(e.value) and "g.json" in str(e.value), str(e.value)


@pytest.mark.parametrize("name", ["zero-length strut", "two identical legs", "zero pose outside the limits",
                                  "misspelt key", "all struts horizontal"])
@pytest.mark.parametrize("command", ["export", "simulate"])
def test_export_refuses_what_simulate_refuses(name, command, tmp_path, capsys):
    """Class: a geometry simulate refuses must not reach a controller through export."""
    d, says = BAD_GEOMETRIES[name]
    path, out = tmp_path / "g.json", tmp_path / "out.hal"
    path.write_text(json.dumps(d))
    argv = (["export", str(path), "--format", "genhexkins", "--out", str(out)] if command == "export"
            else ["simulate", "--geometry", str(path), "--out", str(out)])
    assert main(argv) == 2
    assert says in capsys.readouterr().err and not out.exists()


def test_files_of_every_preset_load_without_a_warning():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for name in presets():
            assert mechanism_from_dict(preset(name).to_dict()).to_dict() == preset(name).to_dict()


def _metres(d):
    d = _edit(d, lengths0=None)
    for k in ("base", "platform"):
        d[k] = [[x / 1000 for x in p] for p in d[k]]
    d["v0"] = [x / 1000 for x in d["v0"]]
    return d


@pytest.mark.parametrize("d, says", [
    # class: a limit in radians where degrees are expected (cuts the travel ~20×)
    (_edit(CAMERA, joint_angle_limits=0.26), "radians typed where degrees are expected? 0.26 rad = 14.9°"),
    # class: stroke limits in metres where mm are expected
    (_edit(CAMERA, stroke_limits=[-0.0141, 0.0141]), "metres typed where mm are expected"),
    # class: stroke limits in µm where mm are expected (no limit at all in effect)
    (_edit(CAMERA, stroke_limits=[-14100.0, 14100.0]), "micrometres typed where mm are expected"),
    # class: a whole file in metres labelled mm
    (_metres(M2), "a file in metres needs every length × 1000"),
])
def test_plausible_unit_slips_are_warned(d, says):
    with pytest.warns(UserWarning, match="") as record:
        mechanism_from_dict(d)
    assert any(says in str(w.message) for w in record), [str(w.message) for w in record]


def test_the_travel_cut_is_measured_against_the_same_struts_without_limits():
    """The warning's factor is an independent bisection (``reachable_travel``) to within the
    check's 19% grid: the radians-for-degrees slip cuts the camera hexapod's travel ~20×."""
    from stewart_jax.calibration import reachable_travel

    with pytest.warns(UserWarning) as record:
        slipped = mechanism_from_dict(_edit(CAMERA, joint_angle_limits=0.26))
    stated = float(str(record[0].message).split("travel ")[1].split("×")[0])
    free = preset("rubin_camera")
    free = type(free)(free.base, free.platform, free.v0, free.lengths0, travel=free.travel)
    truth = reachable_travel(free)[0] / reachable_travel(slipped)[0]
    assert truth / 1.2 <= stated <= truth * 1.2 and truth > 4


# ---- a gross misfit is never "ok" -------------------------------------------------------------------


@pytest.fixture(scope="module")
def m2_data():
    """8 poses of the Rubin M2 hexapod measured with σ = 0.1 µm / 0.1″ (its true geometry)."""
    m = preset("rubin_m2")
    targets = sj.calibration.random_poses(jax.random.key(1), 8, half=tuple(sj.calibration.reachable_travel(m)))
    return m, sj.simulate_measurements(jax.random.key(2), m, m, targets).data


def test_correct_data_are_ok():
    # the 6-PSS on the 120-pose plan: every parameter direction is determined to better than its
    # prior scale (benchmarks/results/determined.md), so nothing is held and nothing is warned
    m = sj.nominal_geometry()
    sim = sj.simulate_measurements(jax.random.key(2), m, m, sj.plan_poses("plan120", jax.random.key(1)))
    a = assess_calibration(m, sim.data, 0.1, 0.1)
    assert a.status == "ok" and not a.warnings


def test_correct_data_that_leave_directions_undetermined_say_so(m2_data):
    # 8 poses of the M2 hexapod: right data, but 13 of 42 directions are determined no better than
    # their prior scale (1 mm, 1 mrad); that is never "ok"
    m, data = m2_data
    a = assess_calibration(m, data, 0.1, 0.1)
    assert a.status != "ok" and any("determine" in w and "of 42" in w for w in a.warnings), a.warnings


def test_radians_under_a_degree_header_are_a_gross_misfit_even_with_few_degrees_of_freedom(m2_data):
    """Class: angles in the wrong unit with 48 readings for 42 parameters: the χ² test has 6
    degrees of freedom and absorbs most of the misfit; the whitened residual does not."""
    m, data = m2_data
    wrong = sj.calibration.make_calibration_data(data.readings, data.poses * jnp.array([1.0] * 3 + [np.pi / 180] * 3))
    a = assess_calibration(m, wrong, 0.1, 0.1)
    assert a.status == "poor_fit"
    gross = [w for w in a.warnings if w.startswith("gross misfit")]
    assert gross and "units" in gross[0] and "geometry" in gross[0] and "parameter set" in gross[0]


def test_a_gross_misfit_outranks_rank_deficiency(m2_data):
    """Class: too few poses (rank-deficient) *and* the wrong geometry: the report must not hide
    the misfit behind "rank_deficient"."""
    m, data = m2_data
    few = sj.calibration.make_calibration_data(data.readings[:3], data.poses[:3])
    a = assess_calibration(preset("rubin_camera"), few, 0.1, 0.1)  # the camera hexapod's geometry for M2 data
    assert a.status == "poor_fit" and a.rank < a.n_params
    assert any(w.startswith("gross misfit") for w in a.warnings)
    from stewart_jax.calibration._report import calibration_report  # private: what `calibrate --report` writes

    report = calibration_report(source={"data": "m2.csv"}, nominal=m, calibrated=m, assessment=a, heldout=None,
                                result={"status": "success", "n_poses": 3, "cost": 1.0, "rms_residual_um": 1.0},
                                pose_errors={})
    assert "data status: `poor_fit`" in report and "gross misfit" in report


def test_a_failed_write_names_the_users_path_not_the_temporary_file(tmp_path):
    """Class: an output whose folder vanished between the check and the write."""
    target = tmp_path / "gone" / "out.json"
    with pytest.raises(OSError) as e:
        write_text_atomic(target, "{}\n")
    assert str(target) in str(e.value) and ".partial" not in str(e.value)
