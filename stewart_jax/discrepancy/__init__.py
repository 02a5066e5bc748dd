"""Model-discrepancy workflow: detect where a calibrated model disagrees with the data, name
the missing effect from a registry of candidates, add it, show the gap shrink on held-out data.

The workflow is generic over :class:`AbstractDiscrepancyModel`; the 6-PSS calibration model of
Wang et al. (2018) (:class:`PSSModel`) and its seven candidate effects are registered under
``"6-pss"``. The FAST cable-robot adapter (``FastModel``, ``fast_model``, ``fast_responses``,
``simulate_fast_measurement``, ``FAST_EFFECTS``, ``FAST_MODEL_NAME``) is imported on first
use, so ``import stewart_jax.discrepancy`` does not load the cable-robot simulator; so is
``plot_residuals`` (matplotlib).
"""

import importlib as _importlib

from . import _effects as _effects  # registers the 6-PSS candidates
from ._effects import DRIFT_TIME_UNIT_S as DRIFT_TIME_UNIT_S, T_REF_C as T_REF_C
from ._hidden import (
    EFFECT_NAMES as EFFECT_NAMES,
    Conditions as Conditions,
    HiddenEffectData as HiddenEffectData,
    HiddenTruth as HiddenTruth,
    random_conditions as random_conditions,
    simulate_hidden_effect as simulate_hidden_effect,
    true_control_error as true_control_error,
    write_hidden_csv as write_hidden_csv,
)
from ._pss import (
    PSSModel as PSSModel,
    PSSState as PSSState,
    load_fitted_model as load_fitted_model,
    pss_model as pss_model,
    pss_strokes as pss_strokes,
    save_fitted_model as save_fitted_model,
)
from ._registry import (
    AbstractDiscrepancyModel as AbstractDiscrepancyModel,
    Effect as Effect,
    effects_for as effects_for,
    get_effect as get_effect,
    register_effect as register_effect,
)
from ._workflow import (
    Absorption as Absorption,
    Candidate as Candidate,
    DiagnosisReport as DiagnosisReport,
    FittedModel as FittedModel,
    absorption as absorption,
    chi2_sf as chi2_sf,
    diagnose as diagnose,
    diagnose_many as diagnose_many,
    f_sf as f_sf,
    heldout_chi2 as heldout_chi2,
    select_effects as select_effects,
    split_rows as split_rows,
    where_analysis as where_analysis,
)

_LAZY = {
    "FastModel": ("._cable_robot", "FastModel"),
    "fast_model": ("._cable_robot", "fast_model"),
    "fast_responses": ("._cable_robot", "fast_responses"),
    "simulate_fast_measurement": ("._cable_robot", "simulate_fast_measurement"),
    "FAST_EFFECTS": ("._cable_robot", "FAST_EFFECTS"),
    "FAST_MODEL_NAME": ("._cable_robot", "MODEL_NAME"),
    "plot_residuals": ("..plotting._discrepancy", "plot_residuals"),
}


def __getattr__(name: str):
    if name in _LAZY:
        module, attr = _LAZY[name]
        return getattr(_importlib.import_module(module, __name__), attr)
    raise AttributeError(f"module 'stewart_jax.discrepancy' has no attribute {name!r}")


def __dir__():
    return sorted([*globals(), *_LAZY])
