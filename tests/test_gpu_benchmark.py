"""``benchmarks/gpu.py`` runs where there is no GPU, at a small size, and says that its figures
are not GPU figures."""

import json
import sys
from pathlib import Path

import jax
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]

# The slow tier (make test-all runs it, make test does not): two batch sizes compiled, 20 s.
pytestmark = pytest.mark.slow


def test_the_gpu_benchmark_runs_on_the_cpu_and_says_so(tmp_path):
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        import gpu
    finally:
        sys.path.pop(0)
    assert gpu.main(["--quick", "--batches", "2,3", "--repeats", "1", "--out", str(tmp_path)]) == 0
    backend = jax.default_backend()
    report = json.loads((tmp_path / f"gpu_{backend}_quick.json").read_text())
    assert report["gpu_figures"] == (backend == "gpu")
    rows = report["rows"]["paper8"]
    assert [r["batch"] for r in rows] == [2, 3]
    for r in rows:
        assert r["calibrations_per_s"] == pytest.approx(r["batch"] / r["warm_s"])
        assert r["first_call_s"] >= r["warm_s"] > 0
        # the paper's noise (0.1 µm, 0.1″) on 8 poses: every calibration converges, to a cost
        # of the order of 48 readings × (0.1 µm)² = 4.8e-7 mm², far below the nominal's
        assert r["success_share"] == 1.0 and 0 < r["median_cost_mm2"] < 1e-5
    md = (tmp_path / f"gpu_{backend}_quick.md").read_text()
    assert ("No GPU figure exists yet" in md) == (backend != "gpu")
    assert np.isfinite(report["reference"]["gpufit_fits_per_s"])
