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
  of nodes and cabin together, and every mode of the whole system.
- :mod:`._lumped_time` — beyond the paper: free and forced response on lumped-mass cables
  (velocity Verlet in ``lax.scan``, modal damping ratio, batched over positions).
- :mod:`._cabin_modal` — beyond the paper: the cabin's free vibration as a differentiable modal
  superposition, quasi-static or with the cables' inertia (Craig–Bampton reduction of the
  lumped cables), a changed EA, cabin mass or damping per mode group.
- :mod:`._free_decay` — beyond the paper: free-decay records of the cabin (quasi-static or
  lumped cables, time integration) sampled with tracker noise; the record CSV.
"""

from ._attitude import (
    ATTITUDES as ATTITUDES,
    AttitudeSolution as AttitudeSolution,
    attitude_summary as attitude_summary,
    max_min_tension_attitude as max_min_tension_attitude,
    rotation_from_vector as rotation_from_vector,
    smallest_feasible_tilt as smallest_feasible_tilt,
    solve_attitude as solve_attitude,
    tilt_angle as tilt_angle,
    towards_centre_attitude as towards_centre_attitude,
)
from ._cabin_modal import (
    DAMPING_GROUPS as DAMPING_GROUPS,
    CabinModalModel as CabinModalModel,
    CabinModalModes as CabinModalModes,
    CabinVariation as CabinVariation,
    cabin_modal_model as cabin_modal_model,
    cabin_modal_modes as cabin_modal_modes,
    damping_group_shares as damping_group_shares,
    free_response as free_response,
    scaled_params as scaled_params,
)
from ._catenary import (
    CableParams as CableParams,
    CatenarySolution as CatenarySolution,
    catenary_jacobian as catenary_jacobian,
    catenary_upper_end as catenary_upper_end,
    peyrot_goulois_start as peyrot_goulois_start,
    solve_catenary as solve_catenary,
    straight_bar_start as straight_bar_start,
)
from ._coupled import (
    CabinState as CabinState,
    Trajectory as Trajectory,
    matrix_to_quat as matrix_to_quat,
    quat_to_matrix as quat_to_matrix,
    simulate as simulate,
)
from ._free_decay import (
    RECORD_COLUMNS as RECORD_COLUMNS,
    CabinRecord as CabinRecord,
    FreeDecay as FreeDecay,
    check_record as check_record,
    lumped_free_decay as lumped_free_decay,
    quasi_static_free_decay as quasi_static_free_decay,
    sample_record as sample_record,
    write_record as write_record,
)
from ._lumped import (
    LumpedModes as LumpedModes,
    LumpedStatics as LumpedStatics,
    ModalSummary as ModalSummary,
    lumped_modes as lumped_modes,
    lumped_statics as lumped_statics,
    modal_summary as modal_summary,
)
from ._lumped_time import (
    LumpedTrajectory as LumpedTrajectory,
    simulate_lumped as simulate_lumped,
)
from ._modes import (
    CabinModes as CabinModes,
    CableStringModes as CableStringModes,
    cabin_mass_matrix as cabin_mass_matrix,
    cabin_modes as cabin_modes,
    cabin_modes_jit as cabin_modes_jit,
    cabin_stiffness as cabin_stiffness,
    cable_inertia_matrix as cable_inertia_matrix,
    cable_string_modes as cable_string_modes,
    modes_from_matrices as modes_from_matrices,
    modes_map as modes_map,
    paper_momentum_matrix as paper_momentum_matrix,
    static_wrench as static_wrench,
)
from ._scenario import (
    PAPER_CORRELATION_CENTRE as PAPER_CORRELATION_CENTRE,
    PAPER_POSITIONS as PAPER_POSITIONS,
    PAPER_TABLE2 as PAPER_TABLE2,
    ScenarioResult as ScenarioResult,
    rotation_vector as rotation_vector,
    run_scenario as run_scenario,
    run_scenario_jit as run_scenario_jit,
    sine_motion as sine_motion,
    system_momentum as system_momentum,
    table2_statistics as table2_statistics,
)
from ._statics import (
    StaticSolution as StaticSolution,
    static_equilibrium as static_equilibrium,
    static_equilibrium_jit as static_equilibrium_jit,
    static_residual as static_residual,
    straight_cable_start as straight_cable_start,
)
from ._stewart import (
    LegKinematics as LegKinematics,
    LowerMotion as LowerMotion,
    StewartForces as StewartForces,
    StewartParams as StewartParams,
    UpperMotion as UpperMotion,
    leg_kinematics as leg_kinematics,
    paper_stewart_params as paper_stewart_params,
    reaction_wrench as reaction_wrench,
    stewart_inverse_dynamics as stewart_inverse_dynamics,
    upper_platform_wrench as upper_platform_wrench,
)
from ._system import (
    CabinDynamics as CabinDynamics,
    FastParams as FastParams,
    anchor_positions as anchor_positions,
    cabin_accelerations as cabin_accelerations,
    cabin_residual as cabin_residual,
    cable_deltas as cable_deltas,
    paper_fast_params as paper_fast_params,
    static_lower_motion as static_lower_motion,
    tower_positions as tower_positions,
    upper_motion as upper_motion,
)
from ._workspace import (
    APERTURE_RADIUS as APERTURE_RADIUS,
    CURVATURE_CENTRE as CURVATURE_CENTRE,
    FOCAL_RADIUS as FOCAL_RADIUS,
    REFLECTOR_RADIUS as REFLECTOR_RADIUS,
    WORKSPACE_STATUS as WORKSPACE_STATUS,
    AssemblyBodies as AssemblyBodies,
    CableStatics as CableStatics,
    assembly_bodies as assembly_bodies,
    assembly_centre_of_mass as assembly_centre_of_mass,
    assess as assess,
    cabin_statics as cabin_statics,
    cabin_statics_jit as cabin_statics_jit,
    cable_profile as cable_profile,
    focal_surface_point as focal_surface_point,
    lowest_points as lowest_points,
    reflector_clearance as reflector_clearance,
    workspace_map as workspace_map,
    zenith_angle as zenith_angle,
)

