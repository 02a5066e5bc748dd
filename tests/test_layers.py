"""The layer rule of ``docs/architecture.md``, read from the package's imports.

Every ``import``/``from … import`` of ``stewart_jax`` (module level or inside a function: a lazy
import is still a dependency) is parsed with :mod:`ast`, and its source and target subpackages
are compared with :data:`MAY_IMPORT`, the table the architecture page draws. A new subpackage
fails here until it has a row (and the page a line).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "stewart_jax"

CORE = {"_math", "_units", "_checks", "_files", "_linalg", "_special", "_runtime", "_cache", "_memory"}
"""The lowest layer: modules directly in ``stewart_jax/``; they import only each other."""

MAY_IMPORT: dict[str, set[str]] = {
    **{core: CORE for core in CORE},
    "optimise": set(),
    "mechanism": CORE,
    "calibration": CORE | {"mechanism", "optimise"},
    "study": CORE | {"mechanism", "optimise", "calibration"},
    "cable_robot": CORE,
    "discrepancy": CORE | {"mechanism", "optimise", "calibration", "cable_robot"},
    "compensation": CORE | {"mechanism", "calibration"},
    "plotting": CORE,
    "<package>": CORE | {"mechanism", "optimise", "calibration", "study", "discrepancy", "cable_robot", "plotting",
                         "compensation"},
    "_cli": CORE | {"<package>", "mechanism", "optimise", "calibration", "study", "discrepancy", "cable_robot",
                    "plotting", "compensation"},
    "__main__": {"_cli"},
}
"""``{layer: the layers it may import}``; ``<package>`` is ``stewart_jax/__init__.py``, which
loads ``discrepancy``, ``cable_robot`` and ``plotting`` on first attribute access."""


def _layer(module: str) -> str:
    """``stewart_jax.calibration._points`` → ``calibration``; ``stewart_jax._math`` → ``_math``."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "<package>"


def _imports(path: Path) -> list[tuple[int, str]]:
    """``[(line, absolute module name)]`` of every ``stewart_jax`` import in ``path``; for
    ``from . import x`` the name is the package's ``x``."""
    rel = path.relative_to(ROOT).with_suffix("")
    package = list(rel.parts[:-1])  # the package a relative import starts from (also for __init__.py)
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found += [(node.lineno, a.name) for a in node.names if a.name.split(".")[0] == "stewart_jax"]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - (node.level - 1)]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            if module.split(".")[0] != "stewart_jax":
                continue
            if node.module is None or module == "stewart_jax":  # from . import x: x a module, or a name of it
                found += [(node.lineno, f"{module}.{a.name}" if _is_module(module, a.name) else module)
                          for a in node.names]
            else:
                found.append((node.lineno, module))
    return found


def _is_module(package: str, name: str) -> bool:
    folder = ROOT.joinpath(*package.split("."))
    return (folder / f"{name}.py").exists() or (folder / name / "__init__.py").exists()


def _source_layer(path: Path) -> str:
    rel = path.relative_to(PACKAGE)
    if len(rel.parts) > 1:
        return rel.parts[0]
    return "<package>" if path.name == "__init__.py" else path.stem


def layer_violations() -> list[str]:
    wrong = []
    for path in sorted(PACKAGE.rglob("*.py")):
        source = _source_layer(path)
        if source not in MAY_IMPORT:
            wrong.append(f"{path.relative_to(ROOT)}: layer {source!r} has no row in MAY_IMPORT "
                         "(tests/test_layers.py) nor a place on docs/architecture.md's diagram")
            continue
        for line, module in _imports(path):
            target = _layer(module)
            if target != source and target not in MAY_IMPORT[source]:
                wrong.append(f"{path.relative_to(ROOT)}:{line}: {source} imports {module} ({target})")
    return wrong


def test_no_import_breaks_the_layer_rule():
    wrong = layer_violations()
    assert not wrong, "imports against the layer rule of docs/architecture.md:\n" + "\n".join(wrong)


def test_the_scan_sees_the_imports_it_checks():
    """The scanner against imports known to be there (a scan that found nothing would pass the
    rule vacuously): relative, absolute, ``from . import`` and lazy imports inside functions."""
    calibration = {m for _, m in _imports(PACKAGE / "calibration" / "_simulation.py")}
    assert "stewart_jax.mechanism._abstract" in calibration
    top = {m for _, m in _imports(PACKAGE / "__init__.py")}
    assert {"stewart_jax.calibration", "stewart_jax.mechanism", "stewart_jax._math"} <= top
    lazy = PACKAGE / "discrepancy" / "_cabin_record.py"
    source = lazy.read_text(encoding="utf-8")
    inside = [i + 1 for i, line in enumerate(source.splitlines()) if re.match(r"\s+from \.\.cable_robot import", line)]
    assert inside and set(inside) <= {line for line, m in _imports(lazy) if m.startswith("stewart_jax.cable_robot")}


def test_mechanism_imports_no_higher_layer():
    """The rule's case that broke before: the mechanism layer (families, presets, their file
    checks) imports nothing from calibration, discrepancy, study or the cable robot."""
    higher = {"calibration", "discrepancy", "study", "cable_robot", "plotting", "_cli"}
    wrong = [(p.name, line, m) for p in (PACKAGE / "mechanism").glob("*.py") for line, m in _imports(p)
             if _layer(m) in higher]
    assert not wrong, wrong


def test_the_architecture_page_states_the_table():
    """Each layer's row of :data:`MAY_IMPORT` is on the page, in the list under the diagram
    (``- `layer/` imports …``, up to a parenthesis): the page and this test change together."""
    page = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    for layer in ("optimise", "mechanism", "calibration", "study", "cable_robot", "discrepancy", "plotting", "_cli"):
        row = re.search(rf"^- `{layer}/` imports ([^(\n]*)", page, re.MULTILINE)
        assert row, f"docs/architecture.md has no line '- `{layer}/` imports …'"
        if row.group(1).startswith("any layer"):
            assert MAY_IMPORT[layer] >= set(MAY_IMPORT) - {layer, "__main__"}, layer
            continue
        named = set(re.findall(r"`(\w+)/`", row.group(1)))
        assert named == MAY_IMPORT[layer] - CORE, (layer, named)
        assert ("the core" in row.group(1)) == bool(MAY_IMPORT[layer] & CORE), layer
