"""Shared pieces of the benchmark scripts: machine description and result files."""

from __future__ import annotations

import datetime
import json
import os
import platform
import shlex
import sys

from stewart_jax._files import write_text_atomic

RESULTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "results")


def machine_info() -> dict:
    """Machine, versions, the command that ran, and the date (UTC)."""
    import jax
    import jaxlib
    import numpy as np

    try:
        load = os.getloadavg()[0]
    except OSError:
        load = None
    return {
        "command": " ".join(shlex.quote(a) for a in [os.path.relpath(sys.executable), *sys.argv]),
        "date_utc": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M:%S"),
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpu_count": os.cpu_count(),
        "load_average_1min": load,
        "python": platform.python_version(),
        "jax": jax.__version__,
        "jaxlib": jaxlib.__version__,
        "numpy": np.__version__,
        "backend": jax.default_backend(),
        "devices": [str(d) for d in jax.devices()],
    }


def write_results(name: str, payload: dict, markdown: str, out: str = RESULTS) -> None:
    """``OUT/NAME.json`` (payload + machine info) and ``OUT/NAME.md`` (``OUT`` is ``results/``
    unless given)."""
    os.makedirs(out, exist_ok=True)
    info = machine_info()
    write_text_atomic(os.path.join(out, f"{name}.json"), json.dumps({"machine": info, **payload}, indent=1) + "\n")
    header = (
        f"Command: `{info['command']}`  \n"
        f"Machine: {info['platform']}, {info['cpu_count']} CPUs ({info['processor']}), backend "
        f"{info['backend']}, load average {info['load_average_1min']}; python {info['python']}, "
        f"jax {info['jax']}, numpy {info['numpy']}; {info['date_utc']} UTC\n\n"
    )
    write_text_atomic(os.path.join(out, f"{name}.md"), header + markdown.rstrip() + "\n")


def expand(text: str) -> list[int]:
    """``"1-5,101-105"`` → ``[1, …, 5, 101, …, 105]``: the numbers of an option."""
    out = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out += list(range(int(a), int(b or a) + 1))
    return out
