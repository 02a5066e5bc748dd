"""Model-discrepancy workflow: detect where a calibrated model disagrees with the data, name
the missing effect from a registry of candidates, add it, show the gap shrink.

The workflow (:func:`diagnose`, :func:`diagnose_many`) is generic over
:class:`AbstractDiscrepancyModel`. The 6-PSS calibration model of Wang et al. 2018, "Improved
cuckoo calibration method of space telescope secondary mirror adjusting mechanism", Infrared
and Laser Engineering 47(5) (:class:`PSSModel`) and its candidate effects are registered under
``"6-pss"``, the 6-UPS strut model (:class:`UPSModel`) and its effects under ``"6-ups"``;
:func:`model_for` picks the model of a mechanism's family, :func:`effects_for` lists a model's
effects and :func:`simulate_hidden_effect` hides any of them in simulated measurements.

The FAST feed-support adapter (Yin, Jiang, Chen, Yao, "Dynamic modeling of a cable-driven
parallel robot with a Stewart platform for use in FAST"; :class:`FastModel`,
:func:`fast_model`, :func:`fast_responses`, :func:`simulate_fast_measurement`, effects under
``"fast"``) is loaded on first access, so that importing this package does not load the
cable-robot simulator; so is the FAST cabin-record model (a record of the cabin's free
vibration against the paper's quasi-static cables: :class:`CabinRecordModel`,
:func:`cabin_record_model`, :func:`read_cabin_record`, :func:`record_data`,
:func:`fitted_modes`, effects under ``"fast-cabin"``); ``plot_residuals`` (matplotlib) likewise.
"""

from typing import Any

from . import _effects as _effects, _ups_effects as _ups_effects  # register the 6-PSS and 6-UPS candidates
from ._driver import (
    MIN_DOF as MIN_DOF,
    check_sizes as check_sizes,
    diagnose as diagnose,
    diagnose_many as diagnose_many,
    select_effects as select_effects,
    split_rows as split_rows,
)
from ._effects import DRIFT_TIME_UNIT_S as DRIFT_TIME_UNIT_S, T_REF_C as T_REF_C
from ._families import (
    ModelFamily as ModelFamily,
    load_fitted_model as load_fitted_model,
    model_families as model_families,
    model_for as model_for,
    model_name_for as model_name_for,
    register_model_family as register_model_family,
    save_fitted_model as save_fitted_model,
)
from ._hidden import (
    Conditions as Conditions,
    HiddenEffectData as HiddenEffectData,
    HiddenTruth as HiddenTruth,
    hidden_pose_set as hidden_pose_set,
    random_conditions as random_conditions,
    simulate_hidden_effect as simulate_hidden_effect,
    true_control_error as true_control_error,
    write_hidden_csv as write_hidden_csv,
)
from ._pss import (
    PSS_MODEL_NAME as PSS_MODEL_NAME,
    PSSModel as PSSModel,
    PSSState as PSSState,
    pss_model as pss_model,
    pss_strokes as pss_strokes,
)
from ._registry import (
    AbstractDiscrepancyModel as AbstractDiscrepancyModel,
    Effect as Effect,
    effect_names as effect_names,
    effects_for as effects_for,
    get_effect as get_effect,
    register_effect as register_effect,
)
from ._report import (
    Candidate as Candidate,
    DiagnosisReport as DiagnosisReport,
    FittedModel as FittedModel,
    SkippedEffect as SkippedEffect,
)
from ._statistics import (
    Bin as Bin,
    FactorDependence as FactorDependence,
    WhereAnalysis as WhereAnalysis,
    WhereFlag as WhereFlag,
    bic as bic,
    chi2_sf as chi2_sf,
    f_sf as f_sf,
    heldout_chi2 as heldout_chi2,
    nested_p as nested_p,
    where_analysis as where_analysis,
)
from ._subspace import Absorption as Absorption, absorption as absorption
from ._ups import (
    UPS_MODEL_NAME as UPS_MODEL_NAME,
    UPSModel as UPSModel,
    UPSState as UPSState,
    gravity_axial_loads as gravity_axial_loads,
    ups_model as ups_model,
    ups_readings as ups_readings,
)

_CABLE_ROBOT = ("FastData", "FastModel", "FastResponses", "FastState", "fast_model", "fast_responses",
                "simulate_fast_measurement")


_CABIN_RECORD = ("CabinRecordData", "CabinRecordModel", "CabinRecordState", "cabin_record_model", "fitted_modes",
                 "read_cabin_record", "record_data")


def __getattr__(name: str) -> Any:
    if name in _CABLE_ROBOT:
        from . import _cable_robot

        return getattr(_cable_robot, name)
    if name in _CABIN_RECORD:
        from . import _cabin_record

        return getattr(_cabin_record, name)
    if name == "plot_residuals":  # a figure: matplotlib is loaded on first use only
        from ..plotting import plot_residuals

        return plot_residuals
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_CABLE_ROBOT) | set(_CABIN_RECORD) | {"plot_residuals"})
