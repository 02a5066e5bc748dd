"""Calibration optimisers (seed 000 §2 and baselines). Import them from ``stewart_jax``.

One algorithm per module, each opening with its citation: :mod:`.levy` (Mantegna),
:mod:`.cuckoo` (CS), :mod:`.simplex` (Nelder–Mead on nests; bounded Nelder–Mead),
:mod:`.smcs`, :mod:`.vsa_smcs`, :mod:`.levenberg_marquardt` (optimistix baseline),
:mod:`.jaxopt_lm` (jaxopt cross-check), :mod:`.hybrid` (vsa-smcs+lm); :mod:`._driver` runs
any of the iterative ones; :mod:`.calibrate` is the entry point.
"""

from ._driver import (
    AbstractSolver as AbstractSolver,
    PopulationState as PopulationState,
    minimise as minimise,
)
from ._result import (
    MAX_STEPS as MAX_STEPS,
    NONFINITE as NONFINITE,
    STATUS_NAMES as STATUS_NAMES,
    SUCCESS as SUCCESS,
    OptimiseResult as OptimiseResult,
)
from ._cuckoo import CuckooSearch as CuckooSearch
from ._hybrid import VSASMCSThenLM as VSASMCSThenLM
from ._jaxopt_lm import JaxoptLevenbergMarquardt as JaxoptLevenbergMarquardt
from ._levenberg_marquardt import LevenbergMarquardt as LevenbergMarquardt, lm_calibrate as lm_calibrate
from ._levy import hill_tail_index as hill_tail_index, mantegna_sigma as mantegna_sigma, mantegna_step as mantegna_step
from ._simplex import (
    NelderMead as NelderMead,
    SimplexCoefficients as SimplexCoefficients,
    simplex_on_worst as simplex_on_worst,
)
from ._smcs import SMCS as SMCS
from ._vsa_smcs import VSASMCS as VSASMCS
