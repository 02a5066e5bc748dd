"""Trustworthy results: bad input is a clear error before the work, output paths are checked
first, a calibration says what its data support, jitted kinematics never call a bad pose
reachable, and random corruptions of valid files give a clean error or a correct result.

One test (or parametrised family) per fault class; ``docs/trust.md`` maps the classes to them.
Public API and the command line only.
"""

import json
import string

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import stewart_jax as sj
from stewart_jax._cli import main
from stewart_jax.calibration import assess_calibration, read_csv, write_csv
from stewart_jax.mechanism import load_mechanism, mechanism_from_dict


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    """24 poses of the paper's 'actual' mechanism measured with σ = 0.1 µm / 0.1″, as data and CSV."""
    nominal, actual = sj.nominal_geometry(), sj.actual_geometry()
    targets = sj.calibration.random_poses(jax.random.key(5), 24)
    sim = sj.simulate_measurements(jax.random.key(6), nominal, actual, targets)
    path = tmp_path_factory.mktemp("m") / "m.csv"
    write_csv(path, sim.data)
    return sim.data, str(path)


def run(argv, capsys):
    rc = main(argv)
    captured = capsys.readouterr()
    return rc, captured.out, captured.err


# ---- class 3: output paths are checked before any work ----------------------------------------


@pytest.mark.parametrize("option", ["--json", "--out-geometry", "--report", "--plot"])
def test_unwritable_output_fails_before_the_calibration(measured, tmp_path, capsys, option):
    rc, _, err = run(["calibrate", measured[1], option, str(tmp_path / "missing" / "out")], capsys)
    assert rc == 2 and "does not exist" in err and "S =" not in err  # nothing was computed


def test_unwritable_outputs_of_the_other_commands(tmp_path, capsys):
    folder = str(tmp_path)
    for argv in (["study", "--trials", "1", "--json", folder],
                 ["study", "--trials", "1", "--checkpoint", str(tmp_path / "no" / "ck.json")],
                 ["simulate", "--out", str(tmp_path / "no" / "m.csv")],
                 ["export", "nominal", "--out", folder]):
        rc, _, err = run(argv, capsys)
        assert rc == 2 and ("is a folder" in err or "does not exist" in err), (argv, err)
        assert "trials" not in err.split("error:")[0] or "simulation study" not in err, err


# ---- class 2: a pose the geometry cannot reach is named, not an SVD failure --------------------


def test_unreachable_row_is_named_before_calibrating(measured, tmp_path, capsys):
    data, _ = measured
    poses = np.asarray(data.poses).copy()
    poses[3, 0] = 500.0  # mm: sideways beyond every rod
    path = tmp_path / "bad.csv"
    write_csv(path, sj.calibration.make_calibration_data(data.readings, poses))
    rc, _, err = run(["calibrate", str(path)], capsys)
    assert rc == 2 and "rows [4]" in err and "cannot reach" in err


# ---- class 4: what the data support -----------------------------------------------------------


def test_good_data_are_ok(measured):
    data, _ = measured
    nominal = sj.nominal_geometry()
    res = sj.calibrate(sj.calibration_problem(data, nominal), "lm-batched")
    a = assess_calibration(nominal.with_params(res.params), data, 0.1, 0.1)
    assert a.status == "ok" and a.rank == 36 and not a.warnings
    assert 0.7 < a.rms_ratio < 1.3 and np.all(np.isfinite(a.param_std))


def test_goodness_of_fit_statistic_is_chi2_distributed():
    """20 noisy data sets of the same poses, each calibrated: the statistic's mean is its degrees
    of freedom (χ² mean = dof, std = sqrt(2 dof)) and its p-values are not piled up near 0."""
    nominal, actual = sj.nominal_geometry(), sj.actual_geometry()
    targets = sj.calibration.random_poses(jax.random.key(5), 24)
    keys = jax.random.split(jax.random.key(9), 20)
    sims = jax.vmap(lambda k: sj.simulate_measurements(k, nominal, actual, targets))(keys)
    problems = jax.vmap(lambda d: sj.calibration_problem(d, nominal))(sims.data)
    res = sj.calibration.calibrate_batch(problems, "lm-batched", keys)
    stats = [assess_calibration(nominal.with_params(res.params[i]), jax.tree.map(lambda x, i=i: x[i], sims.data),
                                0.1, 0.1) for i in range(20)]
    chi2 = np.array([a.chi2 for a in stats])
    dof = stats[0].dof
    assert abs(chi2.mean() - dof) < 3 * np.sqrt(2 * dof / 20)  # 3 standard errors of the mean
    assert np.mean([a.p_value < 0.05 for a in stats]) <= 0.2


def test_radians_for_degrees_fail_the_goodness_of_fit(measured):
    """Angles read in the wrong unit: the fit converges, but to residuals far above the noise."""
    data, _ = measured
    nominal = sj.nominal_geometry()
    wrong = sj.calibration.make_calibration_data(data.readings, data.poses * jnp.array([1, 1, 1] + [np.pi / 180] * 3))
    res = sj.calibrate(sj.calibration_problem(wrong, nominal), "lm-batched")
    a = assess_calibration(nominal.with_params(res.params), wrong, 0.1, 0.1)
    assert a.status == "poor_fit" and a.rms_ratio > 10 and a.p_value < 1e-3
    assert any("units" in w and "diagnose" in w for w in a.warnings)


def test_lengths_in_metres_fail_the_goodness_of_fit(measured):
    """A file in metres: the poses and readings shrink 1000× and no geometry explains them at the
    stated noise (the noise shrinks with them: here the fit ends with χ² deep in the lower tail;
    in the 120-pose plan 1000× below the noise — both flagged)."""
    data, _ = measured
    nominal = sj.nominal_geometry()
    scale = jnp.array([1e-3] * 3 + [1.0] * 3)
    metres = sj.calibration.make_calibration_data(data.readings * 1e-3, data.poses * scale)
    res = sj.calibrate(sj.calibration_problem(metres, nominal), "lm-batched")
    a = assess_calibration(nominal.with_params(res.params), metres, 0.1, 0.1)
    assert a.status == "poor_fit" and a.p_value > 1 - 1e-3  # p of a χ² at least this large
    assert any("units" in w or "metres" in w for w in a.warnings)


def test_identical_rows_are_rank_deficient_and_get_no_std(tmp_path, measured, capsys):
    data, _ = measured
    ten = data.take(np.zeros(10, int))
    path = tmp_path / "ten.csv"
    write_csv(path, ten)
    out = tmp_path / "c.json"
    rc, _, err = run(["calibrate", str(path), "--json", str(out)], capsys)
    assert rc == 3 and "WARNING" in err
    d = json.loads(out.read_text())  # strict JSON: no NaN / Infinity
    assert d["data_status"] == "rank_deficient" and d["identification_rank"] == 6
    assert d["duplicate_rows"] == [list(range(1, 11))]
    # only parameters the data identify alone get a standard deviation: none here
    assert all(s is None for s in d["param_std"]) and not any(d["identifiable"])


def test_duplicated_rows_are_reported(measured):
    data, _ = measured
    twice = data.take(np.concatenate([np.arange(24), np.arange(24)]))
    a = assess_calibration(sj.actual_geometry(), twice, 0.1, 0.1)
    assert len(a.duplicate_rows) == 24 and any("repeat" in w for w in a.warnings)



@pytest.mark.parametrize("seed", range(6))
def test_duplicate_groups_are_the_pairwise_definition(seed):
    # The grouping sorts by a projection (linear-logarithmic in the poses); checked against the
    # definition compared pair by pair, on clusters jittered to either side of the tolerance and
    # on plans whose poses share coordinates exactly.
    from stewart_jax.calibration._assessment import DUPLICATE_ATOL, duplicate_rows

    tol = np.array([DUPLICATE_ATOL[0]] * 3 + [DUPLICATE_ATOL[1]] * 3)

    def pairwise(p):
        seen, groups = np.zeros(len(p), bool), []
        for i in range(len(p)):
            same = [j for j in range(len(p)) if np.all(np.abs(p[j] - p[i]) <= tol)]
            if not seen[i] and len(same) > 1:
                groups.append(same)
                seen[same] = True
        return groups

    rng = np.random.default_rng(seed)
    for _ in range(20):
        centres = rng.uniform(-1, 1, (rng.integers(1, 30), 6)) * [1, 1, 1, 1e-2, 1e-2, 1e-2]
        if seed % 2:
            centres[:, :3] = np.round(centres[:, :3], 1)
        m = int(rng.integers(2, 120))
        steps = rng.choice([0.0, 0.5, 0.99, 1.0, 1.01, 2.0], (m, 6)) * rng.choice([-1, 1], (m, 6))
        p = centres[rng.integers(0, len(centres), m)] + steps * tol * rng.integers(0, 2, (m, 1))
        assert duplicate_rows(p) == pairwise(p)

# ---- class 5: jitted kinematics ---------------------------------------------------------------


@pytest.mark.parametrize("name", ["nominal", "rubin_m2"])
def test_jitted_inverse_kinematics_never_calls_a_bad_pose_reachable(name):
    m = sj.mechanism.preset(name)
    poses = jnp.array([[0, 0, 0, 0, 0, 0.0], [0, 0, jnp.nan, 0, 0, 0], [0, 0, 0, 30.0, 0, 0],
                       [0, 0, 0, 0, 0, jnp.inf]])
    for f in (m.solve_inverse_kinematics, jax.jit(lambda p: m.solve_inverse_kinematics(p))):
        assert np.asarray(f(poses).reachable).tolist() == [True, False, False, False]
    with pytest.raises(Exception, match="invalid one"):
        jax.block_until_ready(jax.jit(lambda p: sj.inverse_kinematics(m, p))(poses))


# ---- class 6: messages that name the problem --------------------------------------------------


def test_bad_files_and_settings_are_named(measured, tmp_path, capsys):
    data, csv_path = measured
    listed = tmp_path / "list.json"
    listed.write_text("[1, 2]")
    broken = tmp_path / "broken.json"
    broken.write_text('{"upper": [')
    repeated = tmp_path / "repeated.csv"
    text = open(csv_path).read().split("\n", 1)
    repeated.write_text(text[0].replace("q2", "q1") + "\n" + text[1])
    latin = tmp_path / "latin.csv"
    latin.write_bytes("q1,q2\n\xb5m,1\n".encode("latin-1"))
    cases = [
        (["calibrate", str(tmp_path)], "is a folder"),
        (["calibrate", csv_path, "--geometry", str(listed)], "list.json"),
        (["calibrate", csv_path, "--geometry", str(broken)], "broken.json"),
        (["calibrate", str(latin)], "not UTF-8"),
        (["calibrate", str(repeated)], "more than once"),
        (["calibrate", csv_path, "--sigma-um", "-1"], "--sigma-um"),
        (["calibrate", csv_path, "--max-steps", "0"], "--max-steps"),
        (["study", "--trials", "0"], "n_trials"),
        (["study", "--chunk", "-1"], "chunk_size"),
        (["study", "--devices", "0"], "n_devices"),
        (["study", "--methods", ","], "methods"),
    ]
    for argv, message in cases:
        rc, _, err = run(argv, capsys)
        assert rc == 2 and message in err and "Traceback" not in err, (argv, err)


def test_excel_csv_with_byte_order_mark_reads(measured, tmp_path):
    data, csv_path = measured
    bom = tmp_path / "bom.csv"
    bom.write_bytes(b"\xef\xbb\xbf" + open(csv_path, "rb").read())
    np.testing.assert_array_equal(np.asarray(read_csv(bom).readings), np.asarray(read_csv(csv_path).readings))


# ---- fuzz: random corruptions of valid CSV and geometry files ---------------------------------


def _corrupt(text: str, rng: np.random.Generator) -> str:
    kind = rng.integers(6)
    i = int(rng.integers(len(text)))
    if kind == 0:  # delete a span
        return text[:i] + text[i + int(rng.integers(1, 20)):]
    if kind == 1:  # replace a character
        return text[:i] + rng.choice(list(string.printable + "\u00b5\u00b0")) + text[i + 1:]
    if kind == 2:  # truncate
        return text[:i]
    if kind == 3:  # duplicate a line
        lines = text.splitlines(keepends=True)
        j = int(rng.integers(len(lines)))
        return "".join(lines[:j + 1] + lines[j:])
    if kind == 4:  # a number becomes nan / inf / a huge value
        return text.replace(",", f",{rng.choice(['nan', 'inf', '1e300', '-0', ''])}", 1) if rng.random() < 0.5 \
            else text[:i] + "nan" + text[i:]
    return text[:i] + "," + text[i:]  # an extra cell


def test_fuzzed_files_give_a_clean_error_or_a_correct_result(measured, tmp_path):
    data, csv_path = measured
    csv_text = open(csv_path).read()
    geo_text = json.dumps(sj.mechanism.preset("rubin_m2").to_dict(), indent=1)
    rng = np.random.default_rng(2026)
    outcomes = {"error": 0, "ok": 0}
    for k in range(150):
        path = tmp_path / f"f{k}.csv"
        path.write_text(_corrupt(csv_text, rng))
        try:
            d = read_csv(path)
        except ValueError:
            outcomes["error"] += 1
            continue
        assert np.all(np.isfinite(np.asarray(d.readings))) and np.all(np.isfinite(np.asarray(d.poses)))
        outcomes["ok"] += 1
    for k in range(150):
        path = tmp_path / f"g{k}.json"
        path.write_text(_corrupt(geo_text, rng))
        try:
            m = load_mechanism(path)
        except (ValueError, FileNotFoundError):
            outcomes["error"] += 1
            continue
        assert np.all(np.isfinite(np.asarray(m.params)))
        assert mechanism_from_dict(m.to_dict()).to_dict() == m.to_dict()  # a correct, loadable geometry
        outcomes["ok"] += 1
    assert outcomes["error"] > 50 and outcomes["ok"] > 20, outcomes  # both branches exercised
