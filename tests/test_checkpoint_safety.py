"""No finished trial of a study is ever lost, and no damaged record is ever used.

Each test names the class of input it stands for: hosts sharing one checkpoint file (two real
processes at once), two outputs at one path, damaged trial records. Checked through the command
line and the public ``run_study``; the shared checkpoint comes from one module-scoped pair of
real ``stewart-jax study`` processes (Cuckoo Search on a 50-evaluation budget: what is tested is
the file, not the method).
"""

import json
import os
import subprocess
import sys
import textwrap

import pytest

import stewart_jax.study as study
from stewart_jax._cli import main

STUDY = ["study", "--methods", "cs", "--max-evaluations", "50", "--seed", "4"]
LIBRARY = {"methods": ("cs",), "seed": 4, "method_options": {"cs": {"max_evaluations": 50}}}


def _cli(*argv):
    env = dict(os.environ, JAX_PLATFORMS="cpu")
    return subprocess.Popen([sys.executable, "-m", "stewart_jax", *argv], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)


@pytest.fixture(scope="module")
def shared(tmp_path_factory):
    """Class: two hosts run their own trial ranges at the same time into ONE checkpoint path
    (the multi-host recipe); before the fix the later writer dropped the other's trials."""
    folder = tmp_path_factory.mktemp("hosts")
    ck = str(folder / "shared.json")
    procs = [_cli(*STUDY, "--trials", "1", "--first-trial", str(i), "--checkpoint", ck) for i in (0, 1)]
    for p in procs:
        _, err = p.communicate(timeout=600)
        assert p.returncode == 0, err[-3000:]
    return ck


def test_two_hosts_sharing_one_checkpoint_keep_every_trial(shared, capsys, tmp_path):
    with open(shared) as f:
        ck = json.load(f)
    for method in ("before", "cs"):
        assert sorted(ck["trials"][method]) == ["0", "1"], ck["trials"][method].keys()
    assert len(ck["seconds"]["cs"]) == 2  # one chunk per host, both kept
    # the recipe's last step: one run over the whole range computes nothing and reports both
    out = tmp_path / "all.json"
    assert main([*STUDY, "--trials", "2", "--checkpoint", shared, "--json", str(out)]) == 0
    assert "cs: trials" not in capsys.readouterr().err  # no chunk was run again
    rows = {r["method"]: r for r in json.loads(out.read_text())["rows"].values()}
    assert sum(rows["cs"]["status_counts"].values()) == 2


def test_many_concurrent_saves_lose_nothing(tmp_path):
    """Class: hosts finishing chunks at the same instant. Two real processes each save 25 trials
    one at a time into one file as fast as they can; all 50 survive."""
    ck = str(tmp_path / "race.json")
    child = textwrap.dedent("""
        import sys
        from stewart_jax.study._study import _save_checkpoint
        first, path = int(sys.argv[1]), sys.argv[2]
        config = {"plan": "paper8"}
        rec = {"calibration": [0.1] * 6, "validation": [0.2] * 6, "fk_ok": True, "cost": 1e-6, "n_evaluations": 3,
               "status": 0, "history_cost": [1.0, 0.5], "history_evaluations": [1, 2]}
        state = {"trials": {}, "seconds": {}}
        for i in range(first, first + 25):
            state["trials"].setdefault("lm", {})[str(i)] = rec
            _save_checkpoint(path, config, state, {"lm": [0.01]})
    """)
    procs = [subprocess.Popen([sys.executable, "-c", child, str(first), ck], stderr=subprocess.PIPE, text=True)
             for first in (0, 100)]
    for p in procs:
        _, err = p.communicate(timeout=300)
        assert p.returncode == 0, err[-3000:]
    with open(ck) as f:
        saved = json.load(f)
    assert sorted(saved["trials"]["lm"], key=int) == [str(i) for i in (*range(25), *range(100, 125))]
    assert len(saved["seconds"]["lm"]) == 50


def _numbers(path):
    rows = json.loads(path.read_text())["rows"]
    keys = ("calibration", "validation", "cost_median", "cost_p90", "status_counts", "n_evaluations_median")
    return {name: {k: row[k] for k in keys} for name, row in rows.items()}


@pytest.mark.slow  # a study killed, resumed and run again uninterrupted: 4 min on the loaded 2-core machine
def test_a_study_killed_with_sigkill_loses_at_most_the_chunk_in_flight(tmp_path, capsys):
    """Class: ``kill -9`` (no handler runs) at a moment between and during chunk writes. The
    checkpoint is a whole JSON file with every finished trial, and the resumed run's numbers are
    the uninterrupted run's."""
    import signal
    import time

    ck = tmp_path / "ck.json"
    argv = [*STUDY, "--trials", "6", "--chunk", "1"]
    proc = _cli(*argv, "--checkpoint", str(ck))
    kept: dict = {}
    deadline = time.monotonic() + 600
    while time.monotonic() < deadline and proc.poll() is None:
        try:
            kept = json.loads(ck.read_text())["trials"].get("cs", {})
        except (OSError, ValueError):  # not written yet; a half-written file would fail below
            pass
        if len(kept) >= 2:
            break
        time.sleep(0.02)
    assert proc.poll() is None, "the study finished before it could be killed: " + proc.stderr.read()[-2000:]
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=60)
    saved = json.loads(ck.read_text())  # whole, never a torn write
    n_kept = len(saved["trials"]["cs"])
    assert 2 <= n_kept < 6, n_kept
    resumed, whole = tmp_path / "resumed.json", tmp_path / "whole.json"
    assert main([*argv, "--checkpoint", str(ck), "--json", str(resumed)]) == 0
    err = capsys.readouterr().err
    assert f"kept {n_kept}/6 trials of cs" in err, err
    assert main([*argv, "--json", str(whole)]) == 0
    assert _numbers(resumed) == _numbers(whole)


@pytest.mark.parametrize("second", ["--json", "--plot"])
def test_checkpoint_and_another_output_at_one_path_are_refused_before_work(shared, capsys, second):
    """Class: two outputs at one path (the result would replace the checkpoint)."""
    before = open(shared, "rb").read()
    rc = main([*STUDY, "--trials", "3", "--checkpoint", shared, second, shared])
    err = capsys.readouterr().err
    assert rc == 2 and "same file" in err and "simulation study" not in err, err
    assert open(shared, "rb").read() == before


def test_an_output_over_an_input_is_refused(tmp_path, capsys):
    """Class: an output path that is an input file (a geometry overwritten by the export)."""
    geometry = tmp_path / "g.json"
    assert main(["export", "rubin_m2", "--out", str(geometry)]) == 0
    text = geometry.read_text()
    assert main(["simulate", "--geometry", str(geometry), "--out", str(geometry)]) == 2
    assert "is the input --geometry" in capsys.readouterr().err and geometry.read_text() == text


def _damage(record):
    record = dict(record)
    del record["calibration"]
    return record


@pytest.mark.parametrize("damage, says", [
    (_damage, "missing ['calibration']"),                                                   # a key lost
    (lambda r: {**r, "validation": [[1.0, 2.0], [3.0]]}, "'validation' must be six numbers"),  # wrong shape
    (lambda r: {**r, "calibration": [float("nan")] * 6}, "NaN"),                            # NaNs
    (lambda r: {**r, "status": "ok"}, "'status'"),                                          # wrong type
    (lambda r: {**r, "history_cost": r["history_cost"][:-1]}, "history"),                   # ragged history
    (lambda r: [1, 2, 3], "not an object"),                                                  # not a record
])
def test_a_damaged_trial_record_is_named_with_advice_and_never_used(shared, tmp_path, damage, says):
    """Class: a damaged record in an otherwise valid checkpoint: one error naming the trial and
    the remedy, before any work — never a traceback, never silently used."""
    with open(shared) as f:
        ck = json.load(f)
    ck["trials"]["cs"]["1"] = damage(ck["trials"]["cs"]["1"])
    path = tmp_path / "damaged.json"
    path.write_text(json.dumps(ck))
    with pytest.raises(ValueError) as e:
        study.run_study(n_trials=2, checkpoint=str(path), log=lambda s: pytest.fail(f"work started: {s}"), **LIBRARY)
    message = str(e.value)
    assert "trial 1 of method 'cs'" in message and says in message and "delete that record" in message, message


def test_a_damaged_record_through_the_command_line_is_one_line(shared, tmp_path, capsys):
    with open(shared) as f:
        ck = json.load(f)
    ck["trials"]["before"]["0"] = _damage(ck["trials"]["before"]["0"])
    path = tmp_path / "damaged.json"
    path.write_text(json.dumps(ck))
    assert main([*STUDY, "--trials", "2", "--checkpoint", str(path)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "trial 0 of method 'before'" in err and "run again" in err
