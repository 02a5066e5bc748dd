"""JAX's settings for the library, applied the moment JAX is loaded (not when stewart_jax is):
``jax_enable_x64`` and the persistent compilation cache (``stewart_jax._cache``).

``import stewart_jax`` does not load JAX, so that the command line answers ``--help``,
``--version`` and a misspelt argument in the time of a bare Python start. Every submodule that
computes imports JAX; when that happens — or at once, where JAX was loaded before stewart_jax —
:func:`configure` runs before any line of stewart_jax creates an array.

NOTE: float64 is not optional: calibration carries micrometres over 100 mm (1e-5 relative),
which float32 cannot hold.
"""

from __future__ import annotations

import importlib.abc
import importlib.util
import sys


def configure(jax) -> None:
    jax.config.update("jax_enable_x64", True)
    from . import _cache

    _cache.enable(jax)


class _AfterJaxImport(importlib.abc.MetaPathFinder):
    """Finds ``jax`` with the other finders and runs :func:`configure` once its module has run."""

    def find_spec(self, name, path=None, target=None):
        if name != "jax":
            return None
        uninstall()
        spec = importlib.util.find_spec("jax")
        if spec is None or spec.loader is None:
            return spec
        run_module = spec.loader.exec_module

        def exec_module(module):
            run_module(module)
            configure(module)

        spec.loader.exec_module = exec_module  # this loader instance loads jax/__init__ only
        return spec


_FINDER = _AfterJaxImport()


def uninstall() -> None:
    if _FINDER in sys.meta_path:
        sys.meta_path.remove(_FINDER)


def install() -> None:
    """Configure JAX now if it is loaded, else when it is."""
    if "jax" in sys.modules:
        configure(sys.modules["jax"])
    elif _FINDER not in sys.meta_path:
        sys.meta_path.insert(0, _FINDER)
