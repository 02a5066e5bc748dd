"""Calibration of any mechanism: measured data, the residual and cost, simulated measurements,
identifiability and pose planning, and the ``calibrate`` entry point over the method registry.

Wang H., Cao X. et al., "Improved cuckoo calibration method of space telescope secondary mirror
adjusting mechanism", Infrared and Laser Engineering 47(5), 2018, §1.2–§4.

- Data: :class:`CalibrationData` from :func:`read_csv` or :func:`make_calibration_data`;
  :func:`write_csv`.
- The problem: :func:`calibration_problem` → :class:`CalibrationProblem`, whose ``residuals``
  and ``cost`` are eqs. 7–9 and whose ``lower``/``upper`` are the feasible box Ω.
- :func:`calibrate` (one problem) and :func:`calibrate_batch` (a batch of trials) with a method
  of :data:`METHOD_REGISTRY`; :func:`register_method` adds one.
- Accuracy: :func:`control_error` (:class:`ControlError`), :func:`summarize_control_error`,
  :func:`error_in_report_units`.
- Simulation: :func:`simulate_measurements` (:class:`SimulatedMeasurement`) at the poses of
  :func:`plan_poses`, :func:`random_poses` or :func:`validation_poses` within
  :func:`reachable_travel`; a true mechanism from :func:`perturbed`; a :class:`LaserTracker`
  from :func:`tracker_for`.
- Trust and planning: :func:`assess_calibration`, :func:`identifiability_report`,
  :func:`calibration_uncertainty`, :func:`predicted_control_error_std`,
  :func:`plan_poses_optimal`.
- The laser tracker's own points: :func:`read_targets`, :func:`read_points_csv`,
  :func:`calibrate_points`.
"""


from .._units import error_in_report_units as error_in_report_units
from ._assessment import CalibrationAssessment as CalibrationAssessment, assess_calibration as assess_calibration
from ._csv import read_csv as read_csv, write_csv as write_csv
from ._identifiability import (
    IdentifiabilityReport as IdentifiabilityReport,
    PosePlan as PosePlan,
    calibration_uncertainty as calibration_uncertainty,
    identifiability_report as identifiability_report,
    plan_poses_optimal as plan_poses_optimal,
    predicted_control_error_std as predicted_control_error_std,
)
from ._methods import (
    METHOD_REGISTRY as METHOD_REGISTRY,
    calibrate as calibrate,
    calibrate_batch as calibrate_batch,
    register_method as register_method,
)
from ._points import (
    PointCalibration as PointCalibration,
    PointData as PointData,
    TrackerTargets as TrackerTargets,
    calibrate_points as calibrate_points,
)
from ._points_io import read_points_csv as read_points_csv, read_targets as read_targets
from ._problem import (
    CalibrationData as CalibrationData,
    CalibrationProblem as CalibrationProblem,
    ControlError as ControlError,
    calibration_problem as calibration_problem,
    control_error as control_error,
    make_calibration_data as make_calibration_data,
    summarize_control_error as summarize_control_error,
)
from ._simulation import (
    LaserTracker as LaserTracker,
    SimulatedMeasurement as SimulatedMeasurement,
    perturbed as perturbed,
    plan_poses as plan_poses,
    random_poses as random_poses,
    reachable_travel as reachable_travel,
    simulate_measurements as simulate_measurements,
    tracker_for as tracker_for,
    validation_poses as validation_poses,
)

