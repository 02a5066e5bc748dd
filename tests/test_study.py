import jax
import numpy as np
import pytest

import stewart_jax.study as study
from stewart_jax._cli import main


def test_trial_keys_do_not_depend_on_the_number_of_trials():
    a = jax.random.key_data(study.trial_keys(3, 5))
    b = jax.random.key_data(study.trial_keys(3, 2))
    np.testing.assert_array_equal(a[:2], b)
    np.testing.assert_array_equal(a[3:], jax.random.key_data(study.trial_keys(3, 2, first=3)))


def test_checkpoint_resume_skips_finished_chunks(tmp_path):
    ck = str(tmp_path / "ck.json")
    first = study.run_study(("lm",), n_trials=4, chunk_size=2, checkpoint=ck, keep_trials=True)
    lm = first["rows"]["LM (optimistix)"]
    assert len(lm["calibration"]["per_trial_max"]) == 4
    # LM reaches the noise floor: ~0.3 µm control error at the calibration poses (see README).
    assert np.max(lm["calibration"]["per_trial_max"]) < 2.0
    # a second host running trials 2-3 gets exactly the big run's trials 2-3
    part = study.run_study(("lm",), n_trials=2, first_trial=2, keep_trials=True)["rows"]["LM (optimistix)"]
    for name in ("calibration", "validation"):
        np.testing.assert_array_equal(part[name]["per_trial_max"], lm[name]["per_trial_max"][2:])

    # resuming from a complete checkpoint computes nothing: no chunk reports progress
    lines: list[str] = []
    again = study.run_study(("lm",), n_trials=4, chunk_size=2, checkpoint=ck, keep_trials=True, log=lines.append)
    assert not [line for line in lines if "trials" in line], lines
    assert again["rows"] == first["rows"]
    with pytest.raises(ValueError, match="other settings"):
        study.run_study(("lm",), n_trials=4, chunk_size=2, checkpoint=ck, sigma_um=0.5)


def test_study_command_prints_table(capsys, tmp_path):
    png = tmp_path / "t.png"
    assert main(["study", "--methods", "lm", "--trials", "2", "--plot", str(png)]) == 0
    assert png.stat().st_size > 1000
    out = capsys.readouterr().out
    assert "| LM (optimistix) |" in out and "paper: VSA-SMCS" in out
