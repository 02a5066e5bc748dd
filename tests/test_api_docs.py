"""The API reference: the documented public names are the real ones, both ways (every public
name of the package has an entry in ``docs/api/*.md``, and every entry ``package.name`` is a name
the package exports, so nothing is public by accident and no page documents a name that is not
there), every member an entry lists exists, and every subpackage has a page. No build is needed
(the strict build, which renders these entries, is ``tests/test_docs.py``): a
file of its own, so that the test workers do not wait for the build to run these.
"""

from __future__ import annotations

import ast
import importlib
import re
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parents[1]
API = ROOT / "docs" / "api"
PACKAGES = ["stewart_jax"] + [
    f"stewart_jax.{name}"
    for name in ("mechanism", "calibration", "optimise", "study", "discrepancy", "cable_robot", "plotting",
                 "compensation")
]


# --- the public API and the API pages -----------------------------------------------------------------


def public_names(module: ModuleType) -> list[str]:
    """The names a package exports: its explicit re-exports (``from ._x import name as name``)
    and the names it loads on first access (listed by its ``__dir__`` but not yet bound)."""
    tree = ast.parse(Path(module.__file__).read_text(encoding="utf-8"))
    names = [
        alias.name
        for node in tree.body
        if isinstance(node, ast.ImportFrom)
        for alias in node.names
        if alias.asname == alias.name and not alias.name.startswith("_")
    ]
    lazy = [n for n in dir(module) if not n.startswith("_") and n not in vars(module)]
    return [n for n in dict.fromkeys(names + lazy) if not isinstance(getattr(module, n), ModuleType)]


def api_entries() -> dict[str, list[str]]:
    """``{identifier: [members listed]}`` of every ``:::`` directive in ``docs/api/*.md``."""
    entries: dict[str, list[str]] = {}
    for page in sorted(API.glob("*.md")):
        current = None
        in_members = False
        for line in page.read_text(encoding="utf-8").splitlines():
            if m := re.match(r"^::: (\S+)\s*$", line):
                current = m.group(1)
                entries[current] = []
                in_members = False
            elif current and re.match(r"^\s+members:\s*$", line):
                in_members = True
            elif current and in_members and (m := re.match(r"^\s+- (\w+)\s*$", line)):
                entries[current].append(m.group(1))
            elif line and not line.startswith(" "):  # the directive's options block has ended
                current, in_members = None, False
    return entries


def resolve(identifier: str):
    """The object a directive names: import the longest module prefix, then the attributes."""
    parts = identifier.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for attr in parts[i:]:
            obj = getattr(obj, attr)
        return obj
    raise ImportError(identifier)


def test_every_public_name_has_an_api_entry():
    entries = api_entries()
    documented = [(ident, resolve(ident)) for ident in entries]
    missing = []
    for package in PACKAGES:
        module = importlib.import_module(package)
        for name in public_names(module):
            obj = getattr(module, name)
            # The same object documented under another path (a re-export, an alias such as
            # Geometry = PSSMechanism, a lazily loaded name) counts; for values that are not
            # classes or functions (constants) the last component of the name must match too,
            # as equal small numbers and strings may be one object in Python.
            named = callable(obj) and hasattr(obj, "__qualname__")
            if not any(o is obj and (named or ident.rsplit(".", 1)[-1] == name) for ident, o in documented):
                missing.append(f"{package}.{name}")
    assert not missing, f"public names without an entry in docs/api/*.md: {missing}"


def test_listed_members_exist():
    for ident, members in api_entries().items():
        obj = resolve(ident)
        for member in members:
            assert hasattr(obj, member), f"{ident} has no member {member!r} (listed in docs/api)"


def test_every_subpackage_has_an_api_page():
    pages = {p.stem for p in API.glob("*.md")}
    assert pages == {"index"} | {p.rsplit(".", 1)[-1] for p in PACKAGES[1:]}


def test_every_documented_package_name_is_public():
    """The other direction: an entry ``stewart_jax[.subpackage].name`` documents a name the
    package exports (entries under a private module, ``package._module.Type``, document a type a
    user receives but does not import)."""
    wrong = []
    for ident in api_entries():
        package, _, name = ident.rpartition(".")
        if package in PACKAGES and ident not in PACKAGES:
            if name not in public_names(importlib.import_module(package)):
                wrong.append(ident)
    assert not wrong, f"entries in docs/api/*.md for names their package does not export: {wrong}"


def test_an_unknown_name_is_an_attribute_error():
    for package in PACKAGES:
        module = importlib.import_module(package)
        with pytest.raises(AttributeError, match="no_such_name"):
            module.no_such_name  # noqa: B018
