"""Every notebook under ``notebooks/`` runs top to bottom in quick mode.

The notebooks are jupytext percent-format ``.py`` files (markdown cells are comments), so each
is executed as a script with ``runpy`` inside this process, with ``STEWART_JAX_QUICK=1`` and
the Agg backend. In-process rather than through a Jupyter kernel: the five notebooks share
JAX's compilation cache (the same calibrations, simulations and fits at the same shapes), and
compilation is most of their run time. A separate cheap test checks that jupytext reads each
file as a notebook with the expected cells (what ``jupytext --to ipynb`` produces).
"""

from __future__ import annotations

import os
import runpy
from pathlib import Path

import pytest

NOTEBOOKS = Path(__file__).resolve().parents[1] / "notebooks"
FILES = sorted(NOTEBOOKS.glob("[0-9][0-9]_*.py"))


def test_six_notebooks_exist():
    assert [f.name[:2] for f in FILES] == ["01", "02", "03", "04", "05", "06"]


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.stem)
def test_jupytext_pairing(path):
    jupytext = pytest.importorskip("jupytext")
    nb = jupytext.read(path)
    kinds = [c.cell_type for c in nb.cells]
    assert kinds.count("markdown") >= 2 and kinds.count("code") >= 3
    assert nb.cells[0].cell_type == "markdown" and nb.cells[0].source.startswith("# ")
    assert all("# %%" not in c.source for c in nb.cells)


def _figure_state():
    d = NOTEBOOKS / "figures"
    return {p.name: p.stat().st_mtime_ns for p in d.glob("*")} if d.exists() else {}


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.stem)
def test_notebook_runs_in_quick_mode(path, monkeypatch, tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    monkeypatch.setenv("STEWART_JAX_QUICK", "1")
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.setenv("STEWART_JAX_OUT", str(tmp_path))
    for var in ("STEWART_JAX_GEOMETRY", "STEWART_JAX_CSV", "STEWART_JAX_FIGURES"):
        monkeypatch.delenv(var, raising=False)
    monkeypatch.chdir(tmp_path)
    before = _figure_state()
    runpy.run_path(os.fspath(path), run_name="__main__")
    assert _figure_state() == before, "quick mode must not write the published figures"
    assert plt.get_fignums() == [], "every figure is shown (and closed) with plotting.show"
