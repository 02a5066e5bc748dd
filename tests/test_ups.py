"""The 6-UPS strut hexapod: kinematics against an independent NumPy model, limits, geometry
files, the LinuxCNC genhexkins export and calibration of the three presets.

Only the public API is used (``stewart_jax``, ``stewart_jax.mechanism``, ``stewart_jax.calibration``).
"""

import json
import re

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import stewart_jax as sj
from stewart_jax.calibration import LaserTracker, identifiability_report
from stewart_jax.mechanism import UPSMechanism, preset, to_genhexkins

UPS_PRESETS = ("rubin_camera", "rubin_m2", "fast_stewart")


# ---- an independent NumPy model ---------------------------------------------------------------


def rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def np_rotation(phi, theta, psi):
    return rz(psi) @ ry(theta) @ rx(phi)


def np_strut_lengths(base, platform, v0, pose):
    rot = np_rotation(*pose[3:])
    return np.linalg.norm(platform @ rot.T + pose[:3] + v0 - base, axis=1)


def np_readings(m, poses):
    base, platform, v0, l0 = (np.asarray(x) for x in (m.base, m.platform, m.v0, m.lengths0))
    return np.stack([np_strut_lengths(base, platform, v0, p) - l0 for p in poses])


def in_travel(m, seed, n, scale=1.0):
    """``n`` poses uniform in ``scale`` × the preset's travel box."""
    rng = np.random.default_rng(seed)
    return rng.uniform(-1, 1, (n, 6)) * m.travel_half_widths * scale


def reachable_in_travel(m, seed, n):
    """``n`` reachable poses in the travel (a published travel is per axis: some corners of the
    box exceed a stroke limit, e.g. the Rubin camera hexapod's)."""
    poses = in_travel(m, seed, 20 * n)
    ok = np.asarray(m.solve_inverse_kinematics(jnp.asarray(poses)).reachable)
    assert ok.sum() >= n
    return poses[ok][:n]


# ---- presets -----------------------------------------------------------------------------------


def test_presets_are_the_published_geometry():
    cam = preset("rubin_camera")
    assert cam.family == "6-UPS" and isinstance(cam, UPSMechanism)
    # moving end 1 (227600, 653800, -525000) µm about the pivot (0, 0, -2758400) µm
    np.testing.assert_array_equal(cam.platform[0], [227.6, 653.8, 2233.4])
    np.testing.assert_array_equal(cam.base[3], [-207.2, -665.5, -121.4])
    np.testing.assert_array_equal(cam.v0, [0.0, 0.0, -2758.4])
    assert cam.stroke_limits == ((-14.1, 14.1),) * 6
    np.testing.assert_allclose(cam.travel_half_widths, [11.4, 11.4, 13.1, *np.deg2rad([0.36, 0.36, 0.10])])
    m2 = preset("rubin_m2")
    np.testing.assert_array_equal(m2.platform[3], [0.79, 1460.49, 931.6])
    np.testing.assert_array_equal(m2.base[0], [0.0, 1701.8, 607.3])
    fast = preset("fast_stewart")
    np.testing.assert_array_equal(fast.v0, [0.0, 0.0, -1700.0])
    np.testing.assert_allclose(np.linalg.norm(np.asarray(fast.base)[:, :2], axis=1), 2000.0, rtol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(np.asarray(fast.platform)[:, :2], axis=1), 980.0, rtol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(fast.base[0] - fast.base[5]), 349.0, rtol=1e-14)  # |B1B6|
    np.testing.assert_allclose(np.linalg.norm(fast.platform[0] - fast.platform[1]), 256.0, rtol=1e-14)  # |P1P2|
    for name in UPS_PRESETS:  # every reading is 0 at the zero pose, exactly
        m = preset(name)
        np.testing.assert_array_equal(m.solve_inverse_kinematics(jnp.zeros(6)).readings, 0.0)
        assert m.n_params == 42 and m.param_names[0] == "platform1x" and m.param_names[-1] == "lengths0_6"


# ---- kinematics --------------------------------------------------------------------------------


@pytest.mark.parametrize("name", UPS_PRESETS)
def test_inverse_kinematics_matches_numpy(name):
    m = preset(name)
    poses = in_travel(m, 10, 64)
    ours = np.asarray(m.solve_inverse_kinematics(jnp.asarray(poses)).readings)
    np.testing.assert_allclose(ours, np_readings(m, poses), rtol=0, atol=1e-9)
    # a calibrated mechanism: lengths0 no longer the zero-pose lengths
    rng = np.random.default_rng(11)
    other = m.with_params(m.params + jnp.asarray(rng.normal(0, 0.5, 42)))
    ours = np.asarray(other.solve_inverse_kinematics(jnp.asarray(poses)).readings)
    np.testing.assert_allclose(ours, np_readings(other, poses), rtol=0, atol=1e-9)


def test_small_readings_keep_full_precision():
    # 1 nm moves of a 2.3 m strut: the reading keeps ~1e-15 relative precision (its second-order
    # expansion u·d + (|d|² − (u·d)²)/(2l) is exact to (d/l)³), not rounding of 2280 mm (4e-13 mm)
    m = preset("fast_stewart")
    e = np.asarray(m.platform + m.v0 - m.base)
    length = np.linalg.norm(e, axis=1)
    u = e / length[:, None]
    for k in range(3):
        d = np.zeros(6)
        d[k] = 1e-6
        q = np.asarray(m.solve_inverse_kinematics(jnp.asarray(d)).readings)
        expected = 1e-6 * u[:, k] + (1e-12 - (1e-6 * u[:, k]) ** 2) / (2 * length)
        np.testing.assert_allclose(q, expected, rtol=1e-13, atol=0)


@pytest.mark.parametrize("name", UPS_PRESETS)
def test_forward_kinematics_round_trip(name):
    m = preset(name)
    poses = reachable_in_travel(m, 12, 32)
    q = sj.inverse_kinematics(m, poses)
    fk = sj.forward_kinematics(m, q)
    assert bool(np.all(fk.converged))
    back = np.asarray(fk.poses)
    np.testing.assert_allclose(back[:, :3], poses[:, :3], rtol=0, atol=1e-9)
    # the moving joints (mm) — angles enter through metre-scale lever arms
    np.testing.assert_allclose(
        np.asarray(m.moving_joints(jnp.asarray(back))),
        np.asarray(m.moving_joints(jnp.asarray(poses))),
        rtol=0,
        atol=1e-9,
    )


@pytest.mark.parametrize("name", UPS_PRESETS)
def test_pose_jacobian_matches_central_differences(name):
    m = preset(name)
    poses = in_travel(m, 13, 4)
    _, _, jac = m.ik_and_jacobian(jnp.asarray(poses))
    steps = np.array([1e-4] * 3 + [1e-7] * 3)
    diff = lambda h, e: (np_readings(m, poses + h * e) - np_readings(m, poses - h * e)) / (2 * h)
    fd = np.stack([diff(h, e) for h, e in zip(steps, np.eye(6), strict=True)], axis=-1)
    # columns: mm/mm (≈1) and mm/rad (≈ lever arms up to 3e3); rounding of the ~1e3 mm readings
    # over 2h dominates the differences' error
    np.testing.assert_allclose(np.asarray(jac)[..., :3], fd[..., :3], rtol=0, atol=1e-8)
    np.testing.assert_allclose(np.asarray(jac)[..., 3:], fd[..., 3:], rtol=0, atol=1e-5)


@pytest.mark.parametrize("name", UPS_PRESETS)
def test_parameter_jacobian_matches_central_differences(name):
    m = preset(name)
    poses = in_travel(m, 14, 3)
    jac = np.asarray(m.parameter_jacobian(jnp.asarray(poses)))
    assert jac.shape == (18, 42)
    u, h = np.asarray(m.params), 1e-4
    readings = lambda v: np_readings(m.with_params(jnp.asarray(v)), poses).reshape(-1)
    fd = np.stack([(readings(u + h * e) - readings(u - h * e)) / (2 * h) for e in np.eye(42)], axis=1)
    np.testing.assert_allclose(jac, fd, rtol=0, atol=1e-8)
    np.testing.assert_array_equal(jac[:, 36:], -np.tile(np.eye(6), (3, 1)))  # ∂q/∂lengths0 = −1


# ---- limits ------------------------------------------------------------------------------------


def test_stroke_limit_is_reported_and_raised():
    cam = preset("rubin_camera")
    ok = np.zeros((6, 6))
    for k in range(6):  # each axis alone at its published travel is reachable
        ok[k, k] = cam.travel_half_widths[k]
    sol = cam.solve_inverse_kinematics(jnp.asarray(ok))
    assert bool(np.all(sol.reachable))
    q = np.asarray(sol.readings)
    np.testing.assert_allclose(np.asarray(sol.margin), np.minimum(q + 14.1, 14.1 - q), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(cam.solve_inverse_kinematics(jnp.zeros(6)).margin, 14.1)
    far = np.array([0.0, 0.0, 20.0, 0.0, 0.0, 0.0])  # dz = 20 mm: axial readings ≈ 16 mm > 14.1
    sol = cam.solve_inverse_kinematics(jnp.asarray(far))
    assert not bool(sol.reachable) and float(np.min(sol.margin)) < 0
    with pytest.raises(ValueError, match=r"unreachable pose.*20\.0"):
        sj.inverse_kinematics(cam, far)
    # asymmetric per-strut limits
    lims = [(-5.0, 1.0)] * 5 + [(-5.0, 50.0)]
    m = UPSMechanism(cam.base, cam.platform, cam.v0, stroke_limits=lims)
    q = np.asarray(m.solve_inverse_kinematics(jnp.asarray(far)).readings)
    margin = np.asarray(m.solve_inverse_kinematics(jnp.asarray(far)).margin)
    np.testing.assert_allclose(margin, np.minimum(q + 5.0, np.array([1.0] * 5 + [50.0]) - q), rtol=0, atol=1e-12)


def test_joint_angle_limit_is_reported_and_raised():
    fast = preset("fast_stewart")
    limit = np.deg2rad(1.0)
    m = UPSMechanism(fast.base, fast.platform, fast.v0, joint_angle_limit=limit)
    poses = in_travel(fast, 15, 200)  # about 40 % of them within 1°
    sol = m.solve_inverse_kinematics(jnp.asarray(poses))
    # independent angles: strut vs its zero-pose direction, in B (base end) and in A (platform end)
    base, plat, v0 = np.asarray(m.base), np.asarray(m.platform), np.asarray(m.v0)
    e = plat + v0 - base
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    worst, lengths = [], []
    for p in poses:
        rot = np_rotation(*p[3:])
        s = plat @ rot.T + p[:3] + v0 - base
        length = np.linalg.norm(s, axis=1)
        ang_b = np.arccos(np.clip(np.sum(s / length[:, None] * e, axis=1), -1, 1))
        ang_a = np.arccos(np.clip(np.sum((s @ rot) / length[:, None] * e, axis=1), -1, 1))
        worst.append(np.maximum(ang_a, ang_b))
        lengths.append(length)
    worst, lengths = np.array(worst), np.array(lengths)
    expected = lengths * (limit - worst)  # mm: the arc the strut end may still sweep
    np.testing.assert_allclose(np.asarray(sol.margin), expected, rtol=0, atol=1e-5)  # arccos ~1e-8 rad near 0
    clear = np.abs(worst - limit).max(axis=1) > 1e-6
    np.testing.assert_array_equal(np.asarray(sol.reachable)[clear], np.all(worst < limit, axis=1)[clear])
    assert 0 < np.mean(np.asarray(sol.reachable)) < 1
    bad = poses[~np.asarray(sol.reachable)][0]
    with pytest.raises(ValueError, match="unreachable pose"):
        sj.inverse_kinematics(m, bad)
    # without limits the margin is the strut length: always reachable
    sol = fast.solve_inverse_kinematics(jnp.asarray(poses))
    assert bool(np.all(sol.reachable))
    np.testing.assert_allclose(np.asarray(sol.margin), lengths, rtol=1e-14)


# ---- geometry files ----------------------------------------------------------------------------


def test_geometry_file_round_trip_with_limits(tmp_path):
    cam = preset("rubin_camera")
    lims = [(-10.0, 12.0), (-14.1, 14.1), (-14.1, 14.1), (-14.1, 14.1), (-14.1, 14.1), (-9.0, 9.5)]
    rng = np.random.default_rng(16)
    m = UPSMechanism(
        cam.base, cam.platform, cam.v0, np.asarray(cam.lengths0) + rng.normal(0, 0.1, 6),
        stroke_limits=lims, joint_angle_limit=np.deg2rad(3.0), travel=cam.travel,
    )
    d = m.to_dict()
    assert d["mechanism"] == "6-UPS" and d["units"] == "mm" and d["joint_angle_limits"] == pytest.approx(3.0)
    assert d["travel"] == pytest.approx({"x_mm": 11.4, "y_mm": 11.4, "z_mm": 13.1, "rx_deg": 0.36, "ry_deg": 0.36,
                                        "rz_deg": 0.10})
    path = tmp_path / "ups.json"
    sj.save_mechanism(m, path)
    back = sj.load_mechanism(path)
    assert isinstance(back, UPSMechanism)
    np.testing.assert_array_equal(back.params, m.params)
    assert back.stroke_limits == m.stroke_limits and back.travel == pytest.approx(m.travel)
    np.testing.assert_allclose(back.joint_angle_limit, m.joint_angle_limit, rtol=1e-15)
    # TOML, lengths0 left to its default
    toml = tmp_path / "ups.toml"
    rows = lambda a: "[" + ", ".join("[" + ", ".join(repr(float(x)) for x in r) + "]" for r in np.asarray(a)) + "]"
    toml.write_text(
        f'mechanism = "6-UPS"\nbase = {rows(cam.base)}\nplatform = {rows(cam.platform)}\n'
        f"v0 = [0.0, 0.0, -2758.4]\nstroke_limits = [-14.1, 14.1]\n"
    )
    back = sj.load_mechanism(toml)
    np.testing.assert_array_equal(back.params, cam.params)


@pytest.mark.parametrize(
    "change, message",
    [
        ({"base": [[0.0, 0.0, 0.0]] * 5}, r"base must have shape \(6, 3\)"),
        ({"platform": [[float("nan"), 0.0, 0.0]] * 6}, "platform contains NaN"),
        ({"lengths0": [1.0] * 5}, r"lengths0 must have shape \(6,\)"),
        ({"units": "m"}, "must be in mm"),
        ({"stroke_limits": [14.1, -14.1]}, "stroke_limits must be ordered"),
        ({"stroke_limits": [[-1.0, 1.0]] * 4}, "stroke_limits must be one"),
        ({"joint_angle_limits": 95.0}, r"joint_angle_limits must be in degrees, in \(0, 90\)"),
        ({"joint_angle_limits": 0.0}, r"joint_angle_limits must be in degrees"),
        ({"travel": {"x_mm": 1.0}}, "travel must be an object"),
    ],
)
def test_bad_geometry_files_name_the_field(change, message):
    d = preset("rubin_camera").to_dict()
    d.update(change)
    with pytest.raises(ValueError, match=message):
        sj.mechanism.mechanism_from_dict(json.loads(json.dumps(d)))


def test_missing_fields_and_radians_in_the_constructor():
    with pytest.raises(ValueError, match=r"missing \['platform'\]"):
        sj.mechanism.mechanism_from_dict({"mechanism": "6-UPS", "base": [[0.0] * 3] * 6})
    cam = preset("rubin_camera")
    with pytest.raises(ValueError, match="radians inside the library"):
        UPSMechanism(cam.base, cam.platform, cam.v0, joint_angle_limit=30.0)


# ---- genhexkins --------------------------------------------------------------------------------


def parse_genhexkins(text):
    base, platform = np.full((6, 3), np.nan), np.full((6, 3), np.nan)
    for line in text.splitlines():
        hit = re.fullmatch(r"setp genhexkins\.(base|platform)\.([0-5])\.([xyz]) (\S+)", line)
        if hit:
            side, n, axis, value = hit.groups()
            (base if side == "base" else platform)[int(n), "xyz".index(axis)] = float(value)
        else:
            assert line.startswith("#"), line
    l0 = re.search(r"^# lengths0: (.*)$", text, re.M).group(1)
    v0 = re.search(r"^# v0 .*: (.*)$", text, re.M).group(1)
    return base, platform, np.array(l0.split(), float), np.array(v0.split(), float)


@pytest.mark.parametrize("name", UPS_PRESETS)
def test_genhexkins_export_reproduces_our_strut_lengths(name):
    rng = np.random.default_rng(17)
    nominal = preset(name)
    m = nominal.with_params(nominal.params + jnp.asarray(rng.normal(0, 0.5, 42)))  # a calibrated geometry
    text = to_genhexkins(m)
    assert len([x for x in text.splitlines() if x.startswith("setp ")]) == 36
    base, platform, l0, v0 = parse_genhexkins(text)
    assert np.all(np.isfinite(base)) and np.all(np.isfinite(platform))
    np.testing.assert_array_equal(l0, m.lengths0)
    np.testing.assert_array_equal(v0, m.v0)
    poses = in_travel(m, 18, 16)
    ours = np.asarray(m.lengths0 + m.solve_inverse_kinematics(jnp.asarray(poses)).readings)
    for p, length in zip(poses, ours, strict=True):
        # genhexkins: |R·a + pos − b| with pos the platform origin in world, A B C in degrees
        pos, abc = p[:3] + v0, np.rad2deg(p[3:])
        rot = rz(np.deg2rad(abc[2])) @ ry(np.deg2rad(abc[1])) @ rx(np.deg2rad(abc[0]))
        np.testing.assert_allclose(np.linalg.norm(platform @ rot.T + pos - base, axis=1), length, rtol=0, atol=1e-9)


def test_genhexkins_refuses_a_slider_mechanism():
    with pytest.raises(TypeError, match="genhexkins models struts"):
        to_genhexkins(sj.nominal_geometry())


# ---- calibration -------------------------------------------------------------------------------


def platform_tracker(m, sigma_um=3.0):
    """Three balls on the platform's joint ring (A's origin can be metres away: the Rubin
    camera hexapod's pivot is 2.2 m from its platform), each coordinate seen with σ = 3 µm."""
    plat = np.asarray(m.platform)
    centre = plat.mean(axis=0)
    radius = np.linalg.norm(plat[:, :2] - centre[:2], axis=1).mean()
    ang = np.deg2rad([90.0, 210.0, 330.0])
    balls = np.stack([centre[0] + radius * np.cos(ang), centre[1] + radius * np.sin(ang), np.full(3, centre[2])], -1)
    return LaserTracker(jnp.asarray(balls), sigma_um * 1e-3)


def along_strut_combinations(m):
    """The 12 parameter combinations a travel of a few mm and a fraction of a degree sees only to
    second order: per strut, both joints slid along the strut, and the base joint moved along
    the strut against ``lengths0`` (unit vectors in parameter space, as columns)."""
    e = np.asarray(m.platform + m.v0 - m.base)
    u = e / np.linalg.norm(e, axis=1, keepdims=True)
    cols = []
    for i in range(6):
        slide = np.zeros(42)
        slide[3 * i : 3 * i + 3] = u[i]
        slide[18 + 3 * i : 21 + 3 * i] = u[i]
        grow = np.zeros(42)
        grow[18 + 3 * i : 21 + 3 * i] = -u[i]
        grow[36 + i] = 1.0
        cols += [slide, grow]
    q, _ = np.linalg.qr(np.array(cols).T)
    return q


@pytest.mark.parametrize("name", UPS_PRESETS)
def test_calibration_reaches_the_noise_floor(name):
    nominal = preset(name)
    rng = np.random.default_rng(19)
    actual = nominal.with_params(nominal.params + jnp.asarray(rng.normal(0, 0.5, 42)))
    targets = jnp.asarray(reachable_in_travel(nominal, 20, 24))
    sim = sj.simulate_measurements(jax.random.key(21), nominal, actual, targets, tracker=platform_tracker(nominal))
    assert bool(np.all(sim.converged))
    problem = sj.calibration_problem(sim.data, nominal, half_width=5.0)
    floor = float(problem.cost(actual.params))  # S at the true parameters: the tracker's noise
    start = float(problem.cost(nominal.params))
    result = sj.calibrate(problem, "lm-batched")
    assert start > 1e3 * floor
    assert float(result.cost) <= floor  # the fit is at the noise floor (it also fits some noise)

    # identifiability: formally full rank, but at a tolerance the noise can resolve (1e-4 of the
    # largest singular value) rank 30: the 12 unidentifiable combinations are the along-strut ones
    report = identifiability_report(nominal, targets, sigma_um=3.0, sigma_arcsec=1.0, rtol=1e-4)
    assert report.rank == 30
    weak = along_strut_combinations(nominal)
    blind = report.unidentifiable.T  # (42, 12)
    assert np.linalg.norm(blind - weak @ (weak.T @ blind), axis=0).max() < 0.15
    # the error of the identifiable part, along the right singular vectors of the Jacobian: the
    # 6 directions seen at zeroth order (each strut's zero-reading length) to < 1 µm, the 18
    # best-determined to < 0.3 mm, from a 0.5 mm (σ) perturbation
    err = np.asarray(result.params - actual.params)
    _, sv, vt = np.linalg.svd(np.asarray(actual.parameter_jacobian(targets)))
    assert sv[-1] > 1e-9 * sv[0]  # rank 42 at the default tolerance
    assert np.abs(vt[:6].T @ (vt[:6] @ err)).max() < 1e-3
    assert np.abs(vt[:18].T @ (vt[:18] @ err)).max() < 0.3
    # and the calibrated model commands the true mechanism 20x better than the nominal one
    fresh = jnp.asarray(reachable_in_travel(nominal, 22, 24))  # as many as targets: compiled solves reused
    after = np.abs(np.asarray(sj.control_error(problem.calibrated(result.params), actual, fresh).errors))
    before = np.abs(np.asarray(sj.control_error(nominal, actual, fresh).errors))
    assert after[:, :3].max() < 0.05 * before[:, :3].max()
    assert after[:, 3:].max() < 0.05 * before[:, 3:].max()
