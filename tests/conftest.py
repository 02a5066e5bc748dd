"""Shared fixtures. Geometries and pose grids are module-level so that jitted functions
compile once per shape across the whole session."""

import gc
import json
import os
from collections import Counter
from pathlib import Path

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

# The order of the test files: longest first, from the seconds each file took in the last
# recorded run (tests/durations.json; `make test` records them, `make durations` records them
# without the other options). `make test` runs two xdist workers, each taking one whole file at a
# time (`--dist loadfile`) in the order of the collection; xdist's default order (most tests
# first) started the documentation build, a third of the whole suite's time in one file, halfway
# through the run, and it finished minutes after everything else. Longest first, the short files
# fill the gaps at the end. A file never recorded counts as the median file.
DURATIONS = Path(__file__).with_name("durations.json")


def recorded_durations() -> dict[str, float]:
    try:
        return {k: float(v) for k, v in json.loads(DURATIONS.read_text(encoding="utf-8"))["seconds"].items()}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return {}


def pytest_addoption(parser):
    parser.addoption("--record-durations", action="store_true",
                     help="write each test file's seconds (setup + call + teardown) to tests/durations.json")


def pytest_configure(config):
    # xdist (when installed) hands out files in the collection order below, not by test count.
    if hasattr(config.option, "loadscopereorder"):
        config.option.loadscopereorder = False


def pytest_collection_modifyitems(config, items):
    """The files in decreasing recorded seconds (then by number of tests, xdist's own order);
    every file's tests stay together and in their order."""
    seconds = recorded_durations()
    default = float(np.median(list(seconds.values()))) if seconds else 0.0
    count = Counter(item.path.name for item in items)
    items.sort(key=lambda item: (-seconds.get(item.path.name, default), -count[item.path.name], str(item.path)))


_FILE_SECONDS: Counter = Counter()


def pytest_runtest_logreport(report):
    # in the controller, also for every worker's report (pytest-xdist)
    _FILE_SECONDS[Path(report.fspath).name] += report.duration


def pytest_sessionfinish(session, exitstatus):
    """``--record-durations``: the files that ran replace their entries; the others are kept."""
    config = session.config
    if not config.getoption("--record-durations") or hasattr(config, "workerinput") or not _FILE_SECONDS:
        return
    from stewart_jax._files import write_text_atomic

    seconds = recorded_durations()
    seconds.update({name: round(s, 1) for name, s in _FILE_SECONDS.items()})
    payload = {"about": "seconds per test file in the last recorded run (setup + call + teardown); "
                        "tests/conftest.py runs the longest first. Refresh: make durations",
               "seconds": dict(sorted(seconds.items(), key=lambda kv: -kv[1]))}
    write_text_atomic(str(DURATIONS), json.dumps(payload, indent=1) + "\n")


# Above this many memory mappings a test worker drops JAX's compiled programs (see below).
MAPPINGS_BEFORE_CLEARING = 25_000


def _memory_mappings() -> int:
    try:
        with open("/proc/self/maps", "rb") as f:
            return sum(1 for _ in f)
    except OSError:  # not Linux: no such limit to stay under
        return 0


def _release_compiled_programs() -> None:
    jax.clear_caches()
    gc.collect()


@pytest.fixture(scope="module", autouse=True)
def _release_programs_after_each_file():
    """Drop JAX's compiled programs after each test file, and after any test that leaves the
    worker above ``MAPPINGS_BEFORE_CLEARING`` memory mappings.

    NOTE: every XLA:CPU executable keeps its machine code in three memory mappings per compiled
    object (code, read-only data, data). A test worker that kept all of a long run's programs
    reached 48 000 mappings, and one large program later passed the kernel's limit
    (``vm.max_map_count``, 65 530 by default): LLVM's allocation failed and the worker died with a
    segmentation fault inside XLA's compilation (once an abort in its serialisation), after which
    pytest-xdist waited forever for it. One file of the FAST cabin record alone rises by 40 000."""
    yield
    _release_compiled_programs()


@pytest.fixture(autouse=True)
def _release_programs_when_near_the_limit():
    yield
    if _memory_mappings() > MAPPINGS_BEFORE_CLEARING:
        _release_compiled_programs()


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
