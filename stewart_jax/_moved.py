"""Names that left the public namespaces, and the deprecation shim that still serves them.

The public surface is what a user calls: mechanisms, solvers, the result types a user receives
and the main functions. Aliases, function wrappers around methods, ``_jit`` variants, helpers,
solver states and constants used inside the package left it; each still answers from its old
place through the package's module-level ``__getattr__``, with a ``DeprecationWarning`` that
names the replacement, and is listed neither by ``dir()`` nor on the API pages.

:data:`MOVED` is the one table: ``{package: {old name: (where the object lives, replacement)}}``.
``docs/api/moved.md`` is generated from it (:func:`moved_markdown`; ``tests/test_api_docs.py``
checks that the page is current) and the shim test walks it.
"""

from __future__ import annotations

import importlib
import warnings
from typing import Any

_CAL = "stewart_jax.calibration"
_MECH = "stewart_jax.mechanism"
_DISC = "stewart_jax.discrepancy"
_CR = "stewart_jax.cable_robot"

_SIMULATE = f"private: the coupled integrator behind {_CR}.run_scenario"
_STEWART = f"private: the Newton–Euler dynamics of the cabin's Stewart platform inside {_CR}.run_scenario"
_MOTION = f"private: the cabin's equations of motion inside {_CR}.run_scenario"
_CATENARY = f"private: a building block of {_CR}.solve_catenary"
_MODES = f"private: a building block of {_CR}.cabin_modes (its result carries stiffness, mass, shapes)"
_REFLECTOR = f"private: FAST's reflector geometry inside {_CR}.cabin_statics and {_CR}.workspace_map"
_ROTATION = "private: a rotation helper of the FAST model"
_POPULATION = "private: a building block of the population solvers (stewart_jax/optimise/_driver.py)"
_LEVY = "private: Mantegna's Lévy steps inside CuckooSearch, SMCS and VSASMCS"
_STATE = "private: a solver's state (OptimiseResult is what a solve returns)"
_PAIRED = "stewart_jax.study.paired_comparison(a, b) (Wilcoxon p-value and bootstrap median ratio, JSON-ready)"
_MODEL = f"{_DISC}.model_for(mechanism, sigma_um, sigma_arcsec, sigma_stroke_um)"
_MODEL_CLASS = f"{_DISC}.model_for(mechanism, ...) returns it; {_DISC}.AbstractDiscrepancyModel documents it"
_EFFECT_STATE = "private: the state a family's effects change"
_WORKFLOW_STATS = f"private: the workflow's statistics; {_DISC}.Candidate and DiagnosisReport carry their values"
_ENGINE = f"private: the batched engine of the discrepancy benchmarks; {_DISC}.diagnose for one data set"
_PRESET = f'{_MECH}.preset("{{}}")'

MOVED: dict[str, dict[str, tuple[str, str]]] = {
    "stewart_jax": {
        "ARCSEC": ("stewart_jax._units:ARCSEC", "private: one arc-second in rad, math.pi / 648000"),
        "COMPONENTS": ("stewart_jax._units:COMPONENTS",
                       "private: the pose components dx, dy, dz, phi, theta, psi (the order of every pose)"),
        "UM": ("stewart_jax._units:UM", "private: one µm in mm, 1e-3"),
        "error_in_report_units": (f"{_CAL}:error_in_report_units", f"{_CAL}.error_in_report_units"),
        "METHODS": ("stewart_jax.calibration._methods:METHODS", f"tuple({_CAL}.METHOD_REGISTRY)"),
        "CalibrationData": (f"{_CAL}:CalibrationData", f"{_CAL}.CalibrationData"),
        "calibration_cost": ("stewart_jax.calibration._problem:calibration_cost",
                             "stewart_jax.calibration_problem(data, mechanism).cost(params)"),
        "make_calibration_data": (f"{_CAL}:make_calibration_data", f"{_CAL}.make_calibration_data"),
        "random_poses": (f"{_CAL}:random_poses", f"{_CAL}.random_poses"),
        "stroke_residuals": ("stewart_jax.calibration._problem:stroke_residuals",
                             "stewart_jax.calibration_problem(data, mechanism).residuals(params)"),
        "validation_poses": (f"{_CAL}:validation_poses", f"{_CAL}.validation_poses"),
        "AbstractMechanism": (f"{_MECH}:AbstractMechanism", f"{_MECH}.AbstractMechanism"),
        "FKSolution": (f"{_MECH}:FKSolution", f"{_MECH}.FKSolution"),
        "Geometry": (f"{_MECH}:PSSMechanism", f"{_MECH}.PSSMechanism"),
        "IKSolution": (f"{_MECH}:IKSolution", f"{_MECH}.IKSolution"),
        "PSSMechanism": (f"{_MECH}:PSSMechanism", f"{_MECH}.PSSMechanism"),
        "geometry_from_params": ("stewart_jax.mechanism._pss:geometry_from_params",
                                 f"{_MECH}.PSSMechanism.from_params(params, v0)"),
        "kinematic_jacobian": ("stewart_jax.mechanism._kinematics:kinematic_jacobian",
                               "mechanism.ik_and_jacobian(poses)[2]"),
        "solve_inverse_kinematics": ("stewart_jax.mechanism._kinematics:solve_inverse_kinematics",
                                     "mechanism.solve_inverse_kinematics(poses)"),
    },
    _MECH: {
        "ik_and_jacobian": ("stewart_jax.mechanism._kinematics:ik_and_jacobian", "mechanism.ik_and_jacobian(poses)"),
        "kinematic_jacobian": ("stewart_jax.mechanism._kinematics:kinematic_jacobian",
                               "mechanism.ik_and_jacobian(poses)[2]"),
        "solve_inverse_kinematics": ("stewart_jax.mechanism._kinematics:solve_inverse_kinematics",
                                     "mechanism.solve_inverse_kinematics(poses)"),
        "upper_joints_in_base": ("stewart_jax.mechanism._kinematics:upper_joints_in_base",
                                 "mechanism.moving_joints(poses)"),
        "N_PARAMS": ("stewart_jax.mechanism._pss:N_PARAMS", "PSSMechanism.n_params (36 for the paper's parameter set)"),
        "Geometry": ("stewart_jax.mechanism._pss:PSSMechanism", f"{_MECH}.PSSMechanism"),
        "geometry_from_dict": ("stewart_jax.mechanism._pss:geometry_from_dict", f"{_MECH}.PSSMechanism.from_dict(d)"),
        "geometry_from_params": ("stewart_jax.mechanism._pss:geometry_from_params",
                                 f"{_MECH}.PSSMechanism.from_params(params, v0)"),
        "rod_lengths": ("stewart_jax.mechanism._pss:rod_lengths", "geometry.rod_lengths (a property)"),
        "DEFAULT_FAMILY": ("stewart_jax.mechanism._registry:DEFAULT_FAMILY",
                           'private: a geometry without a "mechanism" key is a 6-PSS'),
        "family": ("stewart_jax.mechanism._registry:family",
                   f'{_MECH}.mechanism_from_dict(d) builds the family that d["mechanism"] names'),
        "rotary_stewart": ("stewart_jax.mechanism._rus:rotary_stewart", _PRESET.format("rotary_stewart")),
        "FAST_STEWART_TRAVEL": ("stewart_jax.mechanism._ups:FAST_STEWART_TRAVEL",
                                _PRESET.format("fast_stewart") + ".travel_half_widths"),
        "fast_stewart": ("stewart_jax.mechanism._ups:fast_stewart", _PRESET.format("fast_stewart")),
        "rubin_camera": ("stewart_jax.mechanism._ups:rubin_camera", _PRESET.format("rubin_camera")),
        "rubin_m2": ("stewart_jax.mechanism._ups:rubin_m2", _PRESET.format("rubin_m2")),
        "MAX_TRAVEL_RAYS": ("stewart_jax.mechanism._workspace:MAX_TRAVEL_RAYS",
                            f"private: {_MECH}.max_travel's rays are +x, -x, +y, -y, +z, -z, +φ, -φ, +θ, -θ, +ψ, -ψ"),
        "fibonacci_sphere": ("stewart_jax.mechanism._workspace:fibonacci_sphere",
                             f"private: {_MECH}.translation_envelope and orientation_envelope spread their rays"),
    },
    _CAL: {
        "ARCSEC": ("stewart_jax._units:ARCSEC", "private: one arc-second in rad, math.pi / 648000"),
        "COMPONENTS": ("stewart_jax._units:COMPONENTS",
                       "private: the pose components dx, dy, dz, phi, theta, psi (the order of every pose)"),
        "UM": ("stewart_jax._units:UM", "private: one µm in mm, 1e-3"),
        "duplicate_rows": ("stewart_jax.calibration._assessment:duplicate_rows",
                           f"{_CAL}.assess_calibration(...).duplicate_rows"),
        "implied_pose_errors": ("stewart_jax.calibration._assessment:implied_pose_errors",
                                "private: stewart-jax calibrate reports the implied pose errors"),
        "REQUIRED_COLUMNS": ("stewart_jax.calibration._csv:REQUIRED_COLUMNS",
                             "private: the measurement CSV's columns are in docs/conventions.md"),
        "read_csv_columns": ("stewart_jax.calibration._csv:read_csv_columns", f"private: {_CAL}.read_csv"),
        "control_error_sensitivity": ("stewart_jax.calibration._identifiability:control_error_sensitivity",
                                      f"private: a building block of {_CAL}.predicted_control_error_std"),
        "identification_jacobian": ("stewart_jax.calibration._identifiability:identification_jacobian",
                                    "mechanism.parameter_jacobian(poses)"),
        "pose_noise_covariance": ("stewart_jax.calibration._identifiability:pose_noise_covariance",
                                  f"private: {_CAL}.identifiability_report and calibration_uncertainty take "
                                  "sigma_um, sigma_arcsec"),
        "stroke_noise_covariance": ("stewart_jax.calibration._identifiability:stroke_noise_covariance",
                                    f"private: a building block of {_CAL}.identifiability_report"),
        "METHOD_LABELS": ("stewart_jax.calibration._methods:METHOD_LABELS", f"{_CAL}.METHOD_REGISTRY[name].label"),
        "METHODS": ("stewart_jax.calibration._methods:METHODS", f"tuple({_CAL}.METHOD_REGISTRY)"),
        "Method": ("stewart_jax.calibration._methods:Method",
                   f"private: the type of {_CAL}.METHOD_REGISTRY's values (name, label, factory, kind, reference)"),
        "make_solver": ("stewart_jax.calibration._methods:make_solver",
                        f"{_CAL}.METHOD_REGISTRY[name].factory(**options)"),
        "method_label": ("stewart_jax.calibration._methods:method_label", f"{_CAL}.METHOD_REGISTRY[name].label"),
        "simulate_points": ("stewart_jax.calibration._points:simulate_points",
                            "private: stewart-jax simulate --points --targets T.json"),
        "tracker_whitening": ("stewart_jax.calibration._points:tracker_whitening",
                              f"private: the tracker noise model of {_CAL}.calibrate_points"),
        "write_points_csv": ("stewart_jax.calibration._points:write_points_csv",
                             "private: stewart-jax simulate --points writes points files"),
        "calibration_cost": ("stewart_jax.calibration._problem:calibration_cost",
                             f"{_CAL}.calibration_problem(data, mechanism).cost(params)"),
        "feasible_box": ("stewart_jax.calibration._problem:feasible_box",
                         f"{_CAL}.calibration_problem(data, nominal, half_width, half_width_mrad).lower / .upper"),
        "population_objective": ("stewart_jax.calibration._problem:population_objective",
                                 f"{_CAL}.calibration_problem(...).population_cost(params)"),
        "stroke_residuals": ("stewart_jax.calibration._problem:stroke_residuals",
                             f"{_CAL}.calibration_problem(data, mechanism).residuals(params)"),
        "calibration_report": ("stewart_jax.calibration._report:calibration_report",
                               "private: stewart-jax calibrate --report OUT.md"),
        "PLANS": ("stewart_jax.calibration._simulation:PLANS",
                  f'private: {_CAL}.plan_poses takes "paper8", "plan120" or "validation42"'),
        "TRAVEL_MM": ("stewart_jax.calibration._simulation:TRAVEL_MM",
                      f"private: the paper's travel, ±1 mm; {_CAL}.reachable_travel(mechanism) for a mechanism's"),
        "TRAVEL_RAD": ("stewart_jax.calibration._simulation:TRAVEL_RAD",
                       f"private: the paper's travel, ±1° (rad); {_CAL}.reachable_travel(mechanism) for a mechanism's"),
        "default_tracker": ("stewart_jax.calibration._simulation:default_tracker",
                            f"{_CAL}.tracker_for(mechanism) (the same three balls for the paper's 6-PSS)"),
        "rigid_fit": ("stewart_jax.calibration._simulation:rigid_fit",
                      f"private: the Kabsch fit inside {_CAL}.LaserTracker's measurement"),
        "sampling_plan_120": ("stewart_jax.calibration._simulation:sampling_plan_120",
                              f'{_CAL}.plan_poses("plan120", key, half)'),
        "tracker_measure": ("stewart_jax.calibration._simulation:tracker_measure",
                            f"{_CAL}.simulate_measurements(..., tracker=tracker)"),
    },
    "stewart_jax.optimise": {
        "BatchedLMState": ("stewart_jax.optimise._batched_lm:BatchedLMState", _STATE),
        "CMAESState": ("stewart_jax.optimise._cma_es:CMAESState", _STATE),
        "PopulationState": ("stewart_jax.optimise._driver:PopulationState", _STATE),
        "PSOState": ("stewart_jax.optimise._pso:PSOState", _STATE),
        "draw": ("stewart_jax.optimise._random:draw", _POPULATION),
        "evaluate": ("stewart_jax.optimise._driver:evaluate", _POPULATION),
        "greedy": ("stewart_jax.optimise._driver:greedy", _POPULATION),
        "materialize": ("stewart_jax.optimise._driver:materialize", _POPULATION),
        "population_state": ("stewart_jax.optimise._driver:population_state", _POPULATION),
        "uniform_in_box": ("stewart_jax.optimise._driver:uniform_in_box", _POPULATION),
        "hill_tail_index": ("stewart_jax.optimise._levy:hill_tail_index", _LEVY),
        "mantegna_sigma": ("stewart_jax.optimise._levy:mantegna_sigma", _LEVY),
        "mantegna_step": ("stewart_jax.optimise._levy:mantegna_step", _LEVY),
        "simplex_on_worst": ("stewart_jax.optimise._simplex:simplex_on_worst",
                             "private: the simplex step inside SMCS and VSASMCS"),
        "STATUS_NAMES": ("stewart_jax.optimise._result:STATUS_NAMES",
                         "stewart_jax.optimise.status_name(status) (the names of the RESULTS items)"),
        "status_code": ("stewart_jax.optimise._result:status_code",
                        "result.status == stewart_jax.optimise.RESULTS.<item>, or status_name(result.status)"),
    },
    "stewart_jax.study": {
        "RatioInterval": ("stewart_jax.study._statistics:RatioInterval", _PAIRED),
        "WilcoxonResult": ("stewart_jax.study._statistics:WilcoxonResult", _PAIRED),
        "bootstrap_median_ratio": ("stewart_jax.study._statistics:bootstrap_median_ratio", _PAIRED),
        "wilcoxon_signed_rank": ("stewart_jax.study._statistics:wilcoxon_signed_rank", _PAIRED),
        "evaluations_to_solve": ("stewart_jax.study._statistics:evaluations_to_solve",
                                 "private: a building block of stewart_jax.study.data_profiles"),
        "BEFORE": ("stewart_jax.study._study:BEFORE", 'private: the row "before" of run_study\'s result'),
        "METHOD_LABELS": ("stewart_jax.study._study:METHOD_LABELS", f"{_CAL}.METHOD_REGISTRY[name].label"),
    },
    _DISC: {
        "MIN_DOF": ("stewart_jax.discrepancy._driver:MIN_DOF", f"private: {_DISC}.diagnose checks the data's size"),
        "check_sizes": ("stewart_jax.discrepancy._driver:check_sizes",
                        f"private: {_DISC}.diagnose checks the data's size"),
        "diagnose_many": ("stewart_jax.discrepancy._driver:diagnose_many", _ENGINE),
        "select_effects": ("stewart_jax.discrepancy._driver:select_effects", _ENGINE),
        "split_rows": ("stewart_jax.discrepancy._driver:split_rows", _ENGINE),
        "DRIFT_TIME_UNIT_S": ("stewart_jax.discrepancy._effects:DRIFT_TIME_UNIT_S",
                              "private: the drift effects' time unit, 1 h"),
        "T_REF_C": ("stewart_jax.discrepancy._effects:T_REF_C",
                    "private: the thermal effects' reference temperature, 20 °C"),
        "ModelFamily": ("stewart_jax.discrepancy._families:ModelFamily",
                        f"private: the entry {_DISC}.register_model_family makes"),
        "model_families": ("stewart_jax.discrepancy._families:model_families",
                           f"{_DISC}.model_for(mechanism).name for each of stewart_jax.mechanism.families()"),
        "model_name_for": ("stewart_jax.discrepancy._families:model_name_for", f"{_DISC}.model_for(mechanism).name"),
        "Conditions": ("stewart_jax.discrepancy._hidden:Conditions",
                       f"private: the type {_DISC}.random_conditions returns (directions, temperature, time)"),
        "HiddenTruth": ("stewart_jax.discrepancy._hidden:HiddenTruth",
                        f"private: the type of {_DISC}.HiddenEffectData.truth"),
        "hidden_pose_set": ("stewart_jax.discrepancy._hidden:hidden_pose_set",
                            f"private: {_DISC}.simulate_hidden_effect draws its poses with it"),
        "PSS_MODEL_NAME": ("stewart_jax.discrepancy._pss:PSS_MODEL_NAME",
                           f'"6-pss" ({_DISC}.model_for(mechanism).name)'),
        "PSSModel": ("stewart_jax.discrepancy._pss:PSSModel", _MODEL_CLASS),
        "PSSState": ("stewart_jax.discrepancy._pss:PSSState", _EFFECT_STATE),
        "pss_model": ("stewart_jax.discrepancy._pss:pss_model", _MODEL),
        "pss_strokes": ("stewart_jax.discrepancy._pss:pss_strokes", "private: the 6-PSS model's readings"),
        "effects_for": ("stewart_jax.discrepancy._registry:effects_for",
                        f"{_DISC}.get_effect(model, name) for name in {_DISC}.effect_names(model)"),
        "RUSModel": ("stewart_jax.discrepancy._rus:RUSModel", _MODEL_CLASS),
        "RUSState": ("stewart_jax.discrepancy._rus:RUSState", _EFFECT_STATE),
        "rus_model": ("stewart_jax.discrepancy._rus:rus_model", _MODEL),
        "Bin": ("stewart_jax.discrepancy._statistics:Bin", _WORKFLOW_STATS),
        "FactorDependence": ("stewart_jax.discrepancy._statistics:FactorDependence", _WORKFLOW_STATS),
        "WhereAnalysis": ("stewart_jax.discrepancy._statistics:WhereAnalysis", _WORKFLOW_STATS),
        "WhereFlag": ("stewart_jax.discrepancy._statistics:WhereFlag", _WORKFLOW_STATS),
        "bic": ("stewart_jax.discrepancy._statistics:bic", _WORKFLOW_STATS),
        "chi2_sf": ("stewart_jax.discrepancy._statistics:chi2_sf", _WORKFLOW_STATS),
        "f_sf": ("stewart_jax.discrepancy._statistics:f_sf", _WORKFLOW_STATS),
        "heldout_chi2": ("stewart_jax.discrepancy._statistics:heldout_chi2", _WORKFLOW_STATS),
        "nested_p": ("stewart_jax.discrepancy._statistics:nested_p", _WORKFLOW_STATS),
        "where_analysis": ("stewart_jax.discrepancy._statistics:where_analysis", _WORKFLOW_STATS),
        "Absorption": ("stewart_jax.discrepancy._subspace:Absorption", _WORKFLOW_STATS),
        "absorption": ("stewart_jax.discrepancy._subspace:absorption", _WORKFLOW_STATS),
        "UPS_MODEL_NAME": ("stewart_jax.discrepancy._ups:UPS_MODEL_NAME",
                           f'"6-ups" ({_DISC}.model_for(mechanism).name)'),
        "UPSModel": ("stewart_jax.discrepancy._ups:UPSModel", _MODEL_CLASS),
        "UPSState": ("stewart_jax.discrepancy._ups:UPSState", _EFFECT_STATE),
        "gravity_axial_loads": ("stewart_jax.discrepancy._ups:gravity_axial_loads",
                                "private: the loads of the 6-UPS gravity effect"),
        "ups_model": ("stewart_jax.discrepancy._ups:ups_model", _MODEL),
        "ups_readings": ("stewart_jax.discrepancy._ups:ups_readings", "private: the 6-UPS model's readings"),
        "FastModel": ("stewart_jax.discrepancy._cable_robot:FastModel",
                      f"{_DISC}.fast_model(responses) returns it; {_DISC}.AbstractDiscrepancyModel documents it"),
        "FastResponses": ("stewart_jax.discrepancy._cable_robot:FastResponses",
                          f"private: the type {_DISC}.fast_responses returns"),
        "FastState": ("stewart_jax.discrepancy._cable_robot:FastState", _EFFECT_STATE),
        "plot_residuals": ("stewart_jax.plotting:plot_residuals", "stewart_jax.plotting.plot_residuals"),
    },
    _CR: {
        "ATTITUDES": ("stewart_jax.cable_robot._attitude:ATTITUDES",
                      f'private: {_CR}.solve_attitude takes "level", "towards-centre", "smallest-tilt" or '
                      '"max-min-tension"'),
        "attitude_summary": ("stewart_jax.cable_robot._attitude:attitude_summary",
                             "private: the attitude in stewart-jax fast's JSON"),
        "max_min_tension_attitude": ("stewart_jax.cable_robot._attitude:max_min_tension_attitude",
                                     f'{_CR}.solve_attitude(params, position, "max-min-tension")'),
        "towards_centre_attitude": ("stewart_jax.cable_robot._attitude:towards_centre_attitude",
                                    f'{_CR}.solve_attitude(params, position, "towards-centre").R'),
        "rotation_from_vector": ("stewart_jax.cable_robot._attitude:rotation_from_vector", _ROTATION),
        "tilt_angle": ("stewart_jax.cable_robot._attitude:tilt_angle", f"{_CR}.AttitudeSolution.tilt_rad"),
        "catenary_jacobian": ("stewart_jax.cable_robot._catenary:catenary_jacobian", _CATENARY),
        "catenary_upper_end": ("stewart_jax.cable_robot._catenary:catenary_upper_end", _CATENARY),
        "peyrot_goulois_start": ("stewart_jax.cable_robot._catenary:peyrot_goulois_start", _CATENARY),
        "straight_bar_start": ("stewart_jax.cable_robot._catenary:straight_bar_start", _CATENARY),
        "CabinState": ("stewart_jax.cable_robot._coupled:CabinState", _SIMULATE),
        "Trajectory": ("stewart_jax.cable_robot._coupled:Trajectory", _SIMULATE),
        "matrix_to_quat": ("stewart_jax.cable_robot._coupled:matrix_to_quat", _ROTATION),
        "quat_to_matrix": ("stewart_jax.cable_robot._coupled:quat_to_matrix", _ROTATION),
        "simulate": ("stewart_jax.cable_robot._coupled:simulate", _SIMULATE),
        "cabin_mass_matrix": ("stewart_jax.cable_robot._modes:cabin_mass_matrix", _MODES),
        "cabin_modes_jit": ("stewart_jax.cable_robot._modes:cabin_modes_jit", f"jax.jit({_CR}.cabin_modes)"),
        "cabin_stiffness": ("stewart_jax.cable_robot._modes:cabin_stiffness", _MODES),
        "cable_inertia_matrix": ("stewart_jax.cable_robot._modes:cable_inertia_matrix", _MODES),
        "modes_from_matrices": ("stewart_jax.cable_robot._modes:modes_from_matrices", _MODES),
        "paper_momentum_matrix": ("stewart_jax.cable_robot._modes:paper_momentum_matrix", _MODES),
        "static_wrench": ("stewart_jax.cable_robot._modes:static_wrench", _MODES),
        "rotation_vector": ("stewart_jax.cable_robot._scenario:rotation_vector", _ROTATION),
        "run_scenario_jit": ("stewart_jax.cable_robot._scenario:run_scenario_jit",
                             f'jax.jit({_CR}.run_scenario, static_argnames=("duration", "dt", "start", "method"))'),
        "sine_motion": ("stewart_jax.cable_robot._scenario:sine_motion",
                        f"{_CR}.run_scenario(params, position, amplitude=..., frequency=...)"),
        "system_momentum": ("stewart_jax.cable_robot._scenario:system_momentum", _MOTION),
        "table2_statistics": ("stewart_jax.cable_robot._scenario:table2_statistics",
                              f"{_CR}.run_scenario(...).correlation / .std / .amplitude"),
        "static_equilibrium_jit": ("stewart_jax.cable_robot._statics:static_equilibrium_jit",
                                   f"jax.jit({_CR}.static_equilibrium)"),
        "static_residual": ("stewart_jax.cable_robot._statics:static_residual",
                            f"private: the equations {_CR}.static_equilibrium solves"),
        "straight_cable_start": ("stewart_jax.cable_robot._statics:straight_cable_start",
                                 f"private: the start of {_CR}.static_equilibrium"),
        "LegKinematics": ("stewart_jax.cable_robot._stewart:LegKinematics", _STEWART),
        "LowerMotion": ("stewart_jax.cable_robot._stewart:LowerMotion", _STEWART),
        "StewartForces": ("stewart_jax.cable_robot._stewart:StewartForces", _STEWART),
        "StewartParams": ("stewart_jax.cable_robot._stewart:StewartParams",
                          f"{_CR}.paper_fast_params().stewart holds the platform's parameters"),
        "UpperMotion": ("stewart_jax.cable_robot._stewart:UpperMotion", _STEWART),
        "leg_kinematics": ("stewart_jax.cable_robot._stewart:leg_kinematics", _STEWART),
        "paper_stewart_params": ("stewart_jax.cable_robot._stewart:paper_stewart_params",
                                 f"{_CR}.paper_fast_params(g).stewart"),
        "reaction_wrench": ("stewart_jax.cable_robot._stewart:reaction_wrench", _STEWART),
        "stewart_inverse_dynamics": ("stewart_jax.cable_robot._stewart:stewart_inverse_dynamics", _STEWART),
        "upper_platform_wrench": ("stewart_jax.cable_robot._stewart:upper_platform_wrench", _STEWART),
        "CabinDynamics": ("stewart_jax.cable_robot._system:CabinDynamics", _MOTION),
        "anchor_positions": ("stewart_jax.cable_robot._system:anchor_positions", f"{_CR}.paper_fast_params().anchors"),
        "cabin_accelerations": ("stewart_jax.cable_robot._system:cabin_accelerations", _MOTION),
        "cabin_residual": ("stewart_jax.cable_robot._system:cabin_residual", _MOTION),
        "cable_deltas": ("stewart_jax.cable_robot._system:cable_deltas", _MOTION),
        "static_lower_motion": ("stewart_jax.cable_robot._system:static_lower_motion", _SIMULATE),
        "tower_positions": ("stewart_jax.cable_robot._system:tower_positions", f"{_CR}.paper_fast_params().towers"),
        "upper_motion": ("stewart_jax.cable_robot._system:upper_motion", _MOTION),
        "APERTURE_RADIUS": ("stewart_jax.cable_robot._workspace:APERTURE_RADIUS", _REFLECTOR),
        "CURVATURE_CENTRE": ("stewart_jax.cable_robot._workspace:CURVATURE_CENTRE", _REFLECTOR),
        "FOCAL_RADIUS": ("stewart_jax.cable_robot._workspace:FOCAL_RADIUS", _REFLECTOR),
        "REFLECTOR_RADIUS": ("stewart_jax.cable_robot._workspace:REFLECTOR_RADIUS", _REFLECTOR),
        "AssemblyBodies": ("stewart_jax.cable_robot._workspace:AssemblyBodies", _MODES),
        "assembly_bodies": ("stewart_jax.cable_robot._workspace:assembly_bodies", _MODES),
        "assembly_centre_of_mass": ("stewart_jax.cable_robot._workspace:assembly_centre_of_mass", _MODES),
        "assess": ("stewart_jax.cable_robot._workspace:assess", f"{_CR}.cabin_statics (assess is its compiled form)"),
        "cabin_statics_jit": ("stewart_jax.cable_robot._workspace:cabin_statics_jit",
                              f"jax.jit({_CR}.cabin_statics)"),
        "cable_profile": ("stewart_jax.cable_robot._workspace:cable_profile", _REFLECTOR),
        "lowest_points": ("stewart_jax.cable_robot._workspace:lowest_points", _REFLECTOR),
        "reflector_clearance": ("stewart_jax.cable_robot._workspace:reflector_clearance", _REFLECTOR),
        "zenith_angle": ("stewart_jax.cable_robot._workspace:zenith_angle", _REFLECTOR),
    },
    "stewart_jax.plotting": {
        "COMPONENT_LABELS": ("stewart_jax.plotting._common:COMPONENT_LABELS",
                             "private: the component labels of stewart_jax.plotting.plot_pose_errors"),
    },
}


def location(package: str, name: str) -> Any:
    """The object an old public name stands for (no warning)."""
    module, attr = MOVED[package][name][0].split(":")
    return getattr(importlib.import_module(module), attr)


def moved(package: str, name: str) -> Any:
    """The module ``__getattr__`` of ``package`` for an old public name: a ``DeprecationWarning``
    naming the replacement, then the object. ``AttributeError`` for any other name."""
    entry = MOVED.get(package, {}).get(name)
    if entry is None:
        raise AttributeError(f"module {package!r} has no attribute {name!r}")
    warnings.warn(f"{package}.{name} is no longer public; use {entry[1]}", DeprecationWarning, stacklevel=3)
    return location(package, name)


def moved_markdown() -> str:
    """``docs/api/moved.md``: one row per old public name."""
    lines = [
        "# Moved and private names",
        "",
        "The public surface is what a user calls: mechanisms, solvers, the result types a user",
        "receives and the main functions. The names below left it: aliases, function wrappers",
        "around methods, `_jit` variants, helpers, solver states and constants used inside the",
        "package. Each still answers from its old place, with a `DeprecationWarning` that names",
        "its replacement; the object itself lives where the third column says.",
        "",
        "This page is generated from `stewart_jax/_moved.py` (`tests/test_api_docs.py` checks it).",
        "",
        "| old name | use instead | where the object lives |",
        "| --- | --- | --- |",
    ]
    for package, names in MOVED.items():
        for name, (where, replacement) in names.items():
            lines.append(f"| `{package}.{name}` | `{replacement}` | `{where.replace(':', '.')}` |")
    return "\n".join(lines) + "\n"
