"""The persistent compilation cache: XLA programs compiled once are read back from disk by every
later process (the command line, a notebook, a test worker) instead of being compiled again.

JAX's persistent compilation cache (``jax_compilation_cache_dir``) stores each compiled program
under a key that hashes the program, the compile options, the XLA flags, the device and the
jaxlib version. This module chooses the folder and the entry class:

- the folder is ``<user cache folder>/stewart_jax/jax-<jax version>-jaxlib-<jaxlib version>``
  (``$XDG_CACHE_HOME`` or ``~/.cache`` on Linux, ``~/Library/Caches`` on macOS,
  ``%LOCALAPPDATA%`` on Windows): a JAX upgrade starts an empty folder, so no program of another
  version is ever read, and the old folder can be deleted whole;
- ``STEWART_JAX_CACHE_DIR=<folder>`` moves it (the version subfolder is kept), and
  ``STEWART_JAX_CACHE_DIR=off`` turns it off;
- a cache the user configured for JAX (``JAX_COMPILATION_CACHE_DIR`` or
  ``jax.config.update("jax_compilation_cache_dir", …)`` before stewart_jax loaded JAX, or
  ``JAX_ENABLE_COMPILATION_CACHE=false``) is left exactly as configured;
- every program is stored, however short its compilation (JAX's default keeps only those over
  1 s, and this library's programs take 0.05–1 s each; together they are most of a command's
  time);
- entries are written to a temporary file and renamed (a second process never reads half an
  entry), an entry that fails to decompress is deleted and compiled again, and the folder is
  kept under ``STEWART_JAX_CACHE_MAX_MB`` (default 1024 MB) by deleting the least recently used
  entries (checked at a process's first write, and whenever its own writes pass the limit).
"""

from __future__ import annotations

import os
import sys
import time
import zlib
from pathlib import Path

ENV_DIR = "STEWART_JAX_CACHE_DIR"
ENV_MAX_MB = "STEWART_JAX_CACHE_MAX_MB"
OFF = ("off", "0", "false", "no", "none")
DEFAULT_MAX_MB = 1024.0
_SUFFIX = "-cache"
_STALE_TMP_S = 3600.0


def user_cache_root(environ=os.environ) -> Path:
    """The platform's per-user cache folder (the XDG base directory on Linux)."""
    if sys.platform == "darwin":
        return Path.home() / "Library" / "Caches"
    if os.name == "nt":
        return Path(environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local")
    return Path(environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")


def version_folder() -> str:
    """``jax-<version>-jaxlib-<version>``: one folder per pair, read without importing JAX."""
    from importlib.metadata import PackageNotFoundError, version

    def v(name: str) -> str:
        try:
            return version(name)
        except PackageNotFoundError:
            return "unknown"

    return f"jax-{v('jax')}-jaxlib-{v('jaxlib')}"


def cache_dir(environ=os.environ) -> Path | None:
    """The folder stewart_jax would use, or ``None`` where ``STEWART_JAX_CACHE_DIR`` turns it off.

    NOTE: jaxlib 0.10.2 once aborted a process inside ``executable.serialize()`` while storing a
    program here, and another time crashed compiling one. Both were processes past the kernel's
    limit on memory mappings (``vm.max_map_count``): every XLA:CPU executable keeps its code in
    mappings of its own, and a test worker holding thousands of programs ran out. The cache was
    not the cause; a process that compiles thousands of programs should call
    ``jax.clear_caches()`` now and then (the test suite does after every file)."""
    value = environ.get(ENV_DIR, "").strip()
    if value.lower() in OFF:
        return None
    root = Path(value).expanduser() if value else user_cache_root(environ) / "stewart_jax"
    return root / version_folder()


def max_bytes(environ=os.environ) -> int:
    text = environ.get(ENV_MAX_MB, "").strip()
    try:
        mb = float(text) if text else DEFAULT_MAX_MB
    except ValueError:
        raise ValueError(f"{ENV_MAX_MB}={text!r} is not a number of megabytes") from None
    if not mb > 0:
        raise ValueError(f"{ENV_MAX_MB}={text!r}: the cache's size limit must be positive (MB)")
    return int(mb * 1e6)


def configured_by_user(jax) -> bool:
    """Whether the user set JAX's own cache (a folder, or the cache turned off) before we did."""
    return jax.config.jax_compilation_cache_dir is not None or not jax.config.jax_enable_compilation_cache


def enable(jax) -> Path | None:
    """Turn the cache on for this process (see the module's docstring); the folder used, or
    ``None`` where the cache is off or the user's own JAX setting is kept."""
    if configured_by_user(jax):
        return None
    path = cache_dir()
    if path is None:
        return None
    limit = max_bytes()
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None  # a read-only home: compile as before, without a cache
    jax.config.update("jax_compilation_cache_dir", str(path))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
    _install(path, limit)
    return path


def _install(path: Path, limit: int) -> None:
    """Our entry store in place of JAX's (whose writes are not atomic and whose damaged entries
    stay on disk); where this JAX's private cache hook differs, JAX's own store is kept."""
    try:
        from jax._src import compilation_cache as cc

        store = _atomic_store_class(cc)(path, limit)
        with cc._cache_initialized_mutex:
            if cc._cache_initialized:
                return
            cc._cache = store
            cc._cache_initialized = True
    except (ImportError, AttributeError, TypeError):
        return


def _atomic_store_class(cc):
    class AtomicStore(cc.CacheInterface):
        """Files ``<key>-cache`` written by rename, checked on read, least recently used evicted."""

        def __init__(self, path: Path, limit: int):
            self._path = path
            self.limit = limit
            self.size: int | None = None  # the folder's bytes, counted at this process's first write

        def get(self, key: str) -> bytes | None:
            entry = self._path / f"{key}{_SUFFIX}"
            try:
                value = entry.read_bytes()
            except OSError:
                return None
            try:
                cc.decompress_executable(value)
            except (zlib.error, ValueError, RuntimeError, OSError):
                _unlink(entry)  # damaged: compiled again and written anew
                return None
            try:
                os.utime(entry)  # the access time that eviction orders by
            except OSError:
                pass
            return value

        def put(self, key: str, value: bytes) -> None:
            if len(value) > self.limit:
                return
            entry = self._path / f"{key}{_SUFFIX}"
            tmp = self._path / f".{key}.{os.getpid()}.tmp"
            try:
                tmp.write_bytes(value)
                os.replace(tmp, entry)
            except OSError:
                _unlink(tmp)
                return
            # NOTE: the folder is listed once per process (and again whenever this process's own
            # writes take it past the limit), not at every write: a test run writes thousands of
            # entries, and listing thousands of files per entry cost more than the compilations.
            self.size = (evict(self._path, self.limit) if self.size is None else self.size + len(value))
            if self.size > self.limit:
                self.size = evict(self._path, self.limit)

        def clear(self) -> None:
            for entry in self._path.glob(f"*{_SUFFIX}"):
                _unlink(entry)

    return AtomicStore


def evict(path: Path, limit: int) -> int:
    """Delete the least recently used entries until the folder holds at most ``limit`` bytes
    (and temporary files a crashed writer left over an hour ago); the bytes left."""
    now = time.time()
    entries = []
    for item in path.iterdir():
        try:
            st = item.stat()
        except OSError:
            continue  # removed meanwhile by another process
        if item.name.endswith(".tmp") and now - st.st_mtime > _STALE_TMP_S:
            _unlink(item)
        elif item.name.endswith(_SUFFIX):
            entries.append((st.st_mtime, st.st_size, item))
    total = sum(size for _, size, _ in entries)
    for _, size, item in sorted(entries):
        if total <= limit:
            break
        _unlink(item)
        total -= size
    return total


def _unlink(path: Path) -> None:
    try:
        path.unlink()
    except OSError:
        pass
