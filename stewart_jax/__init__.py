"""stewart_jax: kinematics, calibration and dynamics of Stewart platforms in JAX.

NOTE: importing the package enables ``jax_enable_x64`` once (SPEC §1): calibration carries
micrometres over 100 mm (1e-5 relative), which float32 cannot hold. Every array the library
creates is float64.
"""

import jax as _jax

_jax.config.update("jax_enable_x64", True)

from ._geometry import (  # noqa: E402
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
from ._kinematics import (  # noqa: E402
    FKSolution as FKSolution,
    IKSolution as IKSolution,
    euler_angles as euler_angles,
    forward_kinematics as forward_kinematics,
    inverse_kinematics as inverse_kinematics,
    kinematic_jacobian as kinematic_jacobian,
    rotation_matrix as rotation_matrix,
    solve_inverse_kinematics as solve_inverse_kinematics,
    upper_joints_in_base as upper_joints_in_base,
)

__version__ = "0.1.0"
