"""stewart_jax: kinematics, calibration and dynamics of Stewart platforms in JAX.

NOTE: importing the package enables ``jax_enable_x64`` once (SPEC §1): calibration carries
micrometres over 100 mm (1e-5 relative), which float32 cannot hold. Every array the library
creates is float64.
"""

import jax as _jax

_jax.config.update("jax_enable_x64", True)

from .calibration._problem import (
    ARCSEC as ARCSEC,
    COMPONENTS as COMPONENTS,
    UM as UM,
    CalibrationData as CalibrationData,
    CalibrationProblem as CalibrationProblem,
    ControlError as ControlError,
    calibration_cost as calibration_cost,
    calibration_problem as calibration_problem,
    control_error as control_error,
    error_in_report_units as error_in_report_units,
    feasible_box as feasible_box,
    make_calibration_data as make_calibration_data,
    stroke_residuals as stroke_residuals,
    summarize_control_error as summarize_control_error,
)
from .mechanism._pss import (
    PRESETS as PRESETS,
    Geometry as Geometry,
    actual_geometry as actual_geometry,
    geometry_from_dict as geometry_from_dict,
    geometry_from_params as geometry_from_params,
    load_geometry as load_geometry,
    nominal_geometry as nominal_geometry,
    preset_geometry as preset_geometry,
    rod_lengths as rod_lengths,
    save_geometry as save_geometry,
)
from .calibration._identifiability import (
    IdentifiabilityReport as IdentifiabilityReport,
    PosePlan as PosePlan,
    calibration_uncertainty as calibration_uncertainty,
    control_error_sensitivity as control_error_sensitivity,
    identifiability_report as identifiability_report,
    identification_jacobian as identification_jacobian,
    plan_poses_optimal as plan_poses_optimal,
    predicted_control_error_std as predicted_control_error_std,
)
from .calibration._csv import read_csv as read_csv, write_csv as write_csv
from .mechanism._kinematics import (
    FKSolution as FKSolution,
    IKSolution as IKSolution,
    euler_angles as euler_angles,
    forward_kinematics as forward_kinematics,
    ik_and_jacobian as ik_and_jacobian,
    inverse_kinematics as inverse_kinematics,
    kinematic_jacobian as kinematic_jacobian,
    rotation_matrix as rotation_matrix,
    solve_inverse_kinematics as solve_inverse_kinematics,
    upper_joints_in_base as upper_joints_in_base,
)
from .mechanism._batched import (
    forward_kinematics_newton as forward_kinematics_newton,
    inverse_kinematics_sharded as inverse_kinematics_sharded,
    inverse_kinematics_soa as inverse_kinematics_soa,
)
from .calibration._simulation import (
    PLANS as PLANS,
    TRAVEL_MM as TRAVEL_MM,
    TRAVEL_RAD as TRAVEL_RAD,
    LaserTracker as LaserTracker,
    SimulatedMeasurement as SimulatedMeasurement,
    default_tracker as default_tracker,
    plan_poses as plan_poses,
    random_poses as random_poses,
    rigid_fit as rigid_fit,
    sampling_plan_120 as sampling_plan_120,
    simulate_measurements as simulate_measurements,
    tracker_measure as tracker_measure,
    validation_poses as validation_poses,
)
from .calibration._methods import (
    METHODS as METHODS,
    calibrate as calibrate,
    calibrate_batch as calibrate_batch,
    make_solver as make_solver,
)
from .optimise import (
    MAX_STEPS as MAX_STEPS,
    NONFINITE as NONFINITE,
    SMCS as SMCS,
    STATUS_NAMES as STATUS_NAMES,
    SUCCESS as SUCCESS,
    VSASMCS as VSASMCS,
    AbstractSolver as AbstractSolver,
    CuckooSearch as CuckooSearch,
    JaxoptLevenbergMarquardt as JaxoptLevenbergMarquardt,
    LevenbergMarquardt as LevenbergMarquardt,
    NelderMead as NelderMead,
    OptimiseResult as OptimiseResult,
    PopulationState as PopulationState,
    SimplexCoefficients as SimplexCoefficients,
    VSASMCSThenLM as VSASMCSThenLM,
    hill_tail_index as hill_tail_index,
    lm_calibrate as lm_calibrate,
    mantegna_sigma as mantegna_sigma,
    mantegna_step as mantegna_step,
    minimise as minimise,
    simplex_on_worst as simplex_on_worst,
)

__version__ = "0.1.0"
