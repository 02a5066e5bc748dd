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
    first = study.run_study(("lm-batched",), n_trials=4, chunk_size=2, checkpoint=ck, keep_trials=True)
    lm = first["rows"]["LM (batched)"]
    assert len(lm["calibration"]["per_trial_max"]) == 4
    # LM reaches the noise floor: ~0.3 µm control error at the calibration poses (see README).
    assert np.max(lm["calibration"]["per_trial_max"]) < 2.0
    # a second host running trials 2-3 gets exactly the big run's trials 2-3
    part = study.run_study(("lm-batched",), n_trials=2, first_trial=2, keep_trials=True)["rows"]["LM (batched)"]
    for name in ("calibration", "validation"):
        np.testing.assert_array_equal(part[name]["per_trial_max"], lm[name]["per_trial_max"][2:])

    # resuming from a complete checkpoint computes nothing: no chunk reports progress
    lines: list[str] = []
    again = study.run_study(("lm-batched",), n_trials=4, chunk_size=2, checkpoint=ck, keep_trials=True,
                            log=lines.append)
    assert not [line for line in lines if ": trials" in line], lines
    assert again["rows"] == first["rows"]
    # a resumed run says what it kept
    assert f"resuming from checkpoint {ck}: kept 4/4 trials of lm-batched" in "\n".join(lines), lines
    # a changed option is refused, naming it with both values
    with pytest.raises(ValueError, match="sigma_um: checkpoint 0.1, this run 0.5"):
        study.run_study(("lm-batched",), n_trials=4, chunk_size=2, checkpoint=ck, sigma_um=0.5)

    # trials are stored by index: another chunk size resumes exactly (nothing recomputed, nothing
    # counted twice), and more trials extend the study by computing only the new ones (two, so
    # that their chunk has the shape already compiled: a batch of 2)
    lines.clear()
    rechunked = study.run_study(("lm-batched",), n_trials=4, chunk_size=3, checkpoint=ck, keep_trials=True,
                                log=lines.append)
    assert not [line for line in lines if ": trials" in line], lines
    assert rechunked["rows"] == first["rows"]
    more = study.run_study(("lm-batched",), n_trials=6, chunk_size=3, checkpoint=ck, keep_trials=True, log=lines.append)
    assert [line for line in lines if ": trials" in line] == [lines[-1]] and "for 2 trials" in lines[-1]
    got = more["rows"]["LM (batched)"]["validation"]["per_trial_max"]
    assert len(got) == 6 and got[:4] == lm["validation"]["per_trial_max"]


@pytest.mark.parametrize("content", ["[]", '{"version": 2, "config_hash": "x", "tri', "\xff\xfe", "{}"])
def test_a_damaged_checkpoint_is_named(tmp_path, content):
    ck = tmp_path / "ck.json"
    ck.write_bytes(content.encode("latin-1"))
    with pytest.raises(ValueError, match="ck.json"):
        study.run_study(("lm-batched",), n_trials=2, checkpoint=str(ck))


@pytest.mark.parametrize(
    "kwargs, message",
    [({"n_trials": 0}, "n_trials"), ({"n_trials": -2}, "n_trials"), ({"chunk_size": -1}, "chunk_size"),
     ({"n_devices": 0}, "n_devices"), ({"methods": ()}, "methods"), ({"methods": ("lm", "nope")}, "nope"),
     ({"sigma_um": -0.1}, "sigma_um"), ({"plan": "plan8"}, "plan"), ({"half_width": 0.0}, "half_width")],
)
def test_bad_study_settings_are_refused_before_any_work(kwargs, message):
    args = {"methods": ("lm-batched",), "n_trials": 2, **kwargs}
    with pytest.raises(ValueError, match=message):
        study.run_study(log=lambda s: pytest.fail(f"work started: {s}"), **args)


def test_study_command_prints_table(capsys, tmp_path):
    png = tmp_path / "t.png"
    assert main(["study", "--methods", "lm-batched", "--trials", "2", "--plot", str(png)]) == 0
    assert png.stat().st_size > 1000
    out = capsys.readouterr().out
    assert "| LM (batched) |" in out and "paper: VSA-SMCS" in out
