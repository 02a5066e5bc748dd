"""Shared fixtures. Geometries and pose grids are module-level so that jitted functions
compile once per shape across the whole session."""

import os
import shutil
import tempfile

os.environ["MPLBACKEND"] = "Agg"  # the tests only write figures; the library never picks a backend

import jax
import numpy as np
import pytest

import stewart_jax as sj

_XLA_CACHE_ENV = "JAX_COMPILATION_CACHE_DIR"
_CREATED_CACHE = pytest.StashKey[str]()


def pytest_configure(config):
    """One persistent XLA compilation cache for the whole test session, shared by the xdist
    workers and by every process the tests start (the documentation build's notebook kernel,
    the multi-process and multi-device children, the command-line runs).

    NOTE: XLA compilation, not computation, is most of the suite's run time on CPU, and each
    process compiles its own programs: a program that two processes need (the same shapes, the
    same flags) is compiled once and loaded from the cache by the other. The loaded executable
    is the one XLA compiled, so every number is unchanged. The cache starts empty in a fresh
    temporary folder (as on a clean CI machine) and is removed at the end; a cache folder the
    user sets (``JAX_COMPILATION_CACHE_DIR``) is used as it is and kept. The first process
    (controller, or the only one) creates the folder; the xdist workers and child processes
    inherit it through the environment.
    """
    path = os.environ.get(_XLA_CACHE_ENV)
    if not path:
        path = tempfile.mkdtemp(prefix="stewart-jax-xla-cache-")
        os.environ[_XLA_CACHE_ENV] = path
        config.stash[_CREATED_CACHE] = path
    # Programs that compile in under 0.1 s are not worth a file each.
    os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0.1")
    jax.config.update("jax_compilation_cache_dir", path)
    jax.config.update("jax_persistent_cache_min_compile_time_secs",
                      float(os.environ["JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"]))


def pytest_unconfigure(config):
    path = config.stash.get(_CREATED_CACHE, None)
    if path:
        shutil.rmtree(path, ignore_errors=True)


@pytest.fixture(scope="session")
def nominal():
    return sj.nominal_geometry()


@pytest.fixture(scope="session")
def actual():
    return sj.actual_geometry()


@pytest.fixture(scope="session", params=["nominal", "actual"])
def preset(request):
    return sj.mechanism.preset(request.param)


def travel_grid(seed: int = 0, n_random: int = 192) -> np.ndarray:
    """The 64 corners of the ±1 mm/±1° travel box, its centre, and seeded uniform poses."""
    half = np.array([sj.calibration.TRAVEL_MM] * 3 + [sj.calibration.TRAVEL_RAD] * 3)
    corners = np.array(np.meshgrid(*[[-1.0, 1.0]] * 6, indexing="ij")).reshape(6, -1).T * half
    rng = np.random.default_rng(seed)
    inner = rng.uniform(-half, half, size=(n_random, 6))
    return np.concatenate([corners, np.zeros((1, 6)), inner])


@pytest.fixture(scope="session")
def grid():
    return travel_grid()


def perturbed_geometry(seed: int, scale_mm: float = 5.0, with_v0: bool = True) -> sj.Geometry:
    """Nominal joint centres moved by up to ±scale_mm, and a random v0."""
    rng = np.random.default_rng(seed)
    g = sj.nominal_geometry()
    v0 = rng.uniform(-3, 3, 3) if with_v0 else np.zeros(3)
    return sj.Geometry(
        np.asarray(g.upper) + rng.uniform(-scale_mm, scale_mm, (6, 3)),
        np.asarray(g.lower) + rng.uniform(-scale_mm, scale_mm, (6, 3)),
        v0,
    )


jit_ik = jax.jit(sj.solve_inverse_kinematics)
