"""Calibration of any mechanism: measured data, the residual and cost, simulated measurements,
identifiability and pose planning, and the ``calibrate`` entry point over the method registry.

Wang H., Cao X. et al., "Improved cuckoo calibration method of space telescope secondary mirror
adjusting mechanism", Infrared and Laser Engineering 47(5), 2018, §1.2–§4.
"""

from .._units import (
    ARCSEC as ARCSEC,
    COMPONENTS as COMPONENTS,
    UM as UM,
    error_in_report_units as error_in_report_units,
)
from ._assessment import (
    CalibrationAssessment as CalibrationAssessment,
    assess_calibration as assess_calibration,
    duplicate_rows as duplicate_rows,
    implied_pose_errors as implied_pose_errors,
)
from ._csv import (
    REQUIRED_COLUMNS as REQUIRED_COLUMNS,
    read_csv as read_csv,
    read_csv_columns as read_csv_columns,
    write_csv as write_csv,
)
from ._identifiability import (
    IdentifiabilityReport as IdentifiabilityReport,
    PosePlan as PosePlan,
    calibration_uncertainty as calibration_uncertainty,
    control_error_sensitivity as control_error_sensitivity,
    identifiability_report as identifiability_report,
    identification_jacobian as identification_jacobian,
    plan_poses_optimal as plan_poses_optimal,
    pose_noise_covariance as pose_noise_covariance,
    predicted_control_error_std as predicted_control_error_std,
    stroke_noise_covariance as stroke_noise_covariance,
)
from ._methods import (
    METHOD_LABELS as METHOD_LABELS,
    METHOD_REGISTRY as METHOD_REGISTRY,
    METHODS as METHODS,
    Method as Method,
    calibrate as calibrate,
    calibrate_batch as calibrate_batch,
    make_solver as make_solver,
    method_label as method_label,
    register_method as register_method,
)
from ._points import (
    PointCalibration as PointCalibration,
    PointData as PointData,
    TrackerTargets as TrackerTargets,
    calibrate_points as calibrate_points,
    read_points_csv as read_points_csv,
    read_targets as read_targets,
    simulate_points as simulate_points,
    tracker_whitening as tracker_whitening,
    write_points_csv as write_points_csv,
)
from ._problem import (
    CalibrationData as CalibrationData,
    CalibrationProblem as CalibrationProblem,
    ControlError as ControlError,
    calibration_cost as calibration_cost,
    calibration_problem as calibration_problem,
    control_error as control_error,
    feasible_box as feasible_box,
    make_calibration_data as make_calibration_data,
    population_objective as population_objective,
    stroke_residuals as stroke_residuals,
    summarize_control_error as summarize_control_error,
)
from ._report import calibration_report as calibration_report
from ._simulation import (
    PLANS as PLANS,
    TRAVEL_MM as TRAVEL_MM,
    TRAVEL_RAD as TRAVEL_RAD,
    LaserTracker as LaserTracker,
    SimulatedMeasurement as SimulatedMeasurement,
    default_tracker as default_tracker,
    perturbed as perturbed,
    plan_poses as plan_poses,
    random_poses as random_poses,
    reachable_travel as reachable_travel,
    rigid_fit as rigid_fit,
    sampling_plan_120 as sampling_plan_120,
    simulate_measurements as simulate_measurements,
    tracker_for as tracker_for,
    tracker_measure as tracker_measure,
    validation_poses as validation_poses,
)
