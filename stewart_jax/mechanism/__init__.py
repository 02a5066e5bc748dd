"""Mechanisms: the abstraction every hexapod family implements, its families and kinematics.

- :class:`AbstractMechanism` — a pytree of geometry with ``params``/``with_params``, inverse
  kinematics with a reachability margin, pose and parameter Jacobians, a geometry-file dict.
- :class:`PSSMechanism` (alias ``Geometry``) — the 6-PSS of Wang et al. (2018);
  :class:`UPSMechanism` — strut hexapods; :class:`RUSMechanism` — rotary (crank) hexapods.
- :func:`forward_kinematics` — one batched Newton solve with per-pose status for every family.
- Families and presets are registries (:func:`register_family`, :func:`register_preset`);
  :func:`load_mechanism` reads a preset name or a JSON/TOML geometry file naming its family.
- :func:`workspace_along_rays`, :func:`translation_envelope`, :func:`orientation_envelope`,
  :func:`max_travel` — the reachable workspace under the mechanism's limits, along rays.
"""

from ._abstract import AbstractMechanism as AbstractMechanism, IKSolution as IKSolution
from ._batched import (
    forward_kinematics_newton as forward_kinematics_newton,
    inverse_kinematics_sharded as inverse_kinematics_sharded,
    inverse_kinematics_soa as inverse_kinematics_soa,
)
from ._genhexkins import to_genhexkins as to_genhexkins
from ._kinematics import (
    FKSolution as FKSolution,
    forward_kinematics as forward_kinematics,
    ik_and_jacobian as ik_and_jacobian,
    inverse_kinematics as inverse_kinematics,
    kinematic_jacobian as kinematic_jacobian,
    solve_inverse_kinematics as solve_inverse_kinematics,
    upper_joints_in_base as upper_joints_in_base,
)
from ._linuxcnc import LinuxCNCConfig as LinuxCNCConfig, to_linuxcnc as to_linuxcnc
from ._pss import (
    N_PARAMS as N_PARAMS,
    Geometry as Geometry,
    PSSMechanism as PSSMechanism,
    actual_geometry as actual_geometry,
    geometry_from_dict as geometry_from_dict,
    geometry_from_params as geometry_from_params,
    nominal_geometry as nominal_geometry,
    rod_lengths as rod_lengths,
)
from ._registry import (
    DEFAULT_FAMILY as DEFAULT_FAMILY,
    families as families,
    family as family,
    load_mechanism as load_mechanism,
    mechanism_from_dict as mechanism_from_dict,
    preset as preset,
    presets as presets,
    register_family as register_family,
    register_preset as register_preset,
    save_mechanism as save_mechanism,
)
from ._rus import RUSMechanism as RUSMechanism, rotary_stewart as rotary_stewart
from ._ups import (
    FAST_STEWART_TRAVEL as FAST_STEWART_TRAVEL,
    UPSMechanism as UPSMechanism,
    fast_stewart as fast_stewart,
    rubin_camera as rubin_camera,
    rubin_m2 as rubin_m2,
)
from ._workspace import (
    MAX_TRAVEL_RAYS as MAX_TRAVEL_RAYS,
    MaxTravel as MaxTravel,
    RayExtents as RayExtents,
    fibonacci_sphere as fibonacci_sphere,
    max_travel as max_travel,
    orientation_envelope as orientation_envelope,
    translation_envelope as translation_envelope,
    workspace_along_rays as workspace_along_rays,
)
