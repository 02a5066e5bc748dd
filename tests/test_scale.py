"""Memory linear in the number of poses: the identifiability report's covariance is formed per
pose block, never as a dense (6m × 6m) matrix."""

import tracemalloc

import jax
import numpy as np

import stewart_jax as sj
from stewart_jax.calibration import identifiability_report
from stewart_jax.calibration._identifiability import (
    identification_jacobian,
    pose_noise_covariance,
    reading_noise_covariance,
)
from stewart_jax.calibration._simulation import random_poses


def test_covariance_equals_the_dense_sandwich():
    # Independent: the textbook (JᵀJ)⁺ Jᵀ C J (JᵀJ)⁺ with C assembled dense, at 40 poses.
    nom = sj.mechanism.preset("nominal")
    poses = random_poses(jax.random.key(0), 40)
    rep = identifiability_report(nom, poses, sigma_um=0.1, sigma_arcsec=0.1)
    J = np.asarray(identification_jacobian(nom, poses))
    C = np.asarray(reading_noise_covariance(nom, poses, pose_noise_covariance(0.1, 0.1)))
    dense = np.zeros((6 * 40, 6 * 40))
    for j in range(40):
        dense[6 * j:6 * j + 6, 6 * j:6 * j + 6] = C[j]
    p = np.linalg.pinv(J.T @ J, rcond=1e-18, hermitian=True)
    expected = p @ J.T @ dense @ J @ p
    np.testing.assert_allclose(rep.param_cov, 0.5 * (expected + expected.T), rtol=1e-8,
                               atol=1e-12 * np.abs(expected).max())


def test_report_memory_is_linear_in_the_poses():
    # 4000 poses: a dense 24000 × 24000 covariance would take 4.6 GB; the Jacobian is 6.9 MB.
    # The report's NumPy allocations stay within 40 Jacobians' worth.
    nom = sj.mechanism.preset("nominal")
    poses = random_poses(jax.random.key(1), 4000)
    identifiability_report(nom, poses[:10])  # compile outside the measurement
    tracemalloc.start()
    identifiability_report(nom, poses)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    jac_bytes = 6 * 4000 * 36 * 8
    assert peak < 40 * jac_bytes, peak / 1e6


def test_a_large_calibration_says_each_stage_with_its_time(tmp_path, capsys, monkeypatch):
    """At PROGRESS_POSES poses and more, calibrate says on stderr when the fit and the assessment
    start and end (their times), and that the fit's JSON is written before the assessment starts;
    below it, nothing. The threshold is lowered to the paper's 8 poses here, to keep the test short."""
    import json

    from stewart_jax._cli import calibrate as cli_calibrate, main

    assert main(["simulate", "--out", str(tmp_path / "p8.csv"), "--plan", "paper8", "--seed", "0"]) == 0
    argv = ["calibrate", str(tmp_path / "p8.csv"), "--json", str(tmp_path / "c.json")]
    capsys.readouterr()
    assert main(argv) in (0, 3)
    assert "calibrate: fitting" not in capsys.readouterr().err
    monkeypatch.setattr(cli_calibrate, "PROGRESS_POSES", 8)
    assert main(argv) in (0, 3)
    lines = [line for line in capsys.readouterr().err.splitlines() if line.startswith("calibrate: ")]
    assert [line.split(" ")[1] for line in lines] == ["fitting", "fit", "assessing", "assessment"], lines
    assert "8 poses with lm-batched" in lines[0] and f"written to {tmp_path / 'c.json'}" in lines[1]
    assert float(lines[3].split(" in ")[1].split(" s")[0]) >= 0
    assert json.loads((tmp_path / "c.json").read_text())["n_poses"] == 8
