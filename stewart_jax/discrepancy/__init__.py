"""Model-discrepancy workflow (SPEC §7): detect where a calibrated model disagrees with the
data, name the missing effect from a registry of candidates, add it, show the gap shrink.

The workflow is generic over :class:`AbstractDiscrepancyModel`; the 6-PSS calibration model
(:class:`PSSModel`) and the seven SPEC §7 effects are registered under ``"6-pss"``.
"""

from . import _effects as _effects  # registers the 6-PSS candidates
from .._cli.diagnose import add_diagnose_parser as add_diagnose_parser
from ._effects import DRIFT_TIME_UNIT_S as DRIFT_TIME_UNIT_S, T_REF_C as T_REF_C
from ._cable_robot import (
    FastModel as FastModel,
    fast_model as fast_model,
    fast_responses as fast_responses,
    simulate_fast_measurement as simulate_fast_measurement,
)
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
from ..plotting._discrepancy import plot_residuals as plot_residuals
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
    diagnose as diagnose,
    diagnose_many as diagnose_many,
    select_effects as select_effects,
    split_rows as split_rows,
    where_analysis as where_analysis,
)
