"""Writing files so that an interruption never leaves a half-written one, checking output paths
before any work, and strict JSON."""

from __future__ import annotations

import hashlib
import json
import math
import os
import stat
import tempfile


def write_text_atomic(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` to a temporary file beside ``path``, then rename it over ``path`` (atomic
    on POSIX): readers see the old file or the new one, never a part. The temporary file is
    removed if writing fails."""
    directory = os.path.dirname(os.path.abspath(path))
    mode = _target_mode(path)
    try:
        fd, tmp = tempfile.mkstemp(dir=directory, prefix=f".{os.path.basename(path)}-", suffix=".partial")
    except OSError as e:  # name the user's path, not the temporary file's
        raise OSError(e.errno, f"cannot write {os.fspath(path)}: {e.strerror}") from None
    try:
        # NOTE: mkstemp creates its file with mode 0600 whatever the umask; renamed over ``path``
        # that would make an export or a HAL file unreadable to the controller's user. The new
        # file gets the mode ``open()`` would give it (0666 less the umask), an overwritten file
        # keeps its own.
        os.fchmod(fd, mode)
        with os.fdopen(fd, "w") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException as e:
        if os.path.exists(tmp):
            os.unlink(tmp)
        if isinstance(e, OSError):
            raise OSError(e.errno, f"cannot write {os.fspath(path)}: {e.strerror}") from None
        raise


def _current_umask() -> int:
    try:  # Linux ≥ 4.7 states it; reading it does not change it (thread-safe)
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)  # elsewhere reading the umask means setting it; restored at once
    os.umask(mask)
    return mask


def _target_mode(path: str | os.PathLike[str]) -> int:
    """The permission bits a file written at ``path`` should have: those of the file it replaces,
    else ``0o666`` less the process's umask (what ``open(path, "w")`` gives a new file)."""
    try:
        return stat.S_IMODE(os.stat(path).st_mode)
    except FileNotFoundError:
        return 0o666 & ~_current_umask()


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


def same_file(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """Whether two paths name one file (the same resolved path, or hard links to one inode)."""
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def check_distinct_paths(paths: dict[str, str | os.PathLike[str] | None],
                         inputs: dict[str, str | os.PathLike[str] | None] | None = None) -> None:
    """Raise ``ValueError`` if two outputs (``{description: path}``) name one file, or an output
    names an input file: the later write would destroy the earlier file (a study's checkpoint
    replaced by its result, a measurement file by a report). Called before any work."""
    outs = [(what, p) for what, p in paths.items() if p]
    for i, (w1, p1) in enumerate(outs):
        for w2, p2 in outs[i + 1:]:
            if same_file(p1, p2):
                raise ValueError(f"{w1} and {w2} are the same file ({p1!s}): the second write would destroy "
                                 "the first; give each output its own path")
    for what_in, p_in in (inputs or {}).items():
        if not p_in or not os.path.isfile(p_in):
            continue
        for what, p in outs:
            if same_file(p, p_in):
                raise ValueError(f"{what} {p!s} is the input {what_in}: writing it would destroy the input; "
                                 "give the output its own path")


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


_STAMP = "stewart_jax generated file; sha256 of the lines below:"


def stamp_generated(text: str, comment: str = "#") -> str:
    """``text`` with a first comment line recording the SHA-256 of the rest, so that a later
    write can tell an unedited generated file (safe to replace) from an edited or hand-made one
    (:func:`generated_state`)."""
    digest = hashlib.sha256(text.encode()).hexdigest()
    return f"{comment} {_STAMP} {digest}\n{text}"


def generated_state(path: str | os.PathLike[str]) -> str:
    """``"absent"``, ``"unedited"`` (a :func:`stamp_generated` file whose lines match their
    checksum), ``"edited"`` (stamped, but changed since) or ``"foreign"`` (no stamp: made by
    hand or by another program)."""
    try:
        with open(path, encoding="utf-8", errors="replace") as fh:
            first, rest = fh.readline(), fh.read()
    except FileNotFoundError:
        return "absent"
    head, sep, digest = first.rstrip("\n").partition(_STAMP)
    if not sep:
        return "foreign"
    return "unedited" if hashlib.sha256(rest.encode()).hexdigest() == digest.strip() else "edited"


def keep_backup(path: str | os.PathLike[str]) -> str:
    """Copy the file ``path`` to the first free ``PATH.bak``, ``PATH.bak1``, … (never replacing
    an earlier backup) and return the backup's path."""
    import shutil

    candidate, n = f"{path}.bak", 0
    while os.path.exists(candidate):
        n += 1
        candidate = f"{path}.bak{n}"
    shutil.copy2(path, candidate)
    return candidate
