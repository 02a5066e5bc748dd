"""The memory this machine has available now, for refusing up front what it cannot hold."""

from __future__ import annotations

import os

MEMORY_SHARE = 0.5
"""Share of the available memory one command's arrays may take."""


def available_memory_bytes() -> int | None:
    """``MemAvailable`` of ``/proc/meminfo`` (Linux), else the free physical pages, else ``None``."""
    try:
        with open("/proc/meminfo") as f:
            info = dict(line.split(":", 1) for line in f)
        return int(info["MemAvailable"].split()[0]) * 1024
    except (OSError, KeyError, ValueError):
        try:
            return int(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
        except (ValueError, OSError, AttributeError):
            return None


def most_that_fit(bytes_each: float) -> tuple[int, int] | None:
    """How many items of ``bytes_each`` bytes fit in :data:`MEMORY_SHARE` of the available memory,
    and that memory (bytes); ``None`` where it cannot be read."""
    available = available_memory_bytes()
    if available is None:
        return None
    return int(MEMORY_SHARE * available / bytes_each), available
