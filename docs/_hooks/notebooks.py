"""MkDocs hook: the notebooks of ``notebooks/`` as pages of the site, with their outputs.

The notebooks are jupytext percent-format ``.py`` files without stored outputs (see
``notebooks/README.md``). At every build this hook reads each one with jupytext, executes it in
quick mode (``STEWART_JAX_QUICK=1``: small sizes, and no figure is written to
``notebooks/figures``), writes the executed ``.ipynb`` and adds it to the site as
``notebooks/<name>.ipynb``; mkdocs-jupyter renders it, figures included. A notebook that raises
fails the build (nbclient's ``CellExecutionError`` names the cell).

NOTE: the notebooks run one after the other in ONE Jupyter kernel, whose namespace is reset
between them, not in one kernel each. They calibrate, simulate and fit at the same shapes, and
JAX compilation is most of their run time: one process compiles each program once, as the test
suite did when it ran them in-process with ``runpy``. After each notebook the kernel reports the
matplotlib figures still open (every figure should go through ``stewart_jax.plotting.show``,
which closes it); the list is stored in the executed notebook's metadata, under
``stewart_jax_docs``, with the run time and the cache key, for ``tests/test_docs.py``.

Settings, by environment variable:

- ``STEWART_JAX_DOCS_NOTEBOOKS``: the folder of the executed notebooks, ``<folder>/notebooks/
  <name>.ipynb`` (default ``build/docs-notebooks``). An executed notebook there whose key (the notebook's text, the
  package's sources, the mode) matches is reused instead of run again, so that ``mkdocs serve``
  rebuilds quickly.
- ``STEWART_JAX_DOCS_EXECUTE=0``: render the notebooks without running them (no outputs).
"""

from __future__ import annotations

import hashlib
import logging
import os
import tempfile
import time
from pathlib import Path

from mkdocs.plugins import event_priority
from mkdocs.structure.files import File, Files

log = logging.getLogger("mkdocs.hooks.notebooks")

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOKS = ROOT / "notebooks"
PACKAGE = ROOT / "stewart_jax"
SITE_FOLDER = "notebooks"
METADATA_KEY = "stewart_jax_docs"
CELL_TIMEOUT_S = 1800

# Run after each notebook: report the figures left open, then empty the namespace (imported
# modules, and with them JAX's compiled programs, stay loaded).
_AFTER_NOTEBOOK = "import matplotlib.pyplot as _plt\nprint(sorted(_plt.get_fignums()))\n%reset -f\n"


def notebook_sources() -> list[Path]:
    """The notebooks, ``notebooks/NN_name.py``, in order."""
    return sorted(NOTEBOOKS.glob("[0-9][0-9]_*.py"))


def output_folder() -> Path:
    return Path(os.environ.get("STEWART_JAX_DOCS_NOTEBOOKS") or ROOT / "build" / "docs-notebooks")


def _execute_enabled() -> bool:
    return os.environ.get("STEWART_JAX_DOCS_EXECUTE", "1") != "0"


def _key(path: Path, execute: bool) -> str:
    h = hashlib.sha256()
    h.update(f"quick={execute}\n".encode())
    h.update(path.read_bytes())
    for src in sorted(PACKAGE.rglob("*.py")):
        h.update(src.relative_to(PACKAGE).as_posix().encode())
        h.update(src.read_bytes())
    return h.hexdigest()


def _cached(target: Path, key: str) -> bool:
    if not target.exists():
        return False
    import nbformat

    try:
        nb = nbformat.read(target, as_version=4)
    except Exception:  # a damaged cache entry is simply run again
        return False
    return nb.metadata.get(METADATA_KEY, {}).get("key") == key


def _kernel_env(workdir: Path) -> dict[str, str]:
    env = dict(os.environ)
    env["STEWART_JAX_QUICK"] = "1"
    env["STEWART_JAX_OUT"] = os.fspath(workdir)
    # The notebooks' own inputs (05 writes a demonstration pair when they are unset) and the
    # backend: the kernel's inline backend is what puts the figures into the page, so a
    # MPLBACKEND=Agg inherited from a test run must not reach it.
    for var in ("STEWART_JAX_GEOMETRY", "STEWART_JAX_CSV", "STEWART_JAX_FIGURES", "MPLBACKEND"):
        env.pop(var, None)
    # PYTHONPATH as given, plus the repository, so that the kernel imports this checkout.
    env["PYTHONPATH"] = os.pathsep.join(p for p in (os.fspath(ROOT), env.get("PYTHONPATH", "")) if p)
    return env


def _run(pending: list[tuple[Path, Path, str]]) -> None:
    """Execute the notebooks ``(source, target, key)`` in one kernel and write them."""
    import jupytext
    import nbformat
    from nbclient import NotebookClient

    with tempfile.TemporaryDirectory(prefix="stewart-jax-docs-") as tmp:
        workdir = Path(tmp)
        first = jupytext.read(pending[0][0])
        client = NotebookClient(
            first, timeout=CELL_TIMEOUT_S, kernel_name="python3", resources={"metadata": {"path": tmp}}
        )
        with client.setup_kernel(env=_kernel_env(workdir)):
            for source, target, key in pending:
                nb = first if source == pending[0][0] else jupytext.read(source)
                client.nb = nb
                client.reset_execution_trackers()
                log.info("executing %s (quick mode)", source.name)
                start = time.perf_counter()
                for index, cell in enumerate(nb.cells):
                    client.execute_cell(cell, index, execution_count=client.code_cells_executed + 1)
                seconds = time.perf_counter() - start
                check = nbformat.v4.new_code_cell(_AFTER_NOTEBOOK)
                nb.cells.append(check)  # nbclient stores a cell's outputs by its index
                try:
                    client.execute_cell(check, len(nb.cells) - 1, store_history=False)
                finally:
                    nb.cells.pop()
                printed = "".join(o.get("text", "") for o in check.outputs if o.output_type == "stream")
                nb.metadata[METADATA_KEY] = {
                    "key": key,
                    "seconds": round(seconds, 1),
                    "open_figures": printed.strip(),
                }
                nb.metadata.setdefault("language_info", {"name": "python"})
                target.parent.mkdir(parents=True, exist_ok=True)
                tmp_target = target.with_suffix(".ipynb.partial")
                nbformat.write(nb, tmp_target)
                os.replace(tmp_target, target)
                log.info("executed %s in %.1f s", source.name, seconds)


def prepare_notebooks(out: Path | None = None) -> list[Path]:
    """Write the executed (or, with ``STEWART_JAX_DOCS_EXECUTE=0``, unexecuted) notebooks to
    ``out`` and return their paths; notebooks whose cached copy is current are not run again."""
    import jupytext
    import nbformat

    out = output_folder() if out is None else out
    execute = _execute_enabled()
    targets, pending = [], []
    for source in notebook_sources():
        target = out / SITE_FOLDER / f"{source.stem}.ipynb"
        key = _key(source, execute)
        targets.append(target)
        if _cached(target, key):
            continue
        if execute:
            pending.append((source, target, key))
        else:
            nb = jupytext.read(source)
            nb.metadata[METADATA_KEY] = {"key": key, "seconds": None, "open_figures": None}
            target.parent.mkdir(parents=True, exist_ok=True)
            nbformat.write(nb, target)
    if pending:
        _run(pending)
    return targets


@event_priority(50)  # before mkdocs-jupyter turns the .ipynb files into pages
def on_files(files: Files, config) -> Files:
    out = output_folder()
    for path in prepare_notebooks(out):
        files.append(
            File(
                path.relative_to(out).as_posix(),
                src_dir=os.fspath(out),
                dest_dir=config["site_dir"],
                use_directory_urls=config["use_directory_urls"],
            )
        )
    return files
