import numpy as np
import pytest

import stewart_jax as sj


def _data(m=7, seed=0, extras=True):
    rng = np.random.default_rng(seed)
    return sj.calibration.make_calibration_data(
        rng.normal(size=(m, 6)),
        np.concatenate([rng.uniform(-1, 1, (m, 3)), rng.uniform(-0.017, 0.017, (m, 3))], axis=1),
        rng.choice([-1.0, 1.0], (m, 6)) if extras else None,
        rng.uniform(18, 22, m) if extras else None,
        np.cumsum(rng.uniform(1, 5, m)) if extras else None,
    )


def test_csv_round_trip_is_lossless(tmp_path):
    data = _data()
    path = tmp_path / "d.csv"
    sj.write_csv(path, data)
    back = sj.read_csv(path)
    for a, b in zip(data, back, strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    header = path.read_text().splitlines()[0].split(",")
    assert header[:12] == ["q1", "q2", "q3", "q4", "q5", "q6", "x", "y", "z", "rx", "ry", "rz"]
    # Angles are stored in degrees (SPEC §6), independently of the reader:
    row = path.read_text().splitlines()[1].split(",")
    assert float(row[9]) == pytest.approx(np.degrees(float(np.asarray(data.poses)[0, 3])), rel=1e-15)


def test_csv_without_optional_columns(tmp_path):
    data = _data(extras=False)
    path = tmp_path / "d.csv"
    sj.write_csv(path, data, extra={"note_a,note_b": np.ones((7, 2))})
    back = sj.read_csv(path)
    assert back.directions is None and back.temperature is None and back.time is None
    np.testing.assert_array_equal(back.readings, data.readings)


def _write(path, header, rows):
    path.write_text("\n".join([",".join(header)] + [",".join(map(str, r)) for r in rows]) + "\n")


HEADER = ["q1", "q2", "q3", "q4", "q5", "q6", "x", "y", "z", "rx", "ry", "rz"]


def test_missing_column(tmp_path):
    p = tmp_path / "bad.csv"
    _write(p, HEADER[:-1], [[0.0] * 11] * 8)
    with pytest.raises(ValueError, match=r"missing column\(s\) \['rz'\]"):
        sj.read_csv(p)


def test_nan_and_text_cells(tmp_path):
    p = tmp_path / "bad.csv"
    _write(p, HEADER, [[0.0] * 12, [0.0] * 4 + ["nan"] + [0.0] * 7])
    with pytest.raises(ValueError, match="'q5' has NaN"):
        sj.read_csv(p)
    _write(p, HEADER, [[0.0] * 12, [0.0] * 6 + ["abc"] + [0.0] * 5])
    with pytest.raises(ValueError, match="line 3, column 'x'"):
        sj.read_csv(p)


def test_angles_beyond_ten_degrees_are_flagged(tmp_path):
    p = tmp_path / "bad.csv"
    _write(p, HEADER, [[0.0] * 9 + [0.5, 57.3, 0.0]])
    with pytest.raises(ValueError, match="'ry'.*degrees.*radians"):
        sj.read_csv(p)


def test_bad_directions(tmp_path):
    p = tmp_path / "bad.csv"
    _write(p, HEADER + [f"dir{i}" for i in range(1, 7)], [[0.0] * 12 + [1, -1, 1, 0, 1, 1]])
    with pytest.raises(ValueError, match=r"\+1 or -1"):
        sj.read_csv(p)
