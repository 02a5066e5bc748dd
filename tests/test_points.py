"""Point-based calibration from a laser tracker's own measurements (the CLI end to end, the model's
Jacobian against finite differences, the noise model, the coverage of the predicted uncertainty over
20 noise draws, and every bad-input refusal)."""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.stats import chi2 as chi2_dist

from stewart_jax._cli import main as cli_main
from stewart_jax.calibration import (
    PointData,
    calibrate_points,
    control_error,
    read_points_csv,
    read_targets,
    summarize_control_error,
)
from stewart_jax.calibration._points import _problem, start_values, tracker_whitening
from stewart_jax.calibration._points_simulation import default_registration
from stewart_jax.mechanism import forward_kinematics, load_mechanism, preset, presets

RANGE_UM, ACROSS_UM_PER_M = 5.0, 2.5


def np_rotation(a):
    (cf, ct, cp), (sf, st, sp) = np.cos(a), np.sin(a)
    rz = np.array([[cp, -sp, 0], [sp, cp, 0], [0, 0, 1]])
    ry = np.array([[ct, 0, st], [0, 1, 0], [-st, 0, ct]])
    rx = np.array([[1, 0, 0], [0, cf, -sf], [0, sf, cf]])
    return rz @ ry @ rx


def np_covariance(p, range_um, across_um_per_m):
    """σ∥² u uᵀ + σ⊥² (I − u uᵀ), mm²."""
    dist = np.linalg.norm(p)
    u = p / dist
    s_par, s_perp = range_um * 1e-3, across_um_per_m * 1e-3 * dist / 1000
    return s_par**2 * np.outer(u, u) + s_perp**2 * (np.eye(3) - np.outer(u, u))


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """``simulate --points`` then ``calibrate`` on the files, as the how-to runs them."""
    d = tmp_path_factory.mktemp("points")
    assert cli_main(["export", "rubin_m2", "--out", str(d / "g.json")]) == 0
    assert cli_main(["simulate", "--points", "--targets", str(d / "T.json"), "--default-targets",
                     "--geometry", str(d / "g.json"), "--plan", "plan120", "--seed", "3", "--visible", "0.45",
                     "--out", str(d / "points.csv"), "--out-true", str(d / "true.json")]) == 0
    code = cli_main(["calibrate", str(d / "points.csv"), "--geometry", str(d / "g.json"), "--targets",
                     str(d / "T.json"), "--tracker-sigma-um", f"{RANGE_UM},{ACROSS_UM_PER_M}", "--json",
                     str(d / "res.json"), "--out-geometry", str(d / "cal.json"), "--report", str(d / "rep.md")])
    assert code == 0
    targets = read_targets(d / "T.json")
    data = read_points_csv(d / "points.csv", targets)
    return {"dir": d, "targets": targets, "data": data, "nominal": load_mechanism(d / "g.json"),
            "true": load_mechanism(d / "true.json"), "json": json.loads((d / "res.json").read_text())}


@pytest.mark.slow  # the module's command-line run: 50 s on 2 cores
def test_cli_calibration_recovers_the_true_mechanism(run):
    out, data = run["json"], run["data"]
    seen = data.targets_per_pose()
    assert out["poses_with_1_or_2_targets"] == int(np.sum(seen < 3)) >= 10  # used, not dropped
    assert out["n_points"] == len(data.points) == int(seen.sum())
    assert out["data_status"] in ("ok", "partly_determined") and out["status"] == "success"
    k = out["determined_directions"]
    assert (k == 48) == (out["data_status"] == "ok")
    assert out["dof"] == 3 * (len(data.points) + len(data.references)) - k
    assert 1e-3 < out["p_value"] < 1 - 1e-3
    cal, nominal, true = load_mechanism(run["dir"] / "cal.json"), run["nominal"], run["true"]
    targets = jnp.asarray(np.random.default_rng(0).uniform(-1, 1, (30, 6)) * np.array([5, 5, 5, 1e-3, 1e-3, 1e-3]))
    before = summarize_control_error(control_error(nominal, true, targets))["rms"]
    after = summarize_control_error(control_error(cal, true, targets))["rms"]
    assert max(after[:3]) < 20.0 and max(after[3:]) < 2.0  # µm, ″
    assert all(a < b / 20 for a, b in zip(after, before, strict=True))
    rot, t = default_registration(nominal)
    np.testing.assert_allclose(out["registration_translation_mm"], t, atol=0.05)
    np.testing.assert_allclose(out["registration_rotation"], rot, atol=1e-5)
    report = (run["dir"] / "rep.md").read_text()
    assert "tracker points" in report and "χ² = " in report


@pytest.mark.slow  # the module's command-line run: 50 s on 2 cores
def test_jacobian_matches_central_differences(run):
    data, targets, nominal = run["data"], run["targets"], run["nominal"]
    problem = _problem(data, targets, nominal, RANGE_UM, ACROSS_UM_PER_M, start_values(data, targets, nominal))
    n = nominal.n_params
    y = jnp.concatenate([nominal.params, jnp.zeros(6)]) + 1e-3 * jax.random.normal(jax.random.key(4), (n + 6,))
    jac = np.asarray(problem.jacobian(y, nominal))

    def res(z):  # eager: cheaper here than compiling the residual once more
        return problem.residuals(z, nominal)

    for k in (0, 20, 37, n + 1, n + 4, n + 5):
        h = 1e-5 if k < n else 1e-7
        fd = (np.asarray(res(y.at[k].add(h))) - np.asarray(res(y.at[k].add(-h)))) / (2 * h)
        np.testing.assert_allclose(jac[:, k], fd, rtol=1e-5, atol=1e-5 * np.max(np.abs(fd)))


def test_whitening_inverts_the_tracker_covariance():
    pts = np.random.default_rng(1).normal(0, 2000, (50, 3))
    w = tracker_whitening(pts, RANGE_UM, ACROSS_UM_PER_M)
    for wi, p in zip(w, pts, strict=True):
        np.testing.assert_allclose(wi @ np_covariance(p, RANGE_UM, ACROSS_UM_PER_M) @ wi.T, np.eye(3), atol=1e-9)


@pytest.mark.slow  # the module's command-line run: 50 s on 2 cores
def test_predicted_uncertainty_covers_the_error(run):
    """20 noise draws on the same poses and targets: in the directions the points determine (the
    others are held at nominal), the estimate's Mahalanobis distance from the truth under the
    predicted covariance is χ²(k)-distributed when the uncertainty is right (the truncated
    least-squares estimate is unbiased there whatever the truth's held part)."""
    data, targets, nominal, true = run["data"], run["targets"], run["nominal"], run["true"]
    rot, t = default_registration(nominal)
    poses = np.asarray(forward_kinematics(true, jnp.asarray(data.readings)).poses)
    p = poses[data.pose_index]
    in_b = np.stack([np_rotation(x[3:]) @ a for x, a in zip(p, targets.platform[data.target_index], strict=True)])
    exact = (in_b + p[:, :3] + np.asarray(true.v0)) @ rot.T + t
    refs_exact = targets.base[data.reference_index] @ rot.T + t
    chol = [np.linalg.cholesky(np_covariance(x, RANGE_UM, ACROSS_UM_PER_M)) for x in np.vstack([exact, refs_exact])]
    rng = np.random.default_rng(7)
    inside, p_values = 0, []
    for _ in range(20):
        noisy = np.vstack([exact, refs_exact]) + np.stack([c @ rng.normal(size=3) for c in chol])
        draw = data._replace(points=noisy[: len(exact)], references=noisy[len(exact):])
        cal = calibrate_points(draw, targets, nominal, range_um=RANGE_UM, across_um_per_m=ACROSS_UM_PER_M)
        rot0, t0, _, _ = start_values(draw, targets, nominal)
        from stewart_jax import euler_angles

        reg_true = np.concatenate([t - t0, np.asarray(euler_angles(jnp.asarray(rot0.T @ rot)))])
        reg_fit = np.concatenate([cal.translation - t0, np.asarray(euler_angles(jnp.asarray(rot0.T @ cal.rotation)))])
        e = np.concatenate([cal.params - np.asarray(true.params), reg_fit - reg_true])
        det = cal.determination
        b = det.determined / det.scale  # determined coordinates of a parameter vector
        z, cov = b @ e, b @ cal.assessment.param_cov @ b.T
        inside += float(z @ np.linalg.solve(cov, z)) <= chi2_dist.ppf(0.99, det.n_determined)
        p_values.append(cal.assessment.p_value)
    assert inside >= 19
    assert sum(p > 1e-3 for p in p_values) >= 19


@pytest.mark.slow  # two more compilations of the fit (one per number of determined directions): 80 s
def test_determined_std_sets_what_is_held(run):
    """Fitting every direction (a threshold no direction exceeds) is the plain least-squares fit: all
    48 unknowns determined, and a χ² lower than the default's by about one per direction the default
    holds (fitting k more directions to noise lowers χ² by χ²_k, mean k, std √(2k))."""
    data, targets, nominal = run["data"], run["targets"], run["nominal"]
    held = calibrate_points(data, targets, nominal, range_um=RANGE_UM, across_um_per_m=ACROSS_UM_PER_M)
    free = calibrate_points(data, targets, nominal, range_um=RANGE_UM, across_um_per_m=ACROSS_UM_PER_M,
                            determined_std=1e9)
    k = nominal.n_params + 6 - held.assessment.n_determined
    assert free.assessment.n_determined == nominal.n_params + 6 and k > 0
    assert np.all(np.isfinite(free.assessment.param_cov))
    assert 0 < held.chi2 - free.chi2 < k + 4 * np.sqrt(2 * k)


def test_determined_std_must_be_positive(run):
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="determined_std must be a positive, finite number"):
            calibrate_points(run["data"], run["targets"], run["nominal"], determined_std=bad)


# ---- bad input ---------------------------------------------------------------------------------------


def _lines(run):
    return (run["dir"] / "points.csv").read_text().splitlines()


def _refuse(run, tmp_path, lines, match):
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(ValueError, match=match) as e:
        read_points_csv(path, run["targets"])
    assert "\n" not in str(e.value)


@pytest.mark.slow  # the module's command-line run: 50 s on 2 cores
def test_bad_points_files_are_refused_naming_the_line(run, tmp_path):
    lines = _lines(run)
    first_pose = next(i for i, x in enumerate(lines) if i and not x.startswith("ref"))  # line i + 1
    # a target missing from T.json
    bad = list(lines)
    bad[first_pose] = bad[first_pose].replace(",P", ",Q", 1)
    _refuse(run, tmp_path, bad, rf"line {first_pose + 1}: platform target 'Q\d' is not in")
    # fewer than three base references
    _refuse(run, tmp_path, [lines[0], *lines[3:]], "2 base reference")
    # readings that disagree between rows of one pose
    pose = lines[first_pose].split(",")[0]
    second = next(i for i in range(first_pose + 1, len(lines)) if lines[i].split(",")[0] == pose)
    cells = lines[second].split(",")
    cells[2] = repr(float(cells[2]) + 0.001)
    _refuse(run, tmp_path, [*lines[:second], ",".join(cells), *lines[second + 1:]],
            rf"line {second + 1}: pose '{pose}' has readings that disagree with its row on line {first_pose + 1}")
    # a file in metres
    metres = [lines[0]] + [",".join(c[:8] + [repr(float(x) / 1000) for x in c[8:]])
                           for c in (x.split(",") for x in lines[1:])]
    _refuse(run, tmp_path, metres, "in metres")
    # a duplicate row
    _refuse(run, tmp_path, [*lines, lines[first_pose]], rf"line {len(lines) + 1}: duplicate row.*line {first_pose + 1}")


@pytest.mark.slow  # the module's command-line run: 50 s on 2 cores
def test_cli_refuses_before_any_work(run, tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(_lines(run)[:1] + _lines(run)[3:]) + "\n")
    code = cli_main(["calibrate", str(bad), "--geometry", "rubin_m2", "--targets", str(run["dir"] / "T.json")])
    err = capsys.readouterr().err
    assert code == 2 and "base reference" in err and len(err.strip().splitlines()) == 1
    code = cli_main(["calibrate", str(run["dir"] / "points.csv"), "--geometry", "rubin_m2"])
    assert code == 2 and "--targets" in capsys.readouterr().err
    assert isinstance(run["data"], PointData) and preset("rubin_m2").n_params == 42


# ---- every family ------------------------------------------------------------------------------------

FAMILY_PRESET = {preset(name).family: name for name in reversed(presets())}
"""The first preset of each registered family."""


@pytest.mark.parametrize("family", sorted(FAMILY_PRESET))
def test_points_files_of_every_family(family, tmp_path):
    """``simulate --points`` writes a family's readings in its file unit (mm; a crank's angle in
    degrees, as in the pose CSV), the file read with the family's unit gives them back exactly,
    and they are the readings that produced the points: the true geometry's forward kinematics
    of them puts the targets where the tracker saw them, within its noise (χ² of the whitened
    residuals, 3 per point). Read as plain numbers, a crank file misses by millimetres."""
    name = FAMILY_PRESET[family]
    nominal = preset(name)
    assert cli_main(["simulate", "--points", "--targets", str(tmp_path / "T.json"), "--default-targets",
                     "--geometry", name, "--plan", "paper8", "--seed", "2", "--visible", "1",
                     "--out", str(tmp_path / "points.csv"), "--out-true", str(tmp_path / "true.json")]) == 0
    targets, true = read_targets(tmp_path / "T.json"), load_mechanism(tmp_path / "true.json")
    data = read_points_csv(tmp_path / "points.csv", targets, reading_unit=nominal.reading_unit)
    lines = [x.split(",") for x in (tmp_path / "points.csv").read_text().splitlines()[1:] if not x.startswith("ref")]
    cells = np.array([[float(c) for c in x[2:8]] for x in lines])
    in_file = np.degrees(data.readings) if nominal.reading_unit == "rad" else data.readings
    np.testing.assert_allclose(cells, in_file[data.pose_index], rtol=1e-14, atol=0)
    rot, t = default_registration(nominal)

    def chi2(readings):
        fk = forward_kinematics(true, jnp.asarray(readings))
        p = np.asarray(fk.poses)[data.pose_index]
        in_b = np.stack([np_rotation(x[3:]) @ a for x, a in zip(p, targets.platform[data.target_index], strict=True)])
        r = data.points - ((in_b + p[:, :3] + np.asarray(true.v0)) @ rot.T + t)
        w = tracker_whitening(data.points, 5.0, 2.5)  # simulate's default noise
        return float(np.sum(np.einsum("nij,nj->ni", w, r) ** 2)), bool(np.all(np.asarray(fk.converged)))

    value, converged = chi2(data.readings)
    assert converged and 1e-3 < chi2_dist.sf(value, 3 * len(data.points)) < 1 - 1e-3
    if nominal.reading_unit == "rad":
        value, converged = chi2(read_points_csv(tmp_path / "points.csv", targets).readings)
        assert not converged or value > 100 * 3 * len(data.points)


@pytest.mark.slow  # the module's command-line run: 50 s on 2 cores
def test_calibrated_joints_near_the_truth_and_export_checks_support(run, tmp_path, capsys):
    """The how-to's route ends in a geometry whose parameters lie within a few std of the truth
    (each std at most the 1 mm prior scale) and which exports; a geometry moved where its data give
    no support is refused in words, and exported with a warning on request."""
    d = run["dir"]
    cal, true = load_mechanism(d / "cal.json"), run["true"]
    out = run["json"]
    std = np.array(out["param_std"], dtype=float)
    err = np.abs(np.asarray(cal.params) - np.asarray(true.params))
    assert np.all(std <= 1.0 + 1e-9) and np.all(err <= 4 * std) and np.max(err) < 5.0
    assert cli_main(["export", str(d / "cal.json"), "--format", "linuxcnc", "--out", str(tmp_path / "cnc"),
                     "--stroke-limits-mm=-20,20"]) == 0
    record = json.loads((d / "cal.json").read_text())
    moved = dict(record)
    moved["platform"] = (np.asarray(record["platform"]) + [0.0, 0.0, 5.0]).tolist()
    moved["_calibration"] = dict(record["_calibration"], param_std=[50.0] * len(std))
    bad = tmp_path / "moved.json"
    bad.write_text(json.dumps(moved))
    capsys.readouterr()
    assert cli_main(["export", str(bad), "--format", "linuxcnc", "--out", str(tmp_path / "cnc2"),
                     "--stroke-limits-mm=-20,20"]) != 0
    assert "further than its calibration data support" in capsys.readouterr().err
    assert not (tmp_path / "cnc2").exists()
    assert cli_main(["export", str(bad), "--out", str(tmp_path / "g.json"), "--allow-unsupported"]) == 0
    assert "WARNING" in capsys.readouterr().err
