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
- :mod:`stewart_jax.compensation` — telescope compensation tables in the controller's format;
- :mod:`stewart_jax.plotting` — figures (needs matplotlib).

Every name loads its subpackage on first use: ``import stewart_jax`` itself loads neither JAX
nor any subpackage, so that the command line answers ``--help`` at once.

NOTE: when JAX is loaded (by the first subpackage that computes, or before stewart_jax), the
package enables ``jax_enable_x64`` and JAX's persistent compilation cache (``stewart_jax._runtime``,
``stewart_jax._cache``): calibration carries micrometres over 100 mm (1e-5 relative), which
float32 cannot hold, and every array the library creates is float64.
"""

from __future__ import annotations

import importlib as _importlib
from importlib.metadata import PackageNotFoundError as _PackageNotFoundError, version as _version
from typing import TYPE_CHECKING

from . import _runtime

_runtime.install()

if TYPE_CHECKING:  # the names below, for readers and type checkers; at run time they load on first use
    from . import (
        cable_robot as cable_robot,
        calibration as calibration,
        compensation as compensation,
        discrepancy as discrepancy,
        mechanism as mechanism,
        optimise as optimise,
        plotting as plotting,
        study as study,
    )
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

_SUBPACKAGES = ("cable_robot", "calibration", "compensation", "discrepancy", "mechanism", "optimise", "plotting",
                "study")
_NAMES = {
    **dict.fromkeys(("euler_angles", "rotation_matrix"), "_math"),
    **dict.fromkeys(("calibrate", "calibration_problem", "control_error", "plan_poses", "read_csv",
                     "simulate_measurements", "summarize_control_error", "write_csv"), "calibration"),
    **dict.fromkeys(("actual_geometry", "forward_kinematics", "inverse_kinematics", "load_mechanism",
                     "nominal_geometry", "save_mechanism"), "mechanism"),
}
"""``{public name: the submodule that defines it}``."""

try:
    __version__ = _version("stewart-jax")
except _PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0+unknown"


def __getattr__(name: str):
    if name in _SUBPACKAGES:
        return _importlib.import_module(f".{name}", __name__)
    if name in _NAMES:
        return getattr(_importlib.import_module(f".{_NAMES[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted({*globals(), *_SUBPACKAGES, *_NAMES})
