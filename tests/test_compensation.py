"""Compensation tables: the controller's rule against a NumPy re-implementation written here from
the published rule, golden numbers of the published v7 and v3 tables, YAML round trips, the
ranged temperature polynomial on both sides of its range, the merge order, the struts through an
independent inverse kinematics (the controller's own, ``Rx(u)·Ry(v)·Rz(w)`` about the pivot),
and the refusals."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from numpy.polynomial.polynomial import polyval, polyval2d

import stewart_jax as sj
from stewart_jax._cli import main
from stewart_jax.compensation import load_table, offsets_to_poses, save_table, strut_changes

V7 = Path(__file__).parent / "data" / "compensation_v7.yaml"

# A v3-schema table of our own: separate power series, a temperature term on z.
V3_TEXT = """
camera_config:
  elevation_coeffs: [[1.5, -0.02], [640.0, 0.5, -0.2], [-605.0, 15.9], [0.0177, 0.0, -5.0e-6], [0.0], [0.0]]
  rotation_coeffs: [[0.0, 0.3], [0.0], [2.0, 0.0, 0.001], [0.0], [0.0, 1.0e-4], [0.0]]
  azimuth_coeffs: [[0.0], [0.0, 0.01], [0.0], [0.0], [0.0], [0.0]]
  temperature_coeffs: [[0.0], [0.0], [0.0, -66.0, 0.5], [0.0], [0.0], [0.0]]
  min_temperature: -20
  max_temperature: 20
"""

# An override of our own: a temperature model on every axis, a new filter set.
OVERRIDE_TEXT = """
camera_config:
  temperature_coeffs:
    [[1.0, 2.0, 0.1], [0.0, -3.0], [5.0, -66.0, 0.5, 0.01], [0.0, 1.0e-4], [0.0, -2.0e-4, 1.0e-6], [0.0]]
  min_temperature: -5
  max_temperature: 15
  filter_offsets:
    r_57: {z_offset: 0.0}
    g_6: {z_offset: 576.8471}
    i_39: {z_offset: -378.2631}
"""


# ---- the rule, written out in NumPy --------------------------------------------------------------


def merged(*docs):
    out = {}
    for d in docs:
        for k, v in d.items():
            out[k] = merged(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def ranged(c, lo, hi, t):
    c = np.asarray(c, float)
    lin = c[1] if len(c) > 1 else 0.0
    if t < lo:
        return polyval(lo, c) + lin * (t - lo)
    if t > hi:
        return polyval(hi, c) + lin * (t - hi)
    return polyval(t, c)


def rule(cfg, e, r, a=0.0, t=0.0, flt=None):
    """The controller's offsets (µm, deg) at one attitude of a configuration mapping."""
    assert 0 <= e <= 90
    r = (r + 180.0) % 360.0 - 180.0
    a = a % 360.0
    out = []
    for i in range(6):
        if "elevation_rotation_coeffs" in cfg:
            er = polyval2d(e, r, np.asarray(cfg["elevation_rotation_coeffs"][i], float))
        else:
            er = polyval(e, cfg["elevation_coeffs"][i]) + polyval(r, cfg["rotation_coeffs"][i])
        out.append(er + polyval(a, cfg["azimuth_coeffs"][i])
                   + ranged(cfg["temperature_coeffs"][i], cfg["min_temperature"], cfg["max_temperature"], t))
    if flt is not None:
        out[2] += cfg["filter_offsets"][flt]["z_offset"]
    return np.array(out)


def rubin_ik(offset, moving, fixed, pivot):
    """The controller's strut length changes (µm) of one position (µm, deg): the moving ends turn
    about the pivot by Rx(u)·Ry(v)·Rz(w), then translate."""
    x, y, z = np.asarray(offset[:3]) * 1e-3
    u, v, w = np.deg2rad(offset[3:])
    rx = np.array([[1, 0, 0], [0, np.cos(u), -np.sin(u)], [0, np.sin(u), np.cos(u)]])
    ry = np.array([[np.cos(v), 0, np.sin(v)], [0, 1, 0], [-np.sin(v), 0, np.cos(v)]])
    rz = np.array([[np.cos(w), -np.sin(w), 0], [np.sin(w), np.cos(w), 0], [0, 0, 1]])
    ends = (rx @ ry @ rz @ (moving - pivot).T).T + pivot + np.array([x, y, z])
    return (np.linalg.norm(ends - fixed, axis=1) - np.linalg.norm(moving - fixed, axis=1)) * 1e3


# The camera hexapod's strut ends (µm → mm) as the controller's constants publish them.
CAM_MOVING = np.array([[227.6, 653.8, -525.0], [-227.6, 653.8, -525.0], [-680.0, -129.7, -525.0],
                       [-452.3, -524.0, -525.0], [452.3, -524.0, -525.0], [680.0, -129.7, -525.0]])
CAM_FIXED = np.array([[472.8, 512.2, -121.4], [-472.8, 512.2, -121.4], [-680.0, 153.3, -121.4],
                      [-207.2, -665.5, -121.4], [207.2, -665.5, -121.4], [680.0, 153.3, -121.4]])
CAM_PIVOT = np.array([0.0, 0.0, -2758.4])


@pytest.fixture(scope="module")
def camera():
    return sj.mechanism.preset("rubin_camera")


def write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return str(p)


# ---- golden values and the rule ------------------------------------------------------------------


def test_v7_camera_golden_at_45_deg(camera):
    table = load_table(V7, "camera")
    off = np.asarray(table.offsets(45.0, 0.0))
    cfg = yaml.safe_load(V7.read_text())["camera_config"]
    np.testing.assert_allclose(off, rule(cfg, 45.0, 0.0), rtol=0, atol=1e-9)
    # the published strut changes of the compensated pose at elevation 45°, rotation 0 (µm, to 0.1)
    dq = strut_changes(camera, off)[0]
    np.testing.assert_allclose(dq, [2057.5, 743.2, 82.8, 2354.7, 1445.4, 487.4], atol=0.051)


def test_plus_one_mm_in_z_gives_the_published_strut_changes(camera):
    dq = strut_changes(camera, [0.0, 0.0, 1000.0, 0.0, 0.0, 0.0])[0]
    np.testing.assert_allclose(dq, [-818.30, -818.30, -818.44, -818.43, -818.43, -818.44], atol=0.005)


def test_v3_golden_and_rule(tmp_path):
    path = write(tmp_path, "v3.yaml", V3_TEXT)
    table = load_table(path)
    cfg = yaml.safe_load(V3_TEXT)["camera_config"]
    # z at elevation 0, rotation 0, -30 °C: -605 + 2 + the ranged polynomial's edge -20 °C value
    # (1320 + 200) plus -66 × -10 = 660
    assert float(table.offsets(0.0, 0.0, 0.0, -30.0)[2]) == pytest.approx(-605.0 + 2.0 + 1320.0 + 200.0 + 660.0)
    rng = np.random.default_rng(3)
    for _ in range(20):
        e, r, a, t = rng.uniform(0, 90), rng.uniform(-400, 400), rng.uniform(-720, 720), rng.uniform(-40, 40)
        np.testing.assert_allclose(np.asarray(table.offsets(e, r, a, t)), rule(cfg, e, r, a, t), rtol=1e-13, atol=1e-9)


def test_random_attitudes_with_overrides_and_filters_match_the_rule(tmp_path):
    over = write(tmp_path, "over.yaml", OVERRIDE_TEXT)
    table = load_table([V7, over], "camera")
    cfg = merged(yaml.safe_load(V7.read_text()), yaml.safe_load(OVERRIDE_TEXT))["camera_config"]
    assert set(table.filter_names) == {"r_57", "g_6", "i_39", "u_24", "y_10", "z_20", "NONE", "ph_5"}
    rng = np.random.default_rng(0)
    n = 200
    e, r, a = rng.uniform(0, 90, n), rng.uniform(-270, 270, n), rng.uniform(-360, 720, n)
    t = rng.uniform(-30, 40, n)  # well outside [-5, 15] on both sides
    names = list(rng.choice(["g_6", "i_39", "u_24", None], n))
    got = np.asarray(table.offsets(e, r, a, t, names))
    want = np.array([rule(cfg, *x, f) for *x, f in zip(e, r, a, t, names, strict=True)])
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-6)
    assert (t < -5).sum() > 10 and (t > 15).sum() > 10


def test_ranged_polynomial_on_both_sides_of_its_range(tmp_path):
    text = V3_TEXT.replace("[0.0, -66.0, 0.5]", "[1.0, 2.0, 3.0]")
    text = text.replace("min_temperature: -20", "min_temperature: -1")
    text = text.replace("max_temperature: 20", "max_temperature: 2")
    table = load_table(write(tmp_path, "r.yaml", text))
    base = float(table.offsets(0.0, 0.0, 0.0, 0.0)[2]) - 1.0  # the table's z without its temperature part
    z = lambda t: float(table.offsets(0.0, 0.0, 0.0, t)[2]) - base  # noqa: E731
    assert z(1.0) == pytest.approx(1 + 2 + 3)  # inside: the polynomial
    assert z(3.0) == pytest.approx((1 + 4 + 12) + 2 * 1.0)  # above: p(2) + c1·(3 − 2)
    assert z(-2.0) == pytest.approx((1 - 2 + 3) + 2 * -1.0)  # below: p(−1) + c1·(−2 + 1)


def test_merge_order_later_wins_and_lists_are_replaced(tmp_path):
    a = write(tmp_path, "a.yaml", "camera_config:\n  filter_offsets:\n    g_6: {z_offset: 1.0}\n")
    b = write(tmp_path, "b.yaml",
              "camera_config:\n  filter_offsets:\n    g_6: {z_offset: 2.0}\n    x_1: {z_offset: 3.0}\n")
    z = lambda files: float(load_table(files).offsets(10.0, 0.0, filter="g_6")[2])  # noqa: E731
    plain = float(load_table(V7).offsets(10.0, 0.0)[2])
    assert z([V7, a, b]) - plain == pytest.approx(2.0)
    assert z([V7, b, a]) - plain == pytest.approx(1.0)
    assert "x_1" in load_table([V7, b, a]).filter_names  # mappings merge key by key
    short = write(tmp_path, "s.yaml", "camera_config:\n  elevation_rotation_coeffs: [[[1.0]], [[2.0]], [[3.0]], "
                                      "[[0.0]], [[0.0]], [[0.0]]]\n")
    np.testing.assert_allclose(load_table([V7, short]).offsets(50.0, 30.0), [1.0, 2.0, 3.0, 0.0, 0.0, 0.0])


def test_yaml_round_trip_is_bit_for_bit(tmp_path):
    over = write(tmp_path, "over.yaml", OVERRIDE_TEXT)
    for hexapod in ("camera", "m2"):
        table = load_table([V7, over], hexapod)
        out = tmp_path / f"{hexapod}.yaml"
        save_table(table, out, ["round trip"])
        back = load_table(out, hexapod)
        e, r = np.linspace(0, 90, 7), np.linspace(-180, 180, 7)
        assert np.array_equal(np.asarray(back.offsets(e, r, 5.0, 30.0)), np.asarray(table.offsets(e, r, 5.0, 30.0)))
        assert back.filter_names == table.filter_names


def test_strut_changes_agree_with_the_controllers_inverse_kinematics(camera):
    rng = np.random.default_rng(1)
    off = np.concatenate([rng.uniform(-5000, 5000, (50, 3)), rng.uniform(-0.3, 0.3, (50, 2)),
                          rng.uniform(-0.09, 0.09, (50, 1))], axis=1)
    got = strut_changes(camera, off)[0]
    want = np.array([rubin_ik(o, CAM_MOVING, CAM_FIXED, CAM_PIVOT) for o in off])
    np.testing.assert_allclose(got, want, rtol=0, atol=0.05)
    # the library's own angle order would be off by µm at these tilts: the conversion matters
    naive = np.asarray(camera.solve_inverse_kinematics(
        np.concatenate([off[:, :3] * 1e-3, np.deg2rad(off[:, 3:])], 1)).readings)
    assert np.abs(naive * 1e3 - want).max() > 1.0
    back = sj.compensation._apply.poses_to_offsets(offsets_to_poses(off))
    np.testing.assert_allclose(back, off, rtol=0, atol=1e-9)


# ---- refusals --------------------------------------------------------------------------------------


@pytest.mark.parametrize("elevation", [95.0, -1.0])
def test_elevation_outside_0_90_is_refused(elevation, capsys):
    with pytest.raises(ValueError, match="elevation must be in"):
        load_table(V7).offsets(elevation, 0.0)
    assert main(["lut", "apply", str(V7), "--elevation-deg", str(elevation), "--rotation-deg", "0"]) == 2
    assert "elevation" in capsys.readouterr().err


def test_unknown_filter_is_refused():
    with pytest.raises(ValueError, match="unknown filter 'q_99'.*g_6"):
        load_table(V7).offsets(10.0, 0.0, filter="q_99")


@pytest.mark.parametrize(("patch", "match"), [
    ("  azimuth_coeffs: [[0.0], [0.0], [0.0], [0.0], [0.0]]\n", "azimuth_coeffs must list 6 axes"),
    ("  azimuth_coeffs: [[0.0], [0.0], [1e-5], [0.0], [0.0], [0.0]]\n", "must be a number.*1.0e-5"),
    ("  azimuth_coeffs: [[0.0], [0.0], [abc], [0.0], [0.0], [0.0]]\n", r"azimuth_coeffs\[z\]\[0\] must be a number"),
    ("  elevation_rotation_coeffs: [[[1.0, 2.0], [3.0]], [[0.0]], [[0.0]], [[0.0]], [[0.0]], [[0.0]]]\n",
     "rows of .* pad the short rows"),
    ("  elevation_coeffs: [[0.0], [0.0], [0.0], [0.0], [0.0], [0.0]]\n", "mixes the v7 schema"),
    ("  min_temperature: 30\n", "min_temperature 30.0 must be below"),
    ("  filter_offsets: {q_1: {z: 1.0}}\n", "q_1 must be {z_offset"),
])
def test_bad_tables_are_refused_naming_the_key(tmp_path, patch, match):
    over = write(tmp_path, "bad.yaml", "camera_config:\n" + patch)
    with pytest.raises(ValueError, match=match):
        load_table([V7, over])


# ---- the command line --------------------------------------------------------------------------------


def test_lut_apply_cli_rows_match_the_library(tmp_path, camera):
    over = write(tmp_path, "over.yaml", OVERRIDE_TEXT)
    att = write(tmp_path, "att.csv", "elevation_deg,rotation_deg,temperature_degC,filter\n"
                                     "10,20,-30,g_6\n45,0,0,\n80,-100,25,i_39\n")
    out, js = tmp_path / "off.csv", tmp_path / "off.json"
    assert main(["lut", "apply", str(V7), over, "--attitudes", att, "--geometry", "rubin_camera",
                 "--out", str(out), "--json", str(js)]) == 0
    lines = out.read_text().splitlines()
    header = lines[0].split(",")
    assert header == ["x_um", "y_um", "z_um", "u_deg", "v_deg", "w_deg"] + [f"strut{i}_um" for i in range(1, 7)]
    rows = np.array([[float(x) for x in ln.split(",")] for ln in lines[1:]])
    cfg = merged(yaml.safe_load(V7.read_text()), yaml.safe_load(OVERRIDE_TEXT))["camera_config"]
    want = np.array([rule(cfg, 10, 20, 0, -30, "g_6"), rule(cfg, 45, 0, 0, 0), rule(cfg, 80, -100, 0, 25, "i_39")])
    np.testing.assert_allclose(rows[:, :6], want, rtol=0, atol=1e-6)
    ik = np.array([rubin_ik(w, CAM_MOVING, CAM_FIXED, CAM_PIVOT) for w in want])
    np.testing.assert_allclose(rows[:, 6:], ik, rtol=0, atol=0.05)
    doc = json.loads(js.read_text())
    assert doc["rows"][1]["z_um"] == pytest.approx(want[1, 2], abs=1e-9) and doc["rows"][0]["filter"] == "g_6"


def test_no_output_overwrites_an_input(tmp_path, capsys):
    table = tmp_path / "t.yaml"
    table.write_text(V7.read_text())
    assert main(["lut", "apply", str(table), "--elevation-deg", "10", "--rotation-deg", "0", "--out", str(table)]) == 2
    assert "would destroy the input" in capsys.readouterr().err
    assert table.read_text() == V7.read_text()
    assert main(["simulate", "--campaign", "--truth", str(table), "--out", str(table)]) == 2
    assert table.read_text() == V7.read_text()
