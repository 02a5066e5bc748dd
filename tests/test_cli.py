import json

import numpy as np

import stewart_jax as sj
from stewart_jax._cli import main


def test_simulate_then_calibrate(tmp_path):
    csv = tmp_path / "m.csv"
    assert main(["simulate", "--out", str(csv), "--seed", "4", "--sigma-um", "0", "--sigma-arcsec", "0"]) == 0
    data = sj.read_csv(csv)
    assert data.n_poses == 8
    # Noise-free: the measured poses are the true poses, which the true model maps to the readings.
    np.testing.assert_allclose(sj.inverse_kinematics(sj.actual_geometry(), data.poses), data.readings, atol=1e-9)
    out = tmp_path / "c.json"
    geo = tmp_path / "g.json"
    png = tmp_path / "r.png"
    assert main(["calibrate", str(csv), "--method", "lm", "--json", str(out), "--out-geometry", str(geo),
                 "--plot", str(png)]) == 0
    assert png.stat().st_size > 1000
    res = json.loads(out.read_text())
    for key in ("method", "params", "cost", "n_evaluations", "seconds"):
        assert key in res
    assert res["method"] == "lm" and len(res["params"]) == 36
    # noise-free readings: every determined direction fits them exactly; 8 poses leave some directions
    # undetermined at the stated 0.1 µm, held at nominal, whose share of the truth stays below that noise
    assert res["cost"] < 1e-18 or (res["determined_directions"] < 36 and res["rms_residual_um"] < 0.1)
    std = np.asarray(res["param_std"])
    assert std.shape == (36,) and np.all(std > 0) and np.all(np.isfinite(std))
    np.testing.assert_array_equal(sj.load_mechanism(geo).params, res["params"])


def test_cli_reports_bad_file(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("q1,q2\n1,2\n")
    assert main(["calibrate", str(bad)]) == 2
    assert "missing column" in capsys.readouterr().err
