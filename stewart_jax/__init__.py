"""stewart_jax: kinematics, calibration and dynamics of hexapods (Stewart platforms) in JAX.

The top level holds the core a user needs to move, simulate and calibrate a mechanism (presets
and geometry files, forward and inverse kinematics, the measurement CSV, simulated measurements,
``calibrate`` and the control error); the rest lives in named subpackages:

- :mod:`stewart_jax.mechanism` — the mechanism abstraction, its families and presets, kinematics
  and the batched fast paths;
- :mod:`stewart_jax.calibration` — data, residuals, simulated measurements, identifiability and
  pose planning, ``calibrate`` over the method registry;
- :mod:`stewart_jax.optimise` — generic batched optimisers (cuckoo search, SMCS, VSA-SMCS,
  bounded Nelder–Mead, Levenberg–Marquardt) for any objective;
- :mod:`stewart_jax.study` — the papers' Monte Carlo studies;
- :mod:`stewart_jax.discrepancy` — the model-discrepancy workflow;
- :mod:`stewart_jax.cable_robot` — the FAST cable-driven feed support (Yin et al.);
- :mod:`stewart_jax.plotting` — figures (needs matplotlib).

The last three are imported on first use.

NOTE: importing the package enables ``jax_enable_x64`` once: calibration carries micrometres
over 100 mm (1e-5 relative), which float32 cannot hold. Every array the library creates is
float64.
"""

import importlib as _importlib
from importlib.metadata import PackageNotFoundError as _PackageNotFoundError, version as _version

import jax as _jax

_jax.config.update("jax_enable_x64", True)

from . import calibration as calibration, mechanism as mechanism, optimise as optimise, study as study
from ._math import euler_angles as euler_angles, rotation_matrix as rotation_matrix
from .calibration import (
    calibrate as calibrate,
    calibration_problem as calibration_problem,
    control_error as control_error,
    plan_poses as plan_poses,
    read_csv as read_csv,
    simulate_measurements as simulate_measurements,
    summarize_control_error as summarize_control_error,
    write_csv as write_csv,
)
from .mechanism import (
    actual_geometry as actual_geometry,
    forward_kinematics as forward_kinematics,
    inverse_kinematics as inverse_kinematics,
    load_mechanism as load_mechanism,
    nominal_geometry as nominal_geometry,
    save_mechanism as save_mechanism,
)

_LAZY = ("cable_robot", "discrepancy", "plotting")

try:
    __version__ = _version("stewart-jax")
except _PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0+unknown"


def __getattr__(name: str):
    if name in _LAZY:
        return _importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted({*globals(), *_LAZY})
