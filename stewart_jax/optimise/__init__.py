"""Generic batched optimisers for any objective over a box (pytrees welcome).

Nothing here knows about mechanisms or calibration: an objective is ``fn(y, args) -> scalar``
(population and simplex methods, :func:`minimise`) or a residual ``fn(y, args) -> vector``
(Levenberg–Marquardt, :func:`least_squares`, and for a batch of problems
:func:`least_squares_batch`); the optimistix argument order throughout.

One algorithm per module, each opening with its citation: ``_levy`` (Mantegna's Lévy steps),
``_cuckoo`` (cuckoo search, Yang & Deb 2009), ``_simplex`` (Nelder–Mead on nests; bounded
Nelder–Mead), ``_smcs`` and ``_vsa_smcs`` (Wang et al. 2018, §2), the standard population
baselines ``_cma_es`` (Hansen 2016), ``_differential_evolution`` (Storn & Price 1997) and ``_pso``
(Kennedy & Eberhart 1995; Shi & Eberhart 1998), ``_levenberg_marquardt``
(optimistix baseline), ``_jaxopt_lm`` (jaxopt cross-check), ``_batched_lm`` (the batched fast path: Nielsen's damping,
Cholesky per separable block, a refilled working set), ``_hybrid`` (VSA-SMCS then LM);
``_driver`` runs every iterative one in one ``lax.scan`` (``_box``: the box contract it checks first).

A new solver (a module of this package): subclass :class:`AbstractPopulationSolver` (or
:class:`AbstractSolver`) with its hyper-parameters as fields checked in ``__check_init__``;
implement ``step`` with the building blocks of ``_driver`` (``evaluate``, ``greedy``,
``uniform_in_box``, ``population_state``), ``_random.draw``, ``_levy.mantegna_step`` and
``_simplex.simplex_on_worst``; :func:`minimise` runs it. Every solve returns an
:class:`OptimiseResult`; statuses are :class:`RESULTS` items (``result.status ==
RESULTS.successful``), :func:`status_name` their stable names.
"""


from ._batched_lm import (
    BatchedLevenbergMarquardt as BatchedLevenbergMarquardt,
    Blocks as Blocks,
    least_squares_batch as least_squares_batch,
)
from ._cma_es import CMAES as CMAES
from ._cuckoo import CuckooSearch as CuckooSearch
from ._differential_evolution import DifferentialEvolution as DifferentialEvolution
from ._driver import (
    AbstractPopulationSolver as AbstractPopulationSolver,
    AbstractSolver as AbstractSolver,
    minimise as minimise,
)
from ._hybrid import VSASMCSThenLM as VSASMCSThenLM
from ._jaxopt_lm import JaxoptLevenbergMarquardt as JaxoptLevenbergMarquardt
from ._levenberg_marquardt import LevenbergMarquardt as LevenbergMarquardt, least_squares as least_squares
from ._objective import AbstractOptimiser as AbstractOptimiser, Objective as Objective
from ._pso import ParticleSwarm as ParticleSwarm
from ._result import RESULTS as RESULTS, OptimiseResult as OptimiseResult, status_name as status_name
from ._simplex import NelderMead as NelderMead, SimplexCoefficients as SimplexCoefficients
from ._smcs import SMCS as SMCS
from ._vsa_smcs import VSASMCS as VSASMCS

