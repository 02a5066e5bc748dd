"""Shared fixtures. Geometries and pose grids are module-level so that jitted functions
compile once per shape across the whole session."""

import os
from collections import Counter

os.environ["MPLBACKEND"] = "Agg"  # the tests only write figures; the library never picks a backend

import jax
import numpy as np
import pytest

import stewart_jax as sj

# Units and the paper's travel, written here rather than read from the package so that the tests
# compare against numbers of their own: one µm in mm, one arc-second in rad, ±1 mm and ±1°.
UM = 1e-3
ARCSEC = np.pi / (180.0 * 3600.0)
TRAVEL_MM = 1.0
TRAVEL_RAD = float(np.deg2rad(1.0))

# The test files that take longest (measured with --durations on a 2-core machine; compilation
# dominates), longest first. `make test` runs two xdist workers, each taking one whole
# file at a time (`--dist loadfile`) in the order of the collection; xdist's default order (most
# tests first) started the documentation build, a third of the whole suite's time in one file,
# halfway through the run, and it finished minutes after everything else. Longest first, the
# short files fill the gaps at the end. A file missing here only runs later.
SLOW_FILES_FIRST = (
    "test_docs.py",  # the strict build, which executes the six notebooks
    "test_discrepancy.py",
    "test_discrepancy_points.py",  # about 4 min: seven diagnoses of tracker points (-O0, load 10)
    "test_recipes.py",  # 2–3 min: the registry-driven tests in a fresh interpreter on a copy of the package
    "test_solvers.py",
    "test_comparison.py",
    "test_ups.py",
    "test_mechanism.py",
    "test_discrepancy_ups.py",
    "test_trust.py",
    "test_batched_lm.py",
    "test_multihost.py",
    "test_pss_general.py",
    "test_any_hexapod.py",
    "test_cable_robot_coupled.py",
    "test_discrepancy_cable_robot.py",
    "test_identifiability.py",
    "test_sharding.py",
    "test_cable_robot_stewart.py",
    "test_study.py",
)


def pytest_configure(config):
    # xdist (when installed) hands out files in the collection order below, not by test count.
    if hasattr(config.option, "loadscopereorder"):
        config.option.loadscopereorder = False


def pytest_collection_modifyitems(config, items):
    """The slow files first (longest first), then the others by number of tests (xdist's own
    order); every file's tests stay together and in their order."""
    rank = {name: i for i, name in enumerate(SLOW_FILES_FIRST)}
    count = Counter(item.path.name for item in items)
    items.sort(key=lambda item: (rank.get(item.path.name, len(rank)), -count[item.path.name], str(item.path)))


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
    half = np.array([TRAVEL_MM] * 3 + [TRAVEL_RAD] * 3)
    corners = np.array(np.meshgrid(*[[-1.0, 1.0]] * 6, indexing="ij")).reshape(6, -1).T * half
    rng = np.random.default_rng(seed)
    inner = rng.uniform(-half, half, size=(n_random, 6))
    return np.concatenate([corners, np.zeros((1, 6)), inner])


@pytest.fixture(scope="session")
def grid():
    return travel_grid()


def perturbed_geometry(seed: int, scale_mm: float = 5.0, with_v0: bool = True) -> sj.mechanism.PSSMechanism:
    """Nominal joint centres moved by up to ±scale_mm, and a random v0."""
    rng = np.random.default_rng(seed)
    g = sj.nominal_geometry()
    v0 = rng.uniform(-3, 3, 3) if with_v0 else np.zeros(3)
    return sj.mechanism.PSSMechanism(
        np.asarray(g.upper) + rng.uniform(-scale_mm, scale_mm, (6, 3)),
        np.asarray(g.lower) + rng.uniform(-scale_mm, scale_mm, (6, 3)),
        v0,
    )


jit_ik = jax.jit(lambda mechanism, poses: mechanism.solve_inverse_kinematics(poses))
