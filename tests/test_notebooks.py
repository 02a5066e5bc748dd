"""The notebooks under ``notebooks/`` are jupytext percent-format ``.py`` files that read as
notebooks with the expected cells (what ``jupytext --to ipynb`` produces).

Executing them is the documentation build's job: ``tests/test_docs.py`` builds the site with
``mkdocs build --strict``, whose notebook hook runs the six notebooks in quick mode
(``STEWART_JAX_QUICK=1``) in one shared kernel, and checks the executed outputs there (no error,
no figure written to ``notebooks/figures``, every figure shown and closed, figures on the pages).
They run once per test session, not once here and again for the site.
"""

from __future__ import annotations

from pathlib import Path

import pytest

NOTEBOOKS = Path(__file__).resolve().parents[1] / "notebooks"
FILES = sorted(NOTEBOOKS.glob("[0-9][0-9]_*.py"))


def test_six_notebooks_exist():
    assert [f.name[:2] for f in FILES] == ["01", "02", "03", "04", "05", "06"]


def test_notebook_names_do_not_name_a_seed_file():
    assert not [f.name for f in FILES if "seed" in f.name]


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.stem)
def test_jupytext_pairing(path):
    jupytext = pytest.importorskip("jupytext")
    nb = jupytext.read(path)
    kinds = [c.cell_type for c in nb.cells]
    assert kinds.count("markdown") >= 2 and kinds.count("code") >= 3
    assert nb.cells[0].cell_type == "markdown" and nb.cells[0].source.startswith("# ")
    assert all("# %%" not in c.source for c in nb.cells)
