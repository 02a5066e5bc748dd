"""The API reference: every public name of the package has an entry in ``docs/api/*.md``, every
member an entry lists exists, and every subpackage has a page. The public surface stays small,
and every name that left it still answers from its old place with a warning naming its
replacement (the table of ``stewart_jax/_moved.py``, published as ``docs/api/moved.md``). No
build is needed (the strict build, which renders these entries, is ``tests/test_docs.py``): a
file of its own, so that the test workers do not wait for the build to run these.
"""

from __future__ import annotations

import ast
import importlib
import re
import warnings
from pathlib import Path
from types import ModuleType

import pytest

from stewart_jax import _moved

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
    assert pages == {"index", "moved"} | {p.rsplit(".", 1)[-1] for p in PACKAGES[1:]}


# --- a small public surface, and the names that left it ----------------------------------------------

MAX_PUBLIC_NAMES = 220  # all namespaces together (nine); a name in the core and a subpackage counts twice


def test_the_public_surface_stays_small():
    counts = {package: len(public_names(importlib.import_module(package))) for package in PACKAGES}
    assert sum(counts.values()) < MAX_PUBLIC_NAMES, counts


def test_every_moved_name_warns_names_its_replacement_and_is_not_listed():
    """Registry-driven: every old public name of ``stewart_jax._moved.MOVED`` still gives the same
    object, with a ``DeprecationWarning`` that names its replacement, and no namespace lists it."""
    wrong = []
    for package, names in _moved.MOVED.items():
        module = importlib.import_module(package)
        listed = set(dir(module)) | set(public_names(module)) | set(vars(module))
        for name, (where, replacement) in names.items():
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                obj = getattr(module, name)
            messages = [str(w.message) for w in caught if issubclass(w.category, DeprecationWarning)]
            location, attr = where.split(":")
            if messages != [f"{package}.{name} is no longer public; use {replacement}"]:
                wrong.append(f"{package}.{name}: warned {messages}")
            if obj is not getattr(importlib.import_module(location), attr):
                wrong.append(f"{package}.{name}: not the object at {where}")
            if name in listed:
                wrong.append(f"{package}.{name}: still listed by the namespace")
    assert not wrong, wrong
    assert sum(map(len, _moved.MOVED.values())) > 0


def test_an_unknown_name_is_still_an_attribute_error():
    for package in PACKAGES:
        module = importlib.import_module(package)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            with pytest.raises(AttributeError, match="no_such_name"):
                module.no_such_name  # noqa: B018


def test_the_moved_page_is_current():
    assert (API / "moved.md").read_text(encoding="utf-8") == _moved.moved_markdown(), (
        "docs/api/moved.md is stewart_jax._moved.moved_markdown(): write it again after editing the table")
