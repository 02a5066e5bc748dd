"""The documentation site: ``mkdocs build --strict`` succeeds, every API entry is rendered, and the
six notebooks are rendered executed, with their figures (``tests/test_api_docs.py`` checks, without
a build, that every public name has an entry in the API reference).

The strict build is the one place where the test suite executes the notebooks
(``tests/test_notebooks.py`` checks their jupytext form only): the build's notebook hook runs them
in quick mode (``STEWART_JAX_QUICK=1``) in one shared Jupyter kernel, writes the executed
notebooks to a folder this test chooses, and the tests below check those outputs — what the
notebook test used to check after running each one with ``runpy``: no error, no figure written
to ``notebooks/figures``, every figure shown and closed — and that their figures reach the pages.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

# The slow tier (make test-all runs it, make test does not): the strict documentation build, which executes
# every notebook (6 min on 2 cores).
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
API = ROOT / "docs" / "api"
NOTEBOOKS = ROOT / "notebooks"


# --- the strict build, with the notebooks executed ----------------------------------------------------------


def _figure_state() -> dict[str, int]:
    folder = NOTEBOOKS / "figures"
    return {p.name: p.stat().st_mtime_ns for p in folder.glob("*")} if folder.exists() else {}


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("docs")
    env = dict(os.environ)
    env.pop("STEWART_JAX_DOCS_EXECUTE", None)
    env.update(STEWART_JAX_DOCS_NOTEBOOKS=os.fspath(tmp / "executed"), NO_MKDOCS_2_WARNING="1")
    before = _figure_state()
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-f", os.fspath(ROOT / "mkdocs.yml"),
         "-d", os.fspath(tmp / "site")],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=1500,
    )
    assert proc.returncode == 0, f"mkdocs build --strict failed:\n{proc.stderr[-6000:]}"
    return SimpleNamespace(site=tmp / "site", executed=tmp / "executed" / "notebooks", log=proc.stderr,
                           figures_before=before, figures_after=_figure_state())


def test_strict_build_has_no_warning(built):
    assert not re.search(r"^WARNING\s+-", built.log, flags=re.M), built.log[-4000:]


def test_every_api_entry_is_rendered(built):
    pages = {p.stem: (built.site / "api" / ("" if p.stem == "index" else p.stem) / "index.html").read_text(
        encoding="utf-8") for p in API.glob("*.md")}
    for page in API.glob("*.md"):
        html = pages[page.stem]
        for ident in re.findall(r"^::: (\S+)\s*$", page.read_text(encoding="utf-8"), flags=re.M):
            assert f'id="{ident}"' in html, f"{ident} is not rendered on api/{page.stem}"
    # A signature with its annotations, and the docstring's units, reach the page.
    assert "solve_inverse_kinematics" in pages["mechanism"] and "Float[Array" in pages["mechanism"]


NOTEBOOK_FILES = sorted(NOTEBOOKS.glob("[0-9][0-9]_*.py"))


@pytest.mark.parametrize("path", NOTEBOOK_FILES, ids=lambda p: p.stem)
def test_notebook_executed_in_quick_mode(built, path):
    nb = json.loads((built.executed / f"{path.stem}.ipynb").read_text(encoding="utf-8"))
    meta = nb["metadata"]["stewart_jax_docs"]
    assert meta["seconds"] is not None, "the notebook was not executed"
    code = [c for c in nb["cells"] if c["cell_type"] == "code"]
    assert all(c.get("execution_count") for c in code), "every code cell ran"
    outputs = [o for c in code for o in c["outputs"]]
    assert not [o for o in outputs if o["output_type"] == "error"]
    assert meta["open_figures"] == "[]", "every figure is shown (and closed) with plotting.show"
    assert any("image/png" in o.get("data", {}) for o in outputs), "the notebook shows its figures"
    # The rendered page embeds them.
    html = (built.site / "notebooks" / path.stem / "index.html").read_text(encoding="utf-8")
    assert "data:image/png;base64," in html


def test_quick_mode_leaves_the_published_figures(built):
    assert built.figures_after == built.figures_before, "quick mode must not write notebooks/figures"

