"""The study's checkpoint file: every trial's result stored under its index, with the study's
configuration hashed, read back with each record checked, and written atomically under a lock
(see :func:`~stewart_jax.study.run_study`)."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
from typing import Any

import numpy as np

from .._files import write_text_atomic

PER_TRIAL_KEYS = ("calibration", "validation", "fk_ok", "cost", "n_evaluations", "status", "history_cost",
                  "history_evaluations")
"""What a checkpoint stores for each trial (under its index)."""
_CHECKPOINT_VERSION = 2
_NOT_HASHED = ("n_trials", "first_trial")  # trials are stored by index: a run may extend or split a study


def _config_hash(config: dict[str, Any]) -> str:
    hashed = {k: v for k, v in config.items() if k not in _NOT_HASHED}
    return hashlib.sha256(json.dumps(hashed, sort_keys=True).encode()).hexdigest()[:16]


def _read_checkpoint(path: str, config: dict[str, Any]) -> dict[str, Any]:
    """The trials and chunk times of the checkpoint at ``path`` (empty when there is none),
    refusing a file of another run, one that is not a checkpoint, or a damaged trial record."""
    if not os.path.exists(path):
        return {"trials": {}, "seconds": {}}
    try:
        with open(path, encoding="utf-8") as f:
            ck = json.load(f)
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ValueError(f"checkpoint {path} is not a readable study checkpoint ({e}); delete it to start over") from e
    if not isinstance(ck, dict) or ck.get("version") != _CHECKPOINT_VERSION or not isinstance(ck.get("trials"), dict):
        raise ValueError(
            f"checkpoint {path} is not a study checkpoint of this version (expected an object with "
            f"'version': {_CHECKPOINT_VERSION} and 'trials'); delete it or use another path"
        )
    if ck.get("config_hash") != _config_hash(config):
        raise ValueError(
            f"checkpoint {path} was written by a run with other settings; delete it or use another path"
        )
    seconds = ck.get("seconds", {})
    if not isinstance(seconds, dict) or not all(
        isinstance(v, list) and all(_is_number(x) for x in v) for v in seconds.values()
    ):
        raise ValueError(f"checkpoint {path}: its 'seconds' entry is damaged (expected lists of chunk times "
                         "per method); delete the file to start over")
    for method, trials in ck["trials"].items():
        if not isinstance(trials, dict):
            raise ValueError(f"checkpoint {path}: the trials of method {method!r} are not an object of trial "
                             "records; delete that method's entry (or the file) and run again to recompute them")
        history = None
        for index, record in trials.items():
            _check_record(path, method, index, record, history)
            history = len(record["history_cost"])
    return {"trials": ck["trials"], "seconds": seconds}


def _is_number(x: Any) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool)


def _check_record(path: str, method: str, index: str, record: Any, history_length: int | None) -> None:
    """Raise one ``ValueError`` naming the trial, the fault and the remedy unless ``record``
    holds every value a trial stores, each of its shape, with finite control errors."""
    problem = _record_problem(index, record, history_length)
    if problem:
        raise ValueError(
            f"checkpoint {path}: the record of trial {index} of method {method!r} is damaged ({problem}); "
            f"delete that record (the key \"{index}\" under \"trials\" → \"{method}\") or the whole file, "
            "and run again: the study recomputes exactly the trials the file lacks")


def _record_problem(index: str, record: Any, history_length: int | None) -> str | None:
    if not (isinstance(index, str) and index.isdigit()):
        return "its key is not a trial index (a whole number >= 0)"
    if not isinstance(record, dict):
        return f"it is a {type(record).__name__}, not an object"
    missing = [k for k in PER_TRIAL_KEYS if k not in record]
    if missing:
        return f"missing {missing}"
    for key in ("calibration", "validation"):
        v = record[key]
        if not (isinstance(v, list) and len(v) == 6 and all(_is_number(x) for x in v)):
            return f"'{key}' must be six numbers (µm, µm, µm, ″, ″, ″), got {v!r}"
        if record["fk_ok"] is True and not all(np.isfinite(v)):
            return f"'{key}' holds NaN or infinity: {v!r}"
    if not isinstance(record["fk_ok"], bool):
        return f"'fk_ok' must be true or false, got {record['fk_ok']!r}"
    if not _is_number(record["cost"]) or np.isnan(record["cost"]):
        return f"'cost' must be a number, got {record['cost']!r}"
    for key in ("n_evaluations", "status"):
        if not (isinstance(record[key], int) and not isinstance(record[key], bool) and record[key] >= 0):
            return f"'{key}' must be a whole number >= 0, got {record[key]!r}"
    hc, he = record["history_cost"], record["history_evaluations"]
    if not (isinstance(hc, list) and all(_is_number(x) for x in hc)):
        return "'history_cost' must be a list of numbers"
    if not (isinstance(he, list) and len(he) == len(hc) and all(_is_number(x) for x in he)):
        return "'history_evaluations' must be a list of numbers as long as 'history_cost'"
    if history_length is not None and len(hc) != history_length:
        return f"its history has {len(hc)} entries, the method's other trials {history_length}"
    return None


def _load_checkpoint(path: str | None, config: dict[str, Any]) -> dict[str, Any]:
    """``{"trials": {method: {index: result}}, "seconds": {method: [...]}}`` from ``path``
    (empty when there is none), refusing a file of another run, one that is not a checkpoint
    or a damaged trial record."""
    if path is None:
        return {"trials": {}, "seconds": {}}
    with _checkpoint_lock(path):
        return _read_checkpoint(path, config)


@contextlib.contextmanager
def _checkpoint_lock(path: str):
    """An exclusive lock on ``path + ".lock"`` (``fcntl.lockf``: POSIX record locks, which NFS
    carries between hosts) for a read–merge–write of the checkpoint; waits for the holder."""
    import fcntl

    with open(f"{path}.lock", "a") as f:
        fcntl.lockf(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.lockf(f, fcntl.LOCK_UN)


def _save_checkpoint(path: str | None, config: dict[str, Any], state: dict[str, Any],
                     new_seconds: dict[str, list[float]]) -> None:
    """Merge this run's trials into the file at ``path`` under the lock and write it atomically.

    NOTE: hosts (or processes) that share one checkpoint each re-read it under the lock and add
    their own trials, so no host's write drops another's finished trials; a trial in both keeps
    the file's record (same key, same numbers to rounding). ``new_seconds`` (this run's chunk
    times not yet saved) are appended to the file's and then emptied."""
    if path is None:
        return
    with _checkpoint_lock(path):
        disk = _read_checkpoint(path, config)
        for method, trials in disk["trials"].items():
            mine = state["trials"].setdefault(method, {})
            for index, record in trials.items():
                mine.setdefault(index, record)
        for method, secs in new_seconds.items():
            disk["seconds"].setdefault(method, []).extend(secs)
            secs.clear()
        state["seconds"] = disk["seconds"]
        write_text_atomic(path, json.dumps({"version": _CHECKPOINT_VERSION, "config_hash": _config_hash(config),
                                            "config": config, "trials": state["trials"],
                                            "seconds": state["seconds"]}))
