"""The recipes of ``docs/architecture.md`` hold as written.

The page's "Recipes" section holds a family, an optimiser and a discrepancy effect as Python
blocks, each opening with the file it is (``# stewart_jax/...``) or the file it is appended to
(``# append to stewart_jax/...``). The package is copied to a temporary folder, every block is
written into the copy exactly as the page shows it, and the registry-driven tests run on the copy
in a fresh interpreter, selected by the names the recipes register: what a newcomer following the
page would get. The page and the recipes change together.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

# make test (and so CI) builds the recipes into a copy and imports them: a recipe that no longer
# registers fails there. Putting them through every registry-driven test (50 s) is the slow tier's.

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "architecture.md"

REGISTRY_TESTS = ("test_mechanism.py", "test_any_hexapod.py", "test_workspace.py", "test_batched_lm.py",
                  "test_population_cost.py", "test_solvers.py", "test_discrepancy_ups.py")
"""The registry-driven test files: each parametrises over the registered presets, methods or effects."""
NAMES = ("length_hexapod", "one-plus-one-es", "strut_sag")
"""What the recipes register: the family's preset, the method, the effect."""


def recipe_blocks() -> list[tuple[str, str, str]]:
    """``[(action, path, text)]`` of every Python block of the page's "Recipes" section, in page
    order: ``action`` ``"write"`` (a new file) or ``"append"``."""
    page = PAGE.read_text(encoding="utf-8")
    section = page.split("\n## Recipes\n", 1)[1].split("\n## ", 1)[0]
    blocks = []
    for text in re.findall(r"```python\n(.*?)```", section, re.S):
        first = text.split("\n", 1)[0]
        if m := re.fullmatch(r"# append to (stewart_jax/\S+\.py)", first):
            blocks.append(("append", m.group(1), text.split("\n", 1)[1]))
        elif m := re.fullmatch(r"# (stewart_jax/\S+\.py)", first):
            blocks.append(("write", m.group(1), text))
        else:
            raise AssertionError(f"a recipe block must open with its file, '# stewart_jax/…': {first!r}")
    return blocks


def test_the_page_has_the_three_recipes():
    written = {path for action, path, _ in recipe_blocks() if action == "write"}
    assert {p.split("/")[1] for p in written} == {"mechanism", "optimise", "discrepancy"}, written


@pytest.fixture(scope="module")
def package(tmp_path_factory) -> Path:
    """A copy of the package with the recipes written into it."""
    tmp = tmp_path_factory.mktemp("recipes")
    shutil.copytree(ROOT / "stewart_jax", tmp / "stewart_jax", ignore=shutil.ignore_patterns("__pycache__"))
    for action, path, text in recipe_blocks():
        target = tmp / path
        if action == "write":
            assert not target.exists(), f"the recipe's new file {path} exists in the package"
            target.write_text(text, encoding="utf-8")
        else:
            assert target.exists(), f"the recipe appends to {path}, which the package does not have"
            target.write_text(target.read_text(encoding="utf-8") + "\n" + text, encoding="utf-8")
    return tmp


def _run(package: Path, *args: str, timeout: int) -> subprocess.CompletedProcess:
    # PYTHONSAFEPATH: the working directory (the repository, with the unmodified package) is not
    # put on the path, so that the copy on PYTHONPATH is the package imported.
    env = {**os.environ, "PYTHONPATH": str(package), "PYTHONSAFEPATH": "1"}
    return subprocess.run([sys.executable, *args], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=timeout)


def test_the_recipes_register_in_the_copy(package):
    code = ("import stewart_jax as sj; print(sj.__file__); "
            "print('length_hexapod' in sj.mechanism.presets(), '6-SPS-length' in sj.mechanism.families(), "
            "'one-plus-one-es' in sj.calibration.METHOD_REGISTRY, 'strut_sag' in sj.discrepancy.effect_names('6-ups'))")
    r = _run(package, "-c", code, timeout=300)
    assert r.returncode == 0, r.stderr
    where, registered = r.stdout.splitlines()[:2]
    assert Path(where).is_relative_to(package), where
    assert registered == "True True True True", registered


@pytest.mark.slow
def test_the_registry_driven_tests_pass_on_the_recipes(package):
    """Every registry-driven test that selects what the recipes add passes; the one skip allowed is
    the closed-form leg Jacobian's check, which a family without one does not have."""
    r = _run(package, "-m", "pytest", "-q", "-rs", "-p", "no:cacheprovider", "-p", "no:xdist",
             *(str(ROOT / "tests" / f) for f in REGISTRY_TESTS), "-k", " or ".join(NAMES), timeout=1200)
    tail = r.stdout[-3000:]
    assert r.returncode == 0, tail + r.stderr[-3000:]
    counts = dict((k, int(n)) for n, k in re.findall(r"(\d+) (passed|failed|skipped|error)", r.stdout.splitlines()[-1]))
    assert counts.get("passed", 0) >= 15 and not counts.get("failed"), tail
    skips = [line for line in r.stdout.splitlines() if line.startswith("SKIPPED")]
    assert len(skips) == counts.get("skipped", 0) and all("default Jacobian" in s for s in skips), skips
