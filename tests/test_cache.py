"""The persistent compilation cache (``stewart_jax._cache``): where it lives, how it is turned
off or left to the user's own JAX setting, and that a second process compiles nothing, that two
processes at once, a damaged entry and the size bound leave every command working. Each run is a
fresh Python process, as a user's commands are."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import zlib
from importlib.metadata import version
from pathlib import Path

import pytest

from stewart_jax import _cache

# A small computation through the library: the inverse kinematics of a few poses (a few dozen
# small programs), reporting the compilations XLA ran and the programs read back from the cache.
SCRIPT = """
import json, sys
from jax._src import monitoring
events = []
monitoring.register_event_listener(lambda name, **kw: events.append(name))
monitoring.register_event_duration_secs_listener(lambda name, d, **kw: events.append(name))
import numpy as np
import stewart_jax as sj
import jax
readings = sj.inverse_kinematics(sj.nominal_geometry(), np.array([[0.1, 0.0, 0.0, 0.0, 0.0, 0.001]] * 3))
print(json.dumps({
    "compiled": events.count("/jax/core/compile/backend_compile_duration")
                - events.count("/jax/compilation_cache/cache_hits"),
    "read": events.count("/jax/compilation_cache/cache_hits"),
    "dir": jax.config.jax_compilation_cache_dir,
    "q1_mm": float(np.asarray(readings)[0, 0]),
}))
"""


def run(env_extra: dict[str, str], *, script: str = SCRIPT) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("JAX_COMPILATION_CACHE", "STEWART_JAX_CACHE"))}
    env.update(env_extra)
    out = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    return {**json.loads(out.stdout.strip().splitlines()[-1]), "stderr": out.stderr}


def entries(folder: Path) -> list[Path]:
    return sorted(folder.glob("*-cache"))


def test_the_folder_is_per_user_and_keyed_by_the_jax_and_jaxlib_versions(tmp_path):
    expected = f"jax-{version('jax')}-jaxlib-{version('jaxlib')}"
    assert _cache.cache_dir({"XDG_CACHE_HOME": str(tmp_path)}) in (
        tmp_path / "stewart_jax" / expected,  # Linux: the XDG base directory
        Path.home() / "Library" / "Caches" / "stewart_jax" / expected,
    ) or os.name == "nt"
    assert _cache.cache_dir({"STEWART_JAX_CACHE_DIR": str(tmp_path / "c")}) == tmp_path / "c" / expected
    for off in ("off", "OFF", "0", "false", "none"):
        assert _cache.cache_dir({"STEWART_JAX_CACHE_DIR": off}) is None


def test_the_size_limit_is_checked():
    assert _cache.max_bytes({}) == int(_cache.DEFAULT_MAX_MB * 1e6)
    assert _cache.max_bytes({"STEWART_JAX_CACHE_MAX_MB": "2.5"}) == 2_500_000
    for bad in ("lots", "0", "-1"):
        with pytest.raises(ValueError, match="STEWART_JAX_CACHE_MAX_MB"):
            _cache.max_bytes({"STEWART_JAX_CACHE_MAX_MB": bad})


def test_a_second_process_compiles_nothing_and_gets_the_same_numbers(tmp_path):
    first = run({"STEWART_JAX_CACHE_DIR": str(tmp_path)})
    folder = Path(first["dir"])
    assert folder.parent == tmp_path and first["compiled"] > 0 and first["read"] == 0
    assert len(entries(folder)) == first["compiled"]  # every program, however quick to compile
    second = run({"STEWART_JAX_CACHE_DIR": str(tmp_path)})
    assert second["compiled"] == 0 and second["read"] == first["compiled"]
    assert second["q1_mm"] == first["q1_mm"]


def test_off_compiles_every_time_and_writes_nothing(tmp_path):
    home = {"XDG_CACHE_HOME": str(tmp_path), "HOME": str(tmp_path)}
    for _ in range(2):
        out = run({"STEWART_JAX_CACHE_DIR": "off", **home})
        assert out["dir"] is None and out["compiled"] > 0 and out["read"] == 0
    assert not list(tmp_path.rglob("*-cache"))


def test_a_cache_the_user_configured_for_jax_is_kept(tmp_path):
    mine = tmp_path / "mine"
    out = run({"JAX_COMPILATION_CACHE_DIR": str(mine), "STEWART_JAX_CACHE_DIR": str(tmp_path / "ours")})
    assert out["dir"] == str(mine) and not (tmp_path / "ours").exists()
    # JAX's own default (programs under 1 s of compilation are not written) is left as it is.
    assert out["compiled"] > 0 and len(list(mine.glob("*-cache"))) < out["compiled"]
    disabled = run({"JAX_ENABLE_COMPILATION_CACHE": "false", "STEWART_JAX_CACHE_DIR": str(tmp_path / "ours")})
    assert disabled["dir"] is None and not (tmp_path / "ours").exists()


def test_a_damaged_entry_is_compiled_again_and_replaced(tmp_path):
    first = run({"STEWART_JAX_CACHE_DIR": str(tmp_path)})
    folder = Path(first["dir"])
    damaged = entries(folder)
    for i, entry in enumerate(damaged):  # truncated, overwritten, emptied
        data = entry.read_bytes()
        entry.write_bytes([data[: len(data) // 2], b"not a program" * 10, b""][i % 3])
    again = run({"STEWART_JAX_CACHE_DIR": str(tmp_path)})
    assert again["q1_mm"] == first["q1_mm"] and again["compiled"] == len(damaged) and again["read"] == 0
    assert "Error reading persistent compilation cache" not in again["stderr"]
    for entry in entries(folder):
        zlib.decompress(entry.read_bytes())  # every entry whole again
    assert run({"STEWART_JAX_CACHE_DIR": str(tmp_path)})["compiled"] == 0


def test_two_processes_at_once_share_one_folder(tmp_path):
    env = {k: v for k, v in os.environ.items() if not k.startswith(("JAX_COMPILATION_CACHE", "STEWART_JAX_CACHE"))}
    env["STEWART_JAX_CACHE_DIR"] = str(tmp_path)
    procs = [subprocess.Popen([sys.executable, "-c", SCRIPT], env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for _ in range(3)]
    outs = [p.communicate(timeout=300) for p in procs]
    assert all(p.returncode == 0 for p in procs), [e for _, e in outs]
    results = [json.loads(o.strip().splitlines()[-1]) for o, _ in outs]
    assert len({r["q1_mm"] for r in results}) == 1
    folder = Path(results[0]["dir"])
    assert not list(folder.glob("*.tmp"))
    for entry in entries(folder):
        zlib.decompress(entry.read_bytes())
    assert run({"STEWART_JAX_CACHE_DIR": str(tmp_path)})["compiled"] == 0


def test_the_folder_is_kept_under_its_size_limit(tmp_path):
    folder = tmp_path / "entries"
    folder.mkdir()
    for i in range(10):  # 10 entries of 1000 bytes, the oldest first
        entry = folder / f"k{i}-cache"
        entry.write_bytes(b"x" * 1000)
        os.utime(entry, (1_000_000 + i, 1_000_000 + i))
    stale = folder / ".k.123.tmp"
    stale.write_bytes(b"half")
    os.utime(stale, (1_000_000, 1_000_000))
    _cache.evict(folder, 4500)
    assert [p.name for p in entries(folder)] == [f"k{i}-cache" for i in range(6, 10)]
    assert not stale.exists()
    limited = run({"STEWART_JAX_CACHE_DIR": str(tmp_path), "STEWART_JAX_CACHE_MAX_MB": "0.001"})
    assert sum(p.stat().st_size for p in entries(Path(limited["dir"]))) <= 1000
