"""A study split over two JAX processes (``jax.distributed``, CPU, localhost) equals one process.

The recipe of the documentation: every process calls ``jax.distributed.initialize``, runs its
own range of trials (``first_trial = process_index · k``) and the per-trial lists are
concatenated in process order."""

import json
import os
import socket
import subprocess
import sys

import numpy as np
import pytest

from stewart_jax.study import run_study

# The slow tier (make test-all runs it, make test does not): two processes of a study, compared with one.
pytestmark = pytest.mark.slow

K = 1  # trials per process: each process runs its own slice of the trial sequence
# A cheap study: Cuckoo Search (Yang & Deb 2009) on a 200-evaluation budget compiles in about half
# the time of the batched LM (measured: 11 s and 20 s for one trial); what is tested is the split of
# the trials over processes, not the method.
METHOD, OPTIONS = "cs", {"cs": {"max_evaluations": 200}}

CHILD = r"""
import json, sys
import jax
jax.distributed.initialize(coordinator_address=sys.argv[1], num_processes=2, process_id=int(sys.argv[2]),
                           initialization_timeout=120)
import stewart_jax  # noqa: F401
from stewart_jax.study import run_study
k, method, options = int(sys.argv[3]), sys.argv[4], json.loads(sys.argv[5])
r = run_study((method,), n_trials=k, first_trial=jax.process_index() * k, keep_trials=True,
              n_devices=jax.local_device_count(), log=lambda s: None, method_options=options)
json.dump({"process_index": jax.process_index(), "process_count": jax.process_count(),
           "rows": {label: v["calibration"]["per_trial_max"] + v["validation"]["per_trial_max"]
                    for label, v in r["rows"].items()}}, sys.stdout)
jax.distributed.shutdown()
"""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_two_processes_equal_one():
    address = f"127.0.0.1:{_free_port()}"
    env = dict(os.environ, JAX_PLATFORMS="cpu")
    env.pop("XLA_FLAGS", None)
    procs = [subprocess.Popen([sys.executable, "-c", CHILD, address, str(i), str(K), METHOD, json.dumps(OPTIONS)],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env) for i in range(2)]
    outs = []
    for p in procs:
        # the timeout turns a coordinator that never answers into a failure, not a hang
        stdout, stderr = p.communicate(timeout=400)
        assert p.returncode == 0, stderr[-3000:]
        outs.append(json.loads(stdout))
    assert [o["process_index"] for o in outs] == [0, 1] and {o["process_count"] for o in outs} == {2}

    # The single-process reference, in chunks of K trials: the children's batch shape, smaller
    # (and quicker to compile) than one batch of 2K.
    one = run_study((METHOD,), n_trials=2 * K, chunk_size=K, keep_trials=True, log=lambda s: None,
                    method_options=OPTIONS)["rows"]
    for label, v in one.items():
        n = 2 * K
        cal = np.asarray(v["calibration"]["per_trial_max"])
        val = np.asarray(v["validation"]["per_trial_max"])
        split_cal = np.concatenate([np.asarray(o["rows"][label][:K]) for o in outs])
        split_val = np.concatenate([np.asarray(o["rows"][label][K:]) for o in outs])
        assert cal.shape == split_cal.shape == (n, 6)
        # ≤ 1e-5 µm / ″ (the bound that holds even between different batch shapes, whose vector
        # loops round differently: rounding amplified through the iterations, see test_sharding)
        np.testing.assert_allclose(split_cal, cal, rtol=0, atol=1e-5)
        np.testing.assert_allclose(split_val, val, rtol=0, atol=1e-5)
