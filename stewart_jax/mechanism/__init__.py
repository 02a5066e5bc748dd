"""Mechanisms: the abstraction every hexapod family implements, its families and kinematics.

- :class:`AbstractMechanism` — a pytree of geometry with ``params``/``with_params``, inverse
  kinematics with a reachability margin, pose and parameter Jacobians, a geometry-file dict.
- :class:`PSSMechanism` — the 6-PSS of Wang et al. (2018); :class:`UPSMechanism` — strut
  hexapods; :class:`RUSMechanism` — rotary (crank) hexapods.
- :func:`inverse_kinematics` (readings, an error for an unreachable pose; the method
  ``solve_inverse_kinematics`` gives reachability as a status) and :func:`forward_kinematics`
  (one batched Newton solve with per-pose status) for every family; the batched fast paths
  :func:`inverse_kinematics_soa`, :func:`inverse_kinematics_sharded` and
  :func:`forward_kinematics_newton`.
- Families and presets are registries (:func:`register_family`, :func:`register_preset`,
  :func:`preset`); :func:`load_mechanism` reads a preset name or a JSON/TOML geometry file
  naming its family.
- The family kit (``_family_kit.py``, public here for a family written outside the package):
  :func:`field_array`, :func:`field_numbers`, :func:`field_travel` (field checks),
  :func:`check_file_header`, :func:`check_keys`, :func:`read_travel`, :func:`travel_dict`
  (geometry files), :func:`check_geometry` (the generic checks at every file load),
  :func:`valid_poses` (the poses an inverse kinematics may call reachable),
  :func:`population_totals` and :func:`dense_parameter_jacobian` (fast-path building blocks).
- :func:`workspace_along_rays`, :func:`translation_envelope`, :func:`orientation_envelope`,
  :func:`max_travel` — the reachable workspace under the mechanism's limits, along rays.
"""


from . import _ups_presets  # noqa: F401  (the 6-UPS presets register themselves)
from ._abstract import AbstractMechanism as AbstractMechanism, IKSolution as IKSolution
from ._batched import (
    forward_kinematics_newton as forward_kinematics_newton,
    inverse_kinematics_sharded as inverse_kinematics_sharded,
    inverse_kinematics_soa as inverse_kinematics_soa,
)
from ._family_kit import (
    check_file_header as check_file_header,
    check_geometry as check_geometry,
    check_keys as check_keys,
    dense_parameter_jacobian as dense_parameter_jacobian,
    field_array as field_array,
    field_numbers as field_numbers,
    field_travel as field_travel,
    population_totals as population_totals,
    read_travel as read_travel,
    travel_dict as travel_dict,
    valid_poses as valid_poses,
)
from ._genhexkins import to_genhexkins as to_genhexkins
from ._kinematics import (
    FKSolution as FKSolution,
    forward_kinematics as forward_kinematics,
    inverse_kinematics as inverse_kinematics,
)
from ._linuxcnc import LinuxCNCConfig as LinuxCNCConfig, to_linuxcnc as to_linuxcnc
from ._pss import (
    PSSMechanism as PSSMechanism,
    actual_geometry as actual_geometry,
    nominal_geometry as nominal_geometry,
)
from ._registry import (
    families as families,
    load_mechanism as load_mechanism,
    mechanism_from_dict as mechanism_from_dict,
    preset as preset,
    presets as presets,
    register_family as register_family,
    register_preset as register_preset,
    save_mechanism as save_mechanism,
)
from ._rus import RUSMechanism as RUSMechanism
from ._ups import UPSMechanism as UPSMechanism
from ._workspace import (
    MaxTravel as MaxTravel,
    RayExtents as RayExtents,
    max_travel as max_travel,
    orientation_envelope as orientation_envelope,
    translation_envelope as translation_envelope,
    workspace_along_rays as workspace_along_rays,
)

