"""The FAST cable-driven feed support: elastic-catenary cables, a Stewart platform in the
moving cabin, and their coupled time simulation.

Yin J., Jiang P., Chen M., Yao R., *Dynamic modeling of a cable-driven parallel robot with a
Stewart platform for use in FAST* (manuscript received 2021-07-05; "Yin et al." in the
modules). Equation, table and figure numbers below are the paper's.

SI units (m, kg, s, N) and float64 throughout (the parent package enables ``jax_enable_x64``).

- :mod:`._catenary` — eqs. 6–13: cable end point from force and unstretched length, and the
  batched Newton inverse.
- :mod:`._stewart` — eqs. 3–5, 14–53: platform geometry (Table 1), leg kinematics, inverse
  dynamics in the moving frame.
- :mod:`._system` — eqs. 1–2, 54–60: the whole model and the cabin's equations of motion.
- :mod:`._statics` — the 24×24 initial equilibrium.
- :mod:`._coupled` — the coupled time simulation (Fig. 5) inside ``lax.scan``.
- :mod:`._scenario` — eqs. 61–66: the 5 Hz, 10 mm scenario, Table 2, Figs. 6–9.
- :mod:`._workspace` — beyond the paper: tension-feasible workspace on the focal surface.
- :mod:`._attitude` — beyond the paper: cabin attitudes (level, towards the centre of
  curvature, smallest feasible tilt, maximum least tension).
- :mod:`._modes` — beyond the paper: stiffness, mass matrix, natural frequencies and mode
  shapes of the cabin on its cables; the cables' own string frequencies.
- :mod:`._lumped` — beyond the paper: lumped-mass cables (MoorDyn's discretisation), statics
  of nodes and cabin together, every mode of the whole system (dense) or those below a
  cut-off (banded).
- :mod:`._lumped_blocks` — the lumped cables' sparsity: the Hessian by blocks (a star of six
  block-tridiagonal chains), chain-by-chain solves, the banded standard form.
- :mod:`._lumped_time` — beyond the paper: free and forced response on lumped-mass cables
  (velocity Verlet in ``lax.scan``, modal damping ratio, batched over positions).
- :mod:`._cabin_modal` — beyond the paper: the cabin's free vibration as a differentiable modal
  superposition, quasi-static or with the cables' inertia (Craig–Bampton reduction of the
  lumped cables), a changed EA, cabin mass or damping per mode group.
- :mod:`._free_decay` — beyond the paper: free-decay records of the cabin (quasi-static or
  lumped cables, time integration) sampled with tracker noise; the record CSV.

What a user calls: :func:`paper_fast_params` (:class:`FastParams`, with its
:class:`CableParams`); :func:`solve_catenary`; :func:`static_equilibrium`; :func:`run_scenario`,
the coupled simulation of §6 (compiled once with ``jax.jit(run_scenario,
static_argnames=("duration", "dt", "start", "method"))``); :func:`cabin_statics`,
:func:`workspace_map` and :func:`focal_surface_point`; :func:`solve_attitude` and
:func:`smallest_feasible_tilt`; :func:`cabin_modes`, :func:`modes_map` and
:func:`cable_string_modes`; :func:`lumped_statics`, :func:`lumped_modes`, :func:`lumped_low_modes`,
:func:`modal_summary` and :func:`simulate_lumped`; :func:`cabin_modal_model` (its ``modes``
under a :class:`CabinVariation`), :func:`lumped_free_decay` and :func:`quasi_static_free_decay`
(their ``sample``, a tracker's record). The modules' building blocks (the
catenary's Jacobian and starts, the platform's Newton–Euler dynamics, the integrator behind
:func:`run_scenario`, the modal sum and the record CSV's writer) are private.
"""


from ._attitude import (
    AttitudeSolution as AttitudeSolution,
    smallest_feasible_tilt as smallest_feasible_tilt,
    solve_attitude as solve_attitude,
)
from ._cabin_modal import CabinVariation as CabinVariation, cabin_modal_model as cabin_modal_model
from ._catenary import (
    CableParams as CableParams,
    CatenarySolution as CatenarySolution,
    solve_catenary as solve_catenary,
)
from ._free_decay import lumped_free_decay as lumped_free_decay, quasi_static_free_decay as quasi_static_free_decay
from ._lumped import (
    LumpedModes as LumpedModes,
    LumpedStatics as LumpedStatics,
    lumped_modes as lumped_modes,
    lumped_statics as lumped_statics,
)
from ._lumped_low import (
    LumpedLowModes as LumpedLowModes,
    ModalSummary as ModalSummary,
    lumped_low_modes as lumped_low_modes,
    modal_summary as modal_summary,
)
from ._lumped_time import LumpedTrajectory as LumpedTrajectory, simulate_lumped as simulate_lumped
from ._modes import (
    CabinModes as CabinModes,
    CableStringModes as CableStringModes,
    cabin_modes as cabin_modes,
    cable_string_modes as cable_string_modes,
    modes_map as modes_map,
)
from ._scenario import (
    PAPER_CORRELATION_CENTRE as PAPER_CORRELATION_CENTRE,
    PAPER_POSITIONS as PAPER_POSITIONS,
    PAPER_TABLE2 as PAPER_TABLE2,
    ScenarioResult as ScenarioResult,
    run_scenario as run_scenario,
)
from ._statics import StaticSolution as StaticSolution, static_equilibrium as static_equilibrium
from ._system import FastParams as FastParams, paper_fast_params as paper_fast_params
from ._workspace import (
    WORKSPACE_STATUS as WORKSPACE_STATUS,
    CableStatics as CableStatics,
    cabin_statics as cabin_statics,
    focal_surface_point as focal_surface_point,
    workspace_map as workspace_map,
)

