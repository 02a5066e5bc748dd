"""Bad and edge inputs, round 4: one probe per class per surface, each with the answer it must
give (a clear error, a warning naming the likely slip, or the right result), never a silent
wrong answer or lost work. The optimiser's valid edges are in ``test_optimiser_edges.py``, the
controller export's edits in ``test_linuxcnc_edits.py``, the study's changed options and resume
message in ``test_study.py``."""

import json
import warnings

import numpy as np
import pytest

import stewart_jax.study as study
from stewart_jax._cli import main as cli_main
from stewart_jax.mechanism import load_mechanism, preset
from stewart_jax.mechanism._registry import mechanism_json


def _load(tmp_path, d):
    path = tmp_path / "g.json"
    path.write_text(json.dumps(d))
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        load_mechanism(str(path))
    return " | ".join(str(w.message) for w in seen)


def _scaled(d, keys, factor):
    return {**d, **{k: (np.asarray(d[k]) * factor).tolist() for k in keys}}


# ---- unit slips, both directions, every family ---------------------------------------------------

UPS = json.loads(mechanism_json(preset("rubin_m2")))
RUS = json.loads(mechanism_json(preset("rotary_stewart")))


@pytest.mark.parametrize("label, d, says", [
    ("6-UPS file in metres labelled mm", _scaled(UPS, ("base", "platform", "v0", "lengths0"), 1e-3), "metres"),
    ("6-UPS joint_angle_limits in radians", {**UPS, "joint_angle_limits": 0.3}, "radians typed"),
    ("6-RUS file in metres labelled mm", _scaled(RUS, ("base", "platform", "v0", "crank_lengths", "rod_lengths"),
                                                 1e-3), "metres"),
    ("6-RUS azimuths in degrees in a radian field", {**RUS, "crank_azimuths_rad":
                                                    np.degrees(RUS["crank_azimuths_rad"]).tolist()}, "degrees"),
    ("6-RUS crank zeros in degrees in a radian field", {**RUS, "crank_zero_rad":
                                                       np.degrees(RUS["crank_zero_rad"]).tolist()}, "degrees"),
])
def test_a_unit_slip_in_a_geometry_file_is_named(tmp_path, label, d, says):
    assert says in _load(tmp_path, d), label


def test_6rus_crank_limits_in_radians_are_refused(tmp_path):
    with pytest.raises(ValueError, match="not reachable"):
        _load(tmp_path, {**RUS, "crank_limits_deg": [-1.5, 1.5]})


@pytest.mark.parametrize("name", ["rubin_m2", "rotary_stewart", "rubin_camera"])
def test_a_correct_file_gets_no_unit_warning(tmp_path, name):
    # the other direction: the presets themselves (mm, rad where labelled) raise no warning
    assert _load(tmp_path, json.loads(mechanism_json(preset(name)))) == ""


# ---- nothing a user made is overwritten without being asked --------------------------------------

def test_an_output_over_an_existing_file_keeps_a_backup_and_says_so(tmp_path, capsys):
    out = tmp_path / "geometry.json"
    out.write_text("my notes\n")
    assert cli_main(["export", "rubin_camera", "--out", str(out)]) == 0
    assert (tmp_path / "geometry.json.bak").read_text() == "my notes\n"
    assert "kept it as" in capsys.readouterr().err
    assert json.loads(out.read_text())["mechanism"] == "6-UPS"
    # a second replacement never overwrites the first backup
    assert cli_main(["export", "rubin_camera", "--out", str(out)]) == 0
    assert (tmp_path / "geometry.json.bak").read_text() == "my notes\n"
    assert (tmp_path / "geometry.json.bak1").exists()


@pytest.mark.parametrize("argv", [["export", "rubin_camera", "--out"],
                                  ["export", "rubin_m2", "--format", "linuxcnc", "--stroke-limits-mm=-9,9", "--out"]])
def test_a_missing_parent_folder_is_refused_by_every_export(tmp_path, capsys, argv):
    assert cli_main([*argv, str(tmp_path / "missing" / "out")]) == 2
    assert "does not exist" in capsys.readouterr().err and not (tmp_path / "missing").exists()


# ---- interruptions -------------------------------------------------------------------------------

@pytest.mark.parametrize("checkpoint", [False, True])
def test_ctrl_c_during_a_study_says_what_was_kept_and_how_to_keep_it(tmp_path, capsys, monkeypatch, checkpoint):
    import stewart_jax.study._study as impl

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(impl, "run_study", interrupted)
    extra = ["--checkpoint", str(tmp_path / "ck.json")] if checkpoint else []
    assert cli_main(["study", "--trials", "2", *extra]) == 130
    err = capsys.readouterr().err
    assert ("rerun the same command to resume" in err) if checkpoint else ("--checkpoint PATH --chunk N" in err)


def test_trial_indices_past_2_to_the_32_are_refused():
    # trial i and i + 2^32 would share a key (32-bit fold-in): refused, never a silent duplicate
    with pytest.raises(ValueError, match="2\\^32"):
        study.trial_keys(0, 2, first=2**32 - 1)
    study.trial_keys(0, 1, first=2**32 - 1)  # the last distinct index is fine


def test_a_geometry_file_in_metres_never_calibrates_ok(tmp_path, capsys):
    # rubin_m2's data calibrated against its own geometry file scaled 1e-3 (metres labelled mm):
    # refused, or a fit whose data status is not "ok", with the file's slip named
    data, geometry, out = tmp_path / "d.csv", tmp_path / "m2_in_m.json", tmp_path / "r.json"
    assert cli_main(["simulate", "--geometry", "rubin_m2", "--plan", "paper8", "--out", str(data)]) == 0
    geometry.write_text(json.dumps(_scaled(UPS, ("base", "platform", "v0", "lengths0"), 1e-3)))
    capsys.readouterr()
    rc = cli_main(["calibrate", str(data), "--geometry", str(geometry), "--json", str(out)])
    err = capsys.readouterr().err
    assert "metres" in err
    if rc == 0:
        result = json.loads(out.read_text())
        assert result["data_status"] != "ok", result["data_status"]


# ---- inputs checked against what they describe ---------------------------------------------------

@pytest.mark.parametrize("extra", [["--stroke-limits-mm=-9,9"], ["--name", "m2"], ["--replace-edited"]])
def test_an_option_the_chosen_format_would_ignore_is_refused(tmp_path, capsys, extra):
    assert cli_main(["export", "rubin_m2", "--format", "genhexkins", "--out", str(tmp_path / "g.hal"), *extra]) == 2
    assert "--format linuxcnc only" in capsys.readouterr().err and not (tmp_path / "g.hal").exists()


def test_controller_limits_that_contradict_the_geometry_are_refused():
    from stewart_jax.mechanism._linuxcnc import to_linuxcnc
    from stewart_jax.mechanism._ups import UPSMechanism

    m2 = preset("rubin_m2")
    with pytest.raises(ValueError, match="to zero or less"):  # a stroke longer than the strut
        to_linuxcnc(m2, stroke_limits_mm=(-600.0, 10.0))
    own = UPSMechanism(m2.base, m2.platform, m2.v0, m2.lengths0, stroke_limits=(-5.0, 5.0), travel=m2.travel)
    with pytest.raises(ValueError, match="contradict"):  # user limits beside the geometry's own
        to_linuxcnc(own, stroke_limits_mm=(-9.0, 9.0))
    to_linuxcnc(own, stroke_limits_mm=(-5.0, 5.0))  # the same limits twice are no contradiction


def test_a_report_never_says_the_gap_closed_when_it_grew():
    # the words against the report's own numbers: discovered terms "explaining" a record while
    # the held-out RMS grows 10⁸× (a record in metres) are reported as not an explanation
    import dataclasses
    import types

    from stewart_jax.discrepancy._report import DiagnosisReport

    fields = {f.name: None for f in dataclasses.fields(DiagnosisReport)}
    fake = DiagnosisReport(**{**fields, "fitted": types.SimpleNamespace(model=types.SimpleNamespace(report_unit="µm")),
                              "detected": True, "named_effect": None, "explained": True, "gap_before": 1.0,
                              "gap_after": 1e8, "noise_floor": 0.5, "detect_p_value": 1e-9,
                              "discovered": [{"description": "a sine", "gap_after": 1e8}], "partial": [],
                              "absorbed_by": {}, "notes": [], "indistinguishable_from": []})
    text = "\n".join(fake.summary())
    assert "not explained" in text and "close the gap" not in text
    # the term search's own figure is not repeated as if it stood: the refitted model's is named
    lines = [line for line in fake.summary() if line.startswith("discovered")]
    assert lines == ["discovered, not an explanation: a sine (held-out RMS 1e+08 µm in the term search; the "
                     "refitted model's is 1e+08 µm)"], lines
    shrunk = dataclasses.replace(fake, gap_after=0.6)
    assert "discovered terms close the gap" in "\n".join(shrunk.summary())
    assert "discovered: a sine" in "\n".join(shrunk.summary())
    # a candidate removing a sliver of the gap is not called a partial explanation ("removes 0 %")
    unexplained = dataclasses.replace(fake, explained=False, discovered=[], partial=[
        {"effect": "cable_inertia", "gap_share": 0.003, "heldout_rms": 0.999},
        {"effect": "cabin_mass", "gap_share": 0.4, "heldout_rms": 0.8}])
    text = "\n".join(unexplained.summary())
    assert "not an explanation: cable_inertia barely shrinks the held-out gap" in text
    assert "partial explanation: cabin_mass removes 40 % of the gap" in text and "removes 0 %" not in text
    # residuals far below the stated noise (a record in metres and radians read as mm and degrees:
    # "no discrepancy detected" at RMS 32 against a floor of 718) say what they contradict
    quiet = dataclasses.replace(fake, detected=False, explained=False, discovered=[], gap_before=32.2,
                                gap_after=32.2, noise_floor=718.0, noise_estimated=False, detect_p_value=1.0)
    text = "\n".join(quiet.summary())
    assert "no discrepancy detected" in text and "22.3× below the noise floor" in text and "metres for mm" in text
    for ok in (dataclasses.replace(quiet, gap_before=700.0), dataclasses.replace(quiet, noise_estimated=True)):
        assert "below the noise floor" not in "\n".join(ok.summary())


def _decay_record(path, scale_position, scale_rotation, sigma_mm=1.0, sigma_deg=0.01, seed=0):
    # a damped swing at 0.15 Hz from 20 mm and 0.02°, 10 Hz for 60 s, with the tracker's noise,
    # written in mm and degrees times the given scales (the unit slip under test)
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 60.0, 0.1)
    swing = np.exp(-0.005 * 2 * np.pi * 0.15 * t) * np.cos(2 * np.pi * 0.15 * t)
    pos = np.outer(swing, [20.0, 10.0, 5.0]) + sigma_mm * rng.standard_normal((t.size, 3))
    rot = np.outer(swing, [0.02, 0.01, 0.02]) + sigma_deg * rng.standard_normal((t.size, 3))
    table = np.column_stack([t, pos * scale_position, rot * scale_rotation])
    np.savetxt(path, table, delimiter=",", header="time,x,y,z,rx,ry,rz", comments="")
    return path


@pytest.mark.parametrize("label, scales, says", [
    ("positions in metres", (1e-3, 1.0), "a record in metres"),
    ("rotations in radians", (1.0, np.pi / 180), "a record in radians"),
    ("both in metres and radians", (1e-3, np.pi / 180), "a record in metres"),
    ("positions in µm", (1e3, 1.0), "a record in µm"),
    ("rotations in arcseconds", (1.0, 3600.0), "arcseconds"),
])
def test_a_cabin_record_in_the_wrong_unit_is_refused_before_any_fit(label, scales, says, tmp_path, capsys):
    # The sizes contradict the units by the record's own noise (a measured value cannot vary less
    # than its noise) or by what a free vibration reaches; refused before the modal model is built.
    path = _decay_record(tmp_path / "r.csv", *scales)
    assert cli_main(["diagnose", str(path), "--geometry", "fast"]) == 2
    err = capsys.readouterr().err
    assert says in err, (label, err)


def test_a_record_in_the_right_units_passes_the_size_check(tmp_path):
    from stewart_jax.discrepancy import read_cabin_record
    from stewart_jax.discrepancy._cabin_record import check_amplitude

    data = read_cabin_record(_decay_record(tmp_path / "r.csv", 1.0, 1.0))
    check_amplitude(data, 1.0, np.deg2rad(0.01) * 1e3)
    # a smaller stated σ (a better tracker) raises nothing either; a σ larger than every motion does
    check_amplitude(data, 0.1, np.deg2rad(0.001) * 1e3)
    with pytest.raises(ValueError, match="--sigma-um"):
        check_amplitude(data, 100.0, np.deg2rad(0.01) * 1e3)


def test_targets_with_a_pose_file_name_the_mismatch(tmp_path, capsys):
    pose, targets = tmp_path / "p.csv", tmp_path / "T.json"
    assert cli_main(["simulate", "--geometry", "rubin_camera", "--plan", "paper8", "--out", str(pose)]) == 0
    targets.write_text(json.dumps({"platform_targets": {"a": [0.0, 0.0, 0.0]}, "base_references": {}}))
    capsys.readouterr()
    assert cli_main(["calibrate", str(pose), "--geometry", "rubin_camera", "--targets", str(targets)]) == 2
    err = capsys.readouterr().err
    assert "--targets is for a laser tracker's points file" in err and "without --targets" in err


@pytest.mark.parametrize("argv", [["--temperature-degC", "293.15"], ["--temperature-degC", "-150"]])
def test_a_compensation_temperature_in_kelvin_is_refused(capsys, argv):
    # a ranged temperature polynomial extrapolates linearly: 293 "°C" would be a confident offset
    from pathlib import Path

    v7 = Path(__file__).parent / "data" / "compensation_v7.yaml"
    assert cli_main(["lut", "apply", str(v7), "--elevation-deg", "45", "--rotation-deg", "0", *argv]) == 2
    assert "not an air temperature" in capsys.readouterr().err
    assert cli_main(["lut", "apply", str(v7), "--elevation-deg", "45", "--rotation-deg", "0",
                     "--temperature-degC", "-40"]) == 0  # a cold night is no slip


def test_a_campaign_in_kelvin_is_refused():
    from stewart_jax.compensation._campaign import Campaign, check_campaign

    fields = Campaign._fields
    n = 3
    values = {"elevation_deg": np.array([10.0, 40.0, 80.0]), "rotation_deg": np.zeros(n),
              "azimuth_deg": np.zeros(n), "temperature_degC": np.array([283.0, 288.0, 293.0]),
              "offsets": np.zeros((n, 6))}
    kw = {f: values.get(f, True) for f in fields}
    with pytest.raises(ValueError, match="row 1 has temperature_degC 283"):
        check_campaign(Campaign(**kw))


def test_a_targets_file_in_metres_is_named_and_the_right_one_reads(tmp_path, capsys):
    # both directions of the points' scale check: a tracker file in metres (distances 1000×
    # shorter than the targets') and a targets file in metres (1000× longer)
    from stewart_jax.calibration._points_io import read_points_csv, read_targets

    pts, t_mm, t_m = tmp_path / "p.csv", tmp_path / "T.json", tmp_path / "T_m.json"
    assert cli_main(["simulate", "--points", "--targets", str(t_mm), "--default-targets", "--geometry",
                     "rubin_camera", "--plan", "paper8", "--out", str(pts)]) == 0
    raw = json.loads(t_mm.read_text())
    t_m.write_text(json.dumps({k: {n: (np.asarray(v) * 1e-3).tolist() for n, v in d.items()}
                               for k, d in raw.items()}))
    assert read_points_csv(pts, read_targets(t_mm)).n_poses == 8
    with pytest.raises(ValueError, match="targets file's coordinates are in metres"):
        read_points_csv(pts, read_targets(t_m))
