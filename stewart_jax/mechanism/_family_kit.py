"""What a mechanism family's module uses, in one place (the recipe of ``docs/architecture.md``).

A family is a subclass of :class:`AbstractMechanism` decorated with :func:`register_family`, with
its presets decorated with :func:`register_preset`. Its fields are checked at construction with
:func:`field_array` (a float64 array of a shape, finite, optionally positive),
:func:`field_numbers` and :func:`field_travel` (the travel half-widths, mm then rad); its
``from_dict`` starts with :func:`check_file_header` and :func:`check_keys`, and reads the travel
with :func:`read_travel` (one schema for every family). :func:`check_geometry` (duplicate legs,
the zero pose, the pose Jacobian) runs once at every file load, after ``from_dict``; a family
does not call it. An inverse kinematics calls a pose reachable only where :func:`valid_poses`
holds (finite, angles within bounds). A structure-of-arrays ``population_squared_residuals`` ends with
:func:`population_totals`; a closed-form ``parameter_jacobian`` from per-leg blocks is
:func:`dense_parameter_jacobian`. Each of these is public in :mod:`stewart_jax.mechanism` too,
for a family written outside the package.
"""

from .._checks import (
    field_array as field_array,
    field_numbers as field_numbers,
    field_travel as field_travel,
    valid_poses as valid_poses,
)
from ._abstract import (
    AbstractMechanism as AbstractMechanism,
    IKSolution as IKSolution,
    dense_parameter_jacobian as dense_parameter_jacobian,
    population_totals as population_totals,
)
from ._registry import (
    check_file_header as check_file_header,
    check_geometry as check_geometry,
    check_keys as check_keys,
    read_travel as read_travel,
    register_family as register_family,
    register_preset as register_preset,
    travel_dict as travel_dict,
)
