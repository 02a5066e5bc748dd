"""Writing files so that an interruption never leaves a half-written one, checking output paths
before any work, and strict JSON."""

from __future__ import annotations

import json
import math
import os
import tempfile


def write_text_atomic(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` to a temporary file beside ``path``, then rename it over ``path`` (atomic
    on POSIX): readers see the old file or the new one, never a part. The temporary file is
    removed if writing fails."""
    directory = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=f".{os.path.basename(path)}-", suffix=".partial")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def check_writable(path: str | os.PathLike[str], what: str = "output") -> None:
    """Raise ``ValueError`` naming ``what`` and ``path`` unless a file can be written there: its
    folder exists and is writable, and ``path`` is not a folder. Called before any work, so that
    a bad output path costs nothing."""
    p = os.path.abspath(path)
    directory = os.path.dirname(p)
    if os.path.isdir(p):
        raise ValueError(f"{what} {path!s} is a folder, not a file")
    if not os.path.isdir(directory):
        raise ValueError(f"{what} {path!s}: the folder {directory} does not exist")
    if not os.access(directory, os.W_OK | os.X_OK):
        raise ValueError(f"{what} {path!s}: the folder {directory} is not writable")
    if os.path.exists(p) and not os.access(p, os.W_OK):
        raise ValueError(f"{what} {path!s} exists and is not writable")


def finite_or_none(obj):
    """``obj`` (nested dicts, lists, tuples, floats) with every NaN or infinity replaced by
    ``None``: strict JSON (``null``), which every parser reads."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: finite_or_none(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [finite_or_none(v) for v in obj]
    return obj


def json_text(obj, indent: int | None = 2) -> str:
    """Strict JSON text of ``obj`` (non-finite numbers as ``null``), newline-terminated."""
    return json.dumps(finite_or_none(obj), indent=indent, allow_nan=False) + "\n"
