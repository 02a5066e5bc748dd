"""Model-discrepancy workflow: detect where a calibrated model disagrees with the data, name
the missing effect from a registry of candidates, add it, show the gap shrink.

The workflow (:func:`diagnose` → :class:`DiagnosisReport`) is generic over
:class:`AbstractDiscrepancyModel`. :func:`model_for` gives the model of a mechanism's family:
the 6-PSS calibration model of Wang et al. 2018, "Improved cuckoo calibration method of space
telescope secondary mirror adjusting mechanism", Infrared and Laser Engineering 47(5), with
its candidate effects registered under ``"6-pss"``, the 6-UPS strut model under ``"6-ups"``,
the 6-RUS rotary model under ``"6-rus"``; :func:`effect_names` and :func:`get_effect` read the
effect registry (:func:`register_effect`, :func:`register_model_family` extend it), and
:func:`simulate_hidden_effect` hides any effect in simulated measurements. A laser tracker's
points (:func:`point_rows`) are questioned by :func:`points_model`, the family's model seen
through the tracker with its noise.

The FAST feed-support adapter (Yin, Jiang, Chen, Yao, "Dynamic modeling of a cable-driven
parallel robot with a Stewart platform for use in FAST"; :func:`fast_responses`,
:func:`fast_model`, :func:`simulate_fast_measurement`, :class:`FastData`, effects under
``"fast"``) is loaded on first access, so that importing this package does not load the
cable-robot simulator; so is the FAST cabin-record model (a record of the cabin's free
vibration against the paper's quasi-static cables: :func:`read_cabin_record`,
:func:`cabin_record_model`, effects under ``"fast-cabin"``). The residual figures are in
:mod:`stewart_jax.plotting`.
"""

from typing import Any as _Any

from . import _effects as _effects, _rus as _rus, _ups_effects as _ups_effects  # register every family's candidates
from ._driver import diagnose as diagnose
from ._families import (
    load_fitted_model as load_fitted_model,
    model_for as model_for,
    register_model_family as register_model_family,
    save_fitted_model as save_fitted_model,
)
from ._hidden import (
    HiddenEffectData as HiddenEffectData,
    random_conditions as random_conditions,
    simulate_hidden_effect as simulate_hidden_effect,
    true_control_error as true_control_error,
    write_hidden_csv as write_hidden_csv,
)
from ._points import point_rows as point_rows, points_model as points_model
from ._registry import (
    AbstractDiscrepancyModel as AbstractDiscrepancyModel,
    Effect as Effect,
    effect_names as effect_names,
    get_effect as get_effect,
    register_effect as register_effect,
)
from ._report import (
    Candidate as Candidate,
    DiagnosisReport as DiagnosisReport,
    FittedModel as FittedModel,
    SkippedEffect as SkippedEffect,
)

_CABLE_ROBOT = ("FastData", "fast_model", "fast_responses", "simulate_fast_measurement")
_CABIN_RECORD = ("cabin_record_model", "read_cabin_record")


def __getattr__(name: str) -> _Any:
    if name in _CABLE_ROBOT:
        from . import _cable_robot

        return getattr(_cable_robot, name)
    if name in _CABIN_RECORD:
        from . import _cabin_record

        return getattr(_cabin_record, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_CABLE_ROBOT) | set(_CABIN_RECORD))
