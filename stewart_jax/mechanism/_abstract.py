"""The mechanism abstraction every family implements, and the solution records it returns.

A mechanism is six actuators between a fixed frame B and a moving frame A. A pose
``P = [dx, dy, dz, φ, θ, ψ]`` (mm, rad; ``T = Rz(ψ)·Ry(θ)·Rx(φ)``) places A in B; each actuator
then has a *reading* ``q_i``: a length in mm (a slider's stroke, a strut's change of length) or an
angle in rad (a crank's turn), the family's :attr:`~AbstractMechanism.reading_unit`. What differs
between families is only the leg: how a reading follows from the pose and which geometric
parameters the calibration identifies, each in its own unit
(:attr:`~AbstractMechanism.param_units`: mm for lengths, rad or mrad for angles). Everything above
this layer — forward kinematics, residuals, simulation, identifiability, the study, the
discrepancy workflow, the CLI — is written against :class:`AbstractMechanism` and takes sizes,
noise and labels from those units.

A family implements ``params``, ``param_units``, ``with_params``, ``solve_inverse_kinematics``,
``moving_joints``, ``to_dict`` and ``from_dict`` and names its ``family`` and ``reading_unit``;
the pose Jacobian and the parameter Jacobian have automatic-differentiation defaults that a family
may override with closed forms, and the population objective
(:meth:`AbstractMechanism.population_squared_residuals`) a ``vmap`` default that a family may
override with a layout that vectorises over the population. Truly optional (``None`` where
unknown): :attr:`~AbstractMechanism.leg_parameters`, :attr:`~AbstractMechanism.travel_half_widths`
and :meth:`~AbstractMechanism.tracker_layout`. Register a family with
:func:`~stewart_jax.mechanism.register_family` so geometry files naming it load.
"""

from __future__ import annotations

import abc
from collections.abc import Iterable
from typing import Any, ClassVar, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float

from .._checks import array_module, valid_poses
from .._units import per_parameter


class IKSolution(NamedTuple):
    """Inverse kinematics of poses of batch shape ``...``.

    - ``readings``: ``Float[Array, "... 6"]``, actuator readings q (the family's
      :attr:`~AbstractMechanism.reading_unit`, mm or rad). Where a leg is unreachable the value is
      finite but meaningless.
    - ``margin``: ``Float[Array, "... 6"]``, per leg a number that is ≥ 0 exactly when the leg can
      be assembled (family-specific: for the 6-PSS the square-root argument of eq. 4 in mm², for
      the 6-UPS and 6-RUS a length in mm).
    - ``reachable``: ``Bool[Array, "..."]``, every leg's margin is ≥ 0.
    """

    readings: Float[Array, "... 6"]
    margin: Float[Array, "... 6"]
    reachable: Bool[Array, "..."]


def leg_block_columns(per_leg: Float[Array, "m legs k"]) -> Float[Array, "m*legs legs*k"]:
    """Rows of a parameter Jacobian whose legs' parameters are disjoint blocks: the row of leg
    ``i`` at pose ``j`` (row ``legs·j + i``) holds ``per_leg[j, i]`` in the ``k`` columns of leg
    ``i`` (``k·i … k·i + k − 1``) and zeros elsewhere."""
    m, legs, k = per_leg.shape
    return (jnp.eye(legs)[None, :, :, None] * per_leg[:, :, None, :]).reshape(m * legs, legs * k)


def population_totals(
    readings: Float[Array, "m 6"], poses: Float[Array, "m 6"], legs: Iterable[tuple[Array, Array]]
) -> tuple[Float[Array, " n"], Bool[Array, " n"]]:
    """The end of a family's structure-of-arrays
    :meth:`AbstractMechanism.population_squared_residuals`: from each leg ``i``'s readings and
    margins ``(q_i, margin_i)``, both ``(m, n)`` (pose by row, the population innermost), the sum
    of squared residuals ``Σ_j Σ_i (readings_ji − q_i)²`` and whether every leg is assembled at
    every (valid) pose, per population member."""
    total, reachable = None, None
    for i, (q, margin) in enumerate(legs):
        sq = (readings[:, i, None] - q) ** 2
        total = sq if total is None else total + sq
        reachable = margin >= 0.0 if reachable is None else reachable & (margin >= 0.0)
    return jnp.sum(total, axis=0), jnp.all(reachable, axis=0) & jnp.all(valid_poses(poses))


def dense_parameter_jacobian(
    per_leg: Float[Array, "legs m k"], leg_parameters: tuple[tuple[int, ...], ...], n_params: int
) -> Float[Array, "m*legs n"]:
    """The ``(6m, n)`` parameter Jacobian (row ``6j + i``: leg ``i`` at pose ``j``) from its leg
    blocks, ``per_leg[i, j, c] = ∂q_ji/∂u[leg_parameters[i][c]]`` (zeros elsewhere)."""
    legs, m, k = per_leg.shape
    cols = np.asarray(leg_parameters)
    dense = leg_block_columns(jnp.moveaxis(per_leg, 0, 1))  # columns leg-major: (i, c) at k·i + c
    order = np.empty(n_params, dtype=int)
    order[cols.ravel()] = np.arange(legs * k)
    return dense[:, order]


class AbstractMechanism(eqx.Module):
    """A six-actuator parallel mechanism: a pytree of its geometry (lengths in mm, angles in rad).

    Every family has the field ``v0`` (A's origin in B at the zero pose, mm). Class
    attributes: ``family`` (the geometry file's ``"mechanism"`` value, e.g. ``"6-PSS"``) and
    ``reading_unit`` (``"mm"`` for a length reading, ``"rad"`` for an angle). Batch a mechanism
    with ``jax.vmap`` over a leading axis of every leaf.
    """

    family: ClassVar[str]
    reading_unit: ClassVar[str]
    """The unit of the actuator readings: ``"mm"`` (a stroke, a change of length) or ``"rad"``
    (a crank angle). Reports give them in µm or µrad."""
    v0: eqx.AbstractVar[Float[Array, "3"]]
    """Position of A's origin (the point whose pose is commanded) in B at the zero pose (mm)."""
    param_sets: ClassVar[tuple[str, ...]] = ()
    """The family's parameter sets, the choices of :meth:`with_param_set` (empty: one fixed set)."""

    @property
    @abc.abstractmethod
    def params(self) -> Float[Array, " n"]:
        """The calibration parameters as one vector, each in its :attr:`param_units` unit."""

    @property
    @abc.abstractmethod
    def param_units(self) -> tuple[str, ...]:
        """The unit of each calibration parameter, in :attr:`params` order: ``"mm"`` for a
        length, ``"rad"`` (or ``"mrad"``, where a family stores a small angle so) for an angle.
        Perturbations, feasible boxes, the discrepancy models' scales, reports and plots take
        their sizes and labels from it (µm for lengths, µrad for angles)."""

    def natural_scales(self, length_mm: float, angle_mrad: float | None = None) -> np.ndarray:
        """Per calibration parameter, a size in its own unit: ``length_mm`` (mm) for a length,
        ``angle_mrad`` (mrad; default the same number as ``length_mm``) for an angle. What a
        perturbation's σ or a feasible box's half-width given "in mm" means for each parameter."""
        return per_parameter(self.param_units, length_mm, length_mm if angle_mrad is None else angle_mrad)

    @abc.abstractmethod
    def with_params(self, params: Float[Array, " n"]) -> AbstractMechanism:
        """The same mechanism with :attr:`params` replaced; traceable (vmap it over ``params``)."""

    @abc.abstractmethod
    def solve_inverse_kinematics(self, poses: Float[Array, "... 6"]) -> IKSolution:
        """Readings and reachability of poses of any batch shape; pure and jittable."""

    @abc.abstractmethod
    def to_dict(self) -> dict[str, Any]:
        """The geometry file's content (JSON-ready; lengths in mm), ``"mechanism"`` included."""

    @classmethod
    @abc.abstractmethod
    def from_dict(cls, d: dict[str, Any]) -> AbstractMechanism:
        """Inverse of :meth:`to_dict`, validating every field with a message naming it."""

    def with_param_set(self, param_set: str) -> AbstractMechanism:
        """The same mechanism calibrated with the parameter set ``param_set``, one of
        :attr:`param_sets`; a family with one fixed set refuses it with a ``ValueError``."""
        raise ValueError(f"the {self.family} has one fixed parameter set ({self.n_params} parameters), "
                         f"not {param_set!r}")

    @property
    def param_names(self) -> tuple[str, ...]:
        """A label per calibration parameter (default ``p0, p1, …``)."""
        return tuple(f"p{i}" for i in range(self.params.shape[-1]))

    @property
    def n_params(self) -> int:
        return int(self.params.shape[-1])

    def checked_params(self, params: Float[Array, "... n"]) -> Float[Array, "... n"]:
        """``params`` as float64 with a last axis of :attr:`n_params`, else a ``ValueError``
        naming the family (and its parameter set); the first step of every ``with_params`` (NumPy
        for a concrete value: its slices then compile nothing, :func:`array_module`)."""
        p = array_module(params).asarray(params, dtype=np.float64)
        n = self.n_params
        if p.shape[-1:] != (n,):
            raise ValueError(f"{self.params_label} params must have a last axis of {n}, got shape {p.shape}")
        return p

    @property
    def params_label(self) -> str:
        """The parameter vector's name in messages: the family, and its parameter set where a
        family has several."""
        return self.family

    @property
    def leg_parameters(self) -> tuple[tuple[int, ...], ...] | None:
        """Per leg, the indices in :attr:`params` that its reading depends on — disjoint sets, so
        that a calibration splits into one small least-squares problem per leg — or ``None``
        where the readings share parameters (or it is not known)."""
        return None

    @property
    def travel_half_widths(self) -> np.ndarray | None:
        """The mechanism's travel as pose half-widths ``[x, y, z, φ, θ, ψ]`` (mm, rad), or
        ``None`` where it is not known. Simulation and pose plans stay inside it."""
        return None

    def tracker_layout(self) -> tuple[float, float] | None:
        """``(radius, height)`` (mm, in frame A) of the laser-tracker target balls a simulated
        measurement uses, or ``None`` for three balls on the circle of the moving joints."""
        return None

    def file_warnings(self) -> None:
        """Warnings for a geometry file that loads but looks wrong (a unit slip: metres in a file
        of mm, radians typed for degrees), issued with :func:`warnings.warn`; called by
        :func:`~stewart_jax.mechanism.mechanism_from_dict` after the refusals of ``from_dict`` and
        of :func:`~stewart_jax.mechanism.check_geometry` (default: none)."""

    def fixed_joints(self) -> Float[Array, "6 3"] | None:
        """The legs' joint centres fixed to the base, in B (mm): where a simulated tracker's base
        targets go (``calibration``'s points model) — or ``None`` where a leg's lower joint moves
        with its reading (the 6-PSS slider), and the base targets follow the moving joints'
        height."""
        return None

    @abc.abstractmethod
    def moving_joints(self, poses: Float[Array, "... 6"]) -> Float[Array, "... 6 3"]:
        """The moving-side joint centres in B, ``T·a_i + d + v0`` (mm): where the simulated
        laser tracker's balls sit (:meth:`tracker_layout` ``None``) and what plots draw."""

    def ik_and_jacobian(
        self, poses: Float[Array, "... 6"]
    ) -> tuple[Float[Array, "... 6"], Float[Array, "... 6"], Float[Array, "... 6 6"]]:
        """Readings, margins and the pose Jacobian ``∂q_i/∂P_k`` (default: forward-mode AD)."""
        flat = poses.reshape(-1, 6)

        def one(p):
            return self.solve_inverse_kinematics(p).readings

        sol = self.solve_inverse_kinematics(poses)
        jac = jax.vmap(jax.jacfwd(one))(flat).reshape(*poses.shape[:-1], 6, 6)
        return sol.readings, sol.margin, jac

    def population_squared_residuals(
        self, params: Float[Array, "n p"], poses: Float[Array, "m 6"], readings: Float[Array, "m 6"]
    ) -> tuple[Float[Array, " n"], Bool[Array, " n"]]:
        """For every parameter vector ``params[k]`` of a population, ``Σ_j Σ_i (readings_ji −
        q_i(poses_j; params[k]))²`` (the reading unit squared) with ``q`` the inverse kinematics of
        ``self.with_params(params[k])``, and whether every pose is reachable there.

        The objective a population optimiser evaluates (the calibration's ``S(u)`` for a whole
        population at once). Default: ``jax.vmap`` over the rows of ``params``; a family may
        override it with a structure-of-arrays layout (the population innermost) that XLA
        vectorises, as the 6-PSS does. The result must equal the default to rounding.
        """

        def one(u):
            sol = self.with_params(u).solve_inverse_kinematics(poses)
            return jnp.sum((readings - sol.readings) ** 2), jnp.all(sol.reachable)

        return jax.vmap(one)(params)

    def parameter_jacobian(self, poses: Float[Array, "m 6"]) -> Float[Array, "6m n"]:
        """``∂q/∂u`` at :attr:`params` for the stacked readings of ``poses`` (row ``6j + i``
        is leg ``i`` at pose ``j``), forward-mode AD through :meth:`with_params`."""

        def readings(u):
            return self.with_params(u).solve_inverse_kinematics(poses).readings.reshape(-1)

        return jax.jacfwd(readings)(self.params)

    @property
    def has_closed_form_parameter_jacobian(self) -> bool:
        """Whether :meth:`parameter_jacobian` is a closed form (else forward-mode AD, which a
        least-squares solver can do better itself, e.g. by column compression over the legs)."""
        return type(self).parameter_jacobian is not AbstractMechanism.parameter_jacobian

    def leg_parameter_jacobian(self, poses: Float[Array, "m 6"]) -> Float[Array, "6 m k"]:
        """The non-zero blocks of :meth:`parameter_jacobian` where the legs' parameters are
        disjoint (:attr:`leg_parameters` not ``None``): ``[i, j, c] = ∂q_ji/∂u[leg_parameters[i][c]]``.

        What a per-leg least-squares solve needs, without the ``(6m, n)`` matrix of mostly zeros
        (``m = 120`` poses, 36 parameters: 26 000 numbers, 4 300 of them non-zero). Default: cut
        from :meth:`parameter_jacobian`; a family with a closed form overrides it (and builds the
        dense Jacobian from it with :func:`dense_parameter_jacobian`).
        """
        legs = self.leg_parameters
        if legs is None:
            raise ValueError(f"{type(self).__name__}'s legs share parameters: use parameter_jacobian")
        jac = self.parameter_jacobian(poses).reshape(poses.shape[0], len(legs), -1)  # (m, legs, n)
        return jnp.stack([jac[:, i][:, np.asarray(cols)] for i, cols in enumerate(legs)])
