"""Shared fixtures. Geometries and pose grids are module-level so that jitted functions
compile once per shape across the whole session."""

import os

os.environ["MPLBACKEND"] = "Agg"  # the tests only write figures; the library never picks a backend

import jax
import numpy as np
import pytest

import stewart_jax as sj


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
