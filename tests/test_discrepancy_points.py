"""The discrepancy workflow on a laser tracker's points (the 6-UPS strut model of the Rubin camera
hexapod seen through the tracker, with its anisotropic noise).

The sessions come from the independent NumPy simulator of ``_numpy_session.py`` (the true strut
physics with a hidden effect, written without the library's effect registry), with every
platform target measured at each reached pose in the tracker's frame plus the tracker's noise
(σ = 5 µm along the line of sight, 2.5 µm per metre across it, drawn here in NumPy). Every
diagnosis has the same shapes and candidates, so the command line's shares the compiled kernels.
"""

import dataclasses
import json

import jax.numpy as jnp
import numpy as np
import pytest
from _numpy_session import rotation, session

import stewart_jax as sj
from stewart_jax import discrepancy as dc
from stewart_jax._cli import main
from stewart_jax.calibration import PointData

# The slow tier (make test-all runs it, make test does not): the tracker-point diagnosis's rates over seeds.
pytestmark = pytest.mark.slow

RANGE_UM, ACROSS_UM_PER_M = 5.0, 2.5
N_POSES = 30
CANDIDATES = ("strut_scale", "backlash")
SCALE_PPM = (2000.0, 4000.0)
"""The hidden strut scale errors (ppm): a tracker's micrometres see the simulator's 300–600 ppm
(1–2 µm on the camera's strokes of ±4 mm RMS) only with hundreds of poses."""
TRUTH_KEY = {"strut_scale": "k", "thermal_expansion": "alpha", "backlash": "b", "gravity_sag": "c"}


@pytest.fixture(scope="module")
def camera():
    return sj.mechanism.preset("rubin_camera")


@pytest.fixture(scope="module")
def setup(camera):
    from stewart_jax.calibration._points_simulation import default_registration, default_targets

    targets = default_targets(camera)
    rot, t = default_registration(camera)
    half = sj.calibration.reachable_travel(camera)
    return targets, rot, t, half


def tracker_noise(rng, p):
    """σ∥ along the line of sight from the head, σ⊥ = across × distance (NumPy)."""
    dist = np.linalg.norm(p, axis=1, keepdims=True)
    u = p / dist
    z = rng.standard_normal(p.shape)
    along = np.sum(z * u, axis=1, keepdims=True)
    return RANGE_UM * 1e-3 * along * u + ACROSS_UM_PER_M * 1e-3 * dist / 1000 * (z - along * u)


def points_session(camera, setup, effect, seed, *, perturb_um=30.0, noise=True, scale_ppm=None):
    """(PointData, the NumPy session): every target seen at each of ``N_POSES`` poses. With
    ``scale_ppm`` = (lo, hi), the readings of a session without effect are divided by ``1 + k_i``,
    ``|k_i|`` uniform in that range with random signs (a strut scale error as the tracker sees it)."""
    targets, rot, t, half = setup
    geometry = {"base": np.asarray(camera.base), "platform": np.asarray(camera.platform),
                "v0": np.asarray(camera.v0), "lengths0": np.asarray(camera.lengths0)}
    rng = np.random.default_rng(seed)
    s = session("6-UPS", geometry, effect, rng, half=half, n=N_POSES, sigma_um=0.0, sigma_arcsec=0.0,
                perturb_um=perturb_um)  # pose noise 0: ``poses`` are the true reached poses
    if scale_ppm is not None:
        k = rng.choice([-1.0, 1.0], 6) * rng.uniform(*scale_ppm, 6) * 1e-6
        s = dataclasses.replace(s, readings=s.readings / (1.0 + k), effect="strut_scale", truth={"k": k})
    k = len(targets.platform)
    pose, target = np.repeat(np.arange(N_POSES), k), np.tile(np.arange(k), N_POSES)
    in_b = (np.einsum("nij,nj->ni", rotation(s.poses[pose, 3:]), targets.platform[target]) + s.poses[pose, :3]
            + np.asarray(camera.v0))
    points, refs = in_b @ rot.T + t, targets.base @ rot.T + t
    if noise:
        points, refs = points + tracker_noise(rng, points), refs + tracker_noise(rng, refs)
    data = PointData(tuple(str(j + 1) for j in range(N_POSES)), s.readings, pose, target, points,
                     np.arange(len(targets.base)), refs, s.directions, s.temperature, s.time)
    return data, s


@pytest.mark.parametrize("effect", [None, *TRUTH_KEY])
def test_the_model_at_the_truth_reproduces_the_points(camera, setup, effect):
    """Noise-free points of the true machine (nominal geometry + the effect) are predicted to
    1e-9 mm (gravity_sag: 1e-5 mm) by the points model with the effect's true parameters, and missed by > 0.5 µm
    without it: forward kinematics through the effect, independently of the simulator."""
    data, s = points_session(camera, setup, effect, 11, perturb_um=0.0, noise=False)
    targets = setup[0]
    rows, rot, t = dc.point_rows(data, targets, camera, range_um=RANGE_UM, across_um_per_m=ACROSS_UM_PER_M)
    model = dc.points_model(camera, rot, t)
    if effect is None:
        pred = model.predict(model.base_initial, (), (), rows)
    else:
        e = dc.get_effect(model.name, effect)
        theta = np.asarray(s.truth[TRUTH_KEY[effect]])
        theta = np.concatenate([theta, np.zeros(e.n_params - theta.size)])  # a weight at A's origin along −z
        pred = model.predict(model.base_initial, (e,), (jnp.asarray(theta),), rows)
        without = model.predict(model.base_initial, (), (), rows)
        assert np.max(np.abs(np.asarray(without) - data.points)) > 5e-4
    # the registration from the noise-free references is exact, so the points are too; the
    # pose-dependent gravity_sag is evaluated at the starting pose (the model's NOTE): 5 nm here
    atol = 1e-5 if effect == "gravity_sag" else 1e-9
    np.testing.assert_allclose(np.asarray(pred), data.points, rtol=0, atol=atol)


def test_no_measured_pose_effect_is_offered(camera, setup):
    """The registration stands for ``tracker_misalignment``; the candidates are the mechanism's."""
    targets, rot, t, _ = setup
    model = dc.points_model(camera, rot, t)
    names = dc.effect_names(model.name)
    assert "tracker_misalignment" not in names
    assert set(CANDIDATES) <= set(names) and "gravity_sag" in names


@pytest.fixture(scope="module")
def reports(camera, setup):
    """Diagnoses of two null sessions (the command line's test diagnoses one hiding
    ``strut_scale``); one data set each, so all three share one compiled program."""
    targets = setup[0]
    out = {}
    for seed in (0, 1):
        data, _ = points_session(camera, setup, None, 100 + seed)
        rows, rot, t = dc.point_rows(data, targets, camera, range_um=RANGE_UM, across_um_per_m=ACROSS_UM_PER_M)
        out[seed] = dc.diagnose(rows, dc.points_model(camera, rot, t), effects=CANDIDATES, seed=seed)
    return out


def test_no_alarm_without_a_hidden_effect(reports):
    # a name must never be given where nothing is hidden: 0 of 68 null sessions measured were named.
    # The detection alone fires at its nominal rate (3 of 60 null sessions at α = 5 %,
    # benchmarks/discrepancy_points.py --null-seeds 60); seed 1 is one such session (p = 0.012):
    # detected, and still not named. Both detecting has probability ≈ 0.3 % at that rate.
    null = list(reports.values())
    assert all(r.named_effect is None for r in null), [r.named_effect for r in null]
    assert sum(r.detected for r in null) <= 1, [r.detect_p_value for r in null]


def test_cli_diagnoses_a_points_file(tmp_path, camera, setup, capsys):
    from stewart_jax.calibration._points_io import write_points_csv, write_targets

    targets = setup[0]
    data, _ = points_session(camera, setup, None, 100, scale_ppm=SCALE_PPM)
    sj.save_mechanism(camera, tmp_path / "camera.json")
    write_targets(tmp_path / "T.json", targets)
    write_points_csv(tmp_path / "points.csv", data, targets)
    args = ["diagnose", str(tmp_path / "points.csv"), "--geometry", str(tmp_path / "camera.json")]
    assert main(args) == 2 and "--targets" in capsys.readouterr().err
    args += ["--targets", str(tmp_path / "T.json"), "--tracker-sigma-um", f"{RANGE_UM},{ACROSS_UM_PER_M}",
             "--effects", ",".join(CANDIDATES), "--seed", "0"]
    assert main(args + ["--out-model", str(tmp_path / "m.json")]) == 2 and "--out-geometry" in capsys.readouterr().err
    assert main(args + ["--json", str(tmp_path / "d.json")]) == 0
    out = json.loads((tmp_path / "d.json").read_text())
    assert out["data"] == "points" and out["n_points"] == len(data.points) and out["n_poses"] == N_POSES
    assert out["settings"]["tracker_sigma_range_um"] == RANGE_UM
    # a hidden strut scale error of 2000–4000 ppm on the camera's strokes: named in 8 of 8 seeds
    # measured (detection p ≤ 7e-6; gap 9–12 µm before, 7–7.7 µm after, noise floor ~7 µm)
    assert out["detected"] and out["named_effect"] == "strut_scale", (out["detection"], out["named_effect"])
    assert out["gap_after"] < out["gap_before"]
