"""Tension-feasible workspace of the FAST feed cabin: the static equilibrium of the cabin on its
six elastic catenaries at a given position and attitude, the cable tensions, the margin to
slack, the cables' clearance above the reflector, and a physical definition of *feasible*.

The model is Yin J., Jiang P., Chen M., Yao R., *Dynamic modeling of a cable-driven parallel
robot with a Stewart platform for use in FAST* (elastic catenary, eqs. 6–13; the whole
cabin's equilibrium, eqs. 57–58 at rest; Table 1); the static solve is the 24×24 system of
:func:`~stewart_jax.cable_robot.static_equilibrium`. Its moment balance is the true one: the
weight of every body (cabin + upper platform at ``C r_CB0``, the twelve leg parts, the lower
platform) acts at that body's own centre of mass, so the cables' moment about the centre of
mass of the whole suspended assembly vanishes (:func:`assembly_centre_of_mass`, checked in the
tests).

Geometry of the telescope (not in Yin et al.'s text; the values are FAST's published design,
Nan R. D., *Five-hundred-meter aperture spherical radio telescope (FAST)*, Science in China G
49(2), 2006): the reflector is a sphere of radius 300 m whose lowest point is the origin of G,
so its centre of curvature is ``(0, 0, 300)`` m; the aperture is 500 m across (rim at a
horizontal radius of 250 m, height 300 − √(300² − 250²) = 134.17 m). The feed moves on the
focal surface, the sphere of radius 160 m about the centre of curvature: Table 2's four cabin
positions lie on it to 0.04 m (they are given to 0.1 m) (``z = 300 − √(160² − x²)``: 140.0, 142.84, 151.68, 167.71 m).

Feasible (:class:`CableStatics`) means, physically:

1. the 24×24 equilibrium exists with positive unstretched lengths (Newton converged);
   a cable with ``s0 > 0`` cannot push (eqs. 11–12 put the upper end on the side opposite to
   the horizontal force), so every cable is in tension;
2. every cable's *minimum* tension along its length (at its lowest point, or at an end) is at
   least ``tension_floor``;
3. every point of every cable is at least ``clearance`` above the reflector (inside the
   aperture) or above the rim's height (outside it);
4. the cable is on the short branch: ``s0 ≤ 2 × chord``.

NOTE (kilometre-long loops): near the slack boundary the physical root itself carries a cable
whose horizontal force ``H → 0`` and whose length ``s0 → ∞``: eqs. 11–13 are then satisfied by a
cable that hangs hundreds of metres down and back up. Such a root is a valid solution of the
equations (Newton converges to it, residual ~1e-9) but the cable would lie on the reflector;
conditions 3–4 reject it (4 names the case; the loops the tests build also fail 3 by
hundreds of metres).
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Int

from ._catenary import catenary_upper_end
from ._statics import StaticSolution, static_equilibrium, static_equilibrium_jit
from ._stewart import leg_kinematics
from ._system import FastParams, cable_deltas, check_position, static_lower_motion, upper_motion

REFLECTOR_RADIUS = 300.0
"""Radius of curvature of FAST's spherical reflector (m); its lowest point is G's origin."""
CURVATURE_CENTRE = (0.0, 0.0, 300.0)
"""Centre of curvature of the reflector in G (m)."""
APERTURE_RADIUS = 250.0
"""Horizontal radius of the reflector's rim (m): a 500 m aperture."""
FOCAL_RADIUS = 160.0
"""Radius of the focal surface about the centre of curvature (m), fitted by Table 2's positions."""
MAX_SAG_RATIO = 1.0
"""Short-branch bound: a cable with ``s0 > (1 + MAX_SAG_RATIO) × chord`` is a loop."""

WORKSPACE_STATUS = ("feasible", "no_equilibrium", "slack", "sag_on_reflector", "loop_branch")
"""Names of :attr:`CableStatics.status` codes 0–4, the first failed condition in this order:
no equilibrium, loop branch, sag on the reflector, slack."""

_N_PROFILE = 65


class CableStatics(NamedTuple):
    """Static state of the cabin at one pose (:func:`cabin_statics`); SI units, frame G.

    - ``static``: :class:`~stewart_jax.cable_robot.StaticSolution` (s0, forces, residual).
    - ``tension_n``: ``Float[Array, "6"]``, tension at the cabin anchor (N).
    - ``min_tension_n``: ``Float[Array, "6"]``, minimum tension along each cable (N).
    - ``slack_margin_n``: ``Float[Array, ""]``, ``min(min_tension_n) − tension_floor`` (N).
    - ``clearance_m``: ``Float[Array, "6"]``, each cable's lowest height above the reflector
      (inside the aperture) or the rim's height (outside), m.
    - ``sag_ratio``: ``Float[Array, "6"]``, ``s0 / chord − 1``.
    - ``lowest_point_m``: ``Float[Array, "6 3"]``, each cable's lowest point in G.
    - ``moment_about_com``: ``Float[Array, "3"]``, moment of gravity and cable forces about
      the assembly's centre of mass (N·m): zero at an equilibrium, a check.
    - ``converged``, ``short_branch``, ``feasible``: ``Bool[Array, ""]``.
    - ``status``: ``Int[Array, ""]``, index into :data:`WORKSPACE_STATUS`.
    """

    static: StaticSolution
    tension_n: Float[Array, "6"]
    min_tension_n: Float[Array, "6"]
    slack_margin_n: Float[Array, ""]
    clearance_m: Float[Array, "6"]
    sag_ratio: Float[Array, "6"]
    lowest_point_m: Float[Array, "6 3"]
    moment_about_com: Float[Array, "3"]
    converged: Bool[Array, ""]
    short_branch: Bool[Array, ""]
    feasible: Bool[Array, ""]
    status: Int[Array, ""]


def focal_surface_point(
    zenith: Float[ArrayLike, "..."], azimuth: Float[ArrayLike, "..."], radius: float = FOCAL_RADIUS
) -> Float[Array, "... 3"]:
    """Point of the focal surface at zenith angle ``zenith`` (rad, from the vertical through
    the centre of curvature) and azimuth ``azimuth`` (rad, from G's x axis):
    ``c + radius (sin ζ cos α, sin ζ sin α, −cos ζ)``."""
    z, a = jnp.asarray(zenith, jnp.float64), jnp.asarray(azimuth, jnp.float64)
    c = jnp.asarray(CURVATURE_CENTRE)
    return c + radius * jnp.stack([jnp.sin(z) * jnp.cos(a), jnp.sin(z) * jnp.sin(a), -jnp.cos(z)], -1)


def zenith_angle(position: Float[ArrayLike, "... 3"]) -> Float[Array, "..."]:
    """Zenith angle (rad) of a position seen from the centre of curvature."""
    d = jnp.asarray(CURVATURE_CENTRE) - jnp.asarray(position, jnp.float64)
    return jnp.arctan2(jnp.linalg.norm(d[..., :2], axis=-1), d[..., 2])


def reflector_clearance(points: Float[ArrayLike, "... 3"]) -> Float[Array, "..."]:
    """Height (m) of points above FAST's reflector: ``300 − |p − c|`` inside the aperture
    (positive above the surface), ``z − z_rim`` outside it."""
    p = jnp.asarray(points, jnp.float64)
    c = jnp.asarray(CURVATURE_CENTRE)
    r_h = jnp.linalg.norm(p[..., :2], axis=-1)
    z_rim = REFLECTOR_RADIUS - np.sqrt(REFLECTOR_RADIUS**2 - APERTURE_RADIUS**2)
    inside = REFLECTOR_RADIUS - jnp.linalg.norm(p - c, axis=-1)
    return jnp.where(r_h <= APERTURE_RADIUS, inside, p[..., 2] - z_rim)


def cable_profile(
    params: FastParams, force: Float[Array, "6 3"], s0: Float[Array, "6"], n: int = _N_PROFILE
) -> Float[Array, "6 n 3"]:
    """Points of each cable at ``n`` equally spaced material coordinates ``s ∈ [0, s0]``,
    relative to its lower end (eqs. 11–13 with ``s0`` replaced by ``s``)."""
    frac = jnp.linspace(0.0, 1.0, n)
    return jax.vmap(lambda f: catenary_upper_end(params.cable, force, f * s0), out_axes=1)(frac)


def lowest_points(
    params: FastParams, force: Float[Array, "6 3"], s0: Float[Array, "6"]
) -> tuple[Float[Array, "6 3"], Float[Array, "6"]]:
    """Each cable's lowest point relative to its lower end, and its minimum tension.

    The force in the cable at material coordinate ``s`` is ``F + ρ g s e_z``; its vertical
    component vanishes at ``s* = F_z/(ρ|g|)``, where the cable is lowest and the tension is
    the horizontal force ``H``; outside ``[0, s0]`` the lowest point and least tension are at
    an end. Closed form: no sampling."""
    w = params.cable.rho * jnp.abs(params.cable.g)
    s_star = jnp.clip(force[:, 2] / w, 0.0, s0)
    low = catenary_upper_end(params.cable, force, s_star)
    k = force + jnp.array([0.0, 0.0, 1.0]) * (params.cable.rho * params.cable.g * s_star)[:, None]
    return low, jnp.linalg.norm(k, axis=-1)


class AssemblyBodies(NamedTuple):
    """The 14 rigid bodies of the suspended assembly held at rest (cabin + upper platform, six
    upper and six lower leg parts, lower platform), in G.

    - ``mass``: ``Float[Array, "14"]`` (kg); ``centre``: ``Float[Array, "14 3"]``, centres of
      mass relative to C's origin (m); ``inertia``: ``Float[Array, "14 3 3"]``, central
      inertias (kg·m²).
    """

    mass: Float[Array, "14"]
    centre: Float[Array, "14 3"]
    inertia: Float[Array, "14 3 3"]


def assembly_bodies(params: FastParams, R: Float[Array, "3 3"]) -> AssemblyBodies:
    """Masses, centres of mass (relative to C's origin) and central inertias of the 14 bodies
    at cabin attitude ``R`` with the lower platform at ``B t_P = (0, 0, h)`` (Table 1; leg
    frames of eqs. 35–42)."""
    sp = params.stewart
    zero = jnp.zeros(3, jnp.float64)
    legs = leg_kinematics(sp, upper_motion(params, R, zero, zero, zero), static_lower_motion(params.h))
    G_tB = R @ params.C_t_B
    R_B = R @ params.C_R_B
    RL, RLt = legs.R_L, jnp.swapaxes(legs.R_L, -1, -2)
    centre = jnp.concatenate([
        (R @ params.r_CB0)[None],
        G_tB + legs.G_B + legs.r_U,
        G_tB + legs.G_B + legs.r_D,
        (G_tB + R_B @ (jnp.array([0.0, 0.0, 1.0]) * params.h) + R_B @ sp.r_P0)[None],
    ])
    inertia = jnp.concatenate([
        (R @ params.I_CB @ R.T)[None], RL @ sp.I_U @ RLt, RL @ sp.I_D @ RLt,
        (R_B @ sp.I_P @ R_B.T)[None],
    ])
    mass = jnp.concatenate([params.m_CB[None], jnp.full(6, sp.m_U), jnp.full(6, sp.m_D),
                            sp.m_P[None]])
    return AssemblyBodies(mass, centre, inertia)


def assembly_centre_of_mass(
    params: FastParams, position: Float[Array, "3"], R: Float[Array, "3 3"]
) -> tuple[Float[Array, ""], Float[Array, "3"]]:
    """Mass (kg) and centre of mass (G, m) of the suspended assembly at rest: cabin + upper
    platform, the six legs' two parts, and the lower platform at ``B t_P = (0, 0, h)``."""
    b = assembly_bodies(params, R)
    m = jnp.sum(b.mass)
    return m, position + jnp.sum(b.mass[:, None] * b.centre, axis=0) / m


def cabin_statics(
    params: FastParams,
    position: Float[ArrayLike, "3"],
    R: Float[ArrayLike, "3 3"] | None = None,
    *,
    static: StaticSolution | None = None,
    tension_floor: float | Float[Array, ""] = 0.0,
    clearance: float | Float[Array, ""] = 0.0,
) -> CableStatics:
    """Static equilibrium, tensions and feasibility of the cabin at ``position`` (G t_C, m)
    with attitude ``R`` (G R_C, identity by default). Traceable in every array argument
    (vmap over a map of positions and attitudes).

    **Arguments:**

    - ``params``: :class:`~stewart_jax.cable_robot.FastParams`.
    - ``position``: ``Float[Array, "3"]`` (m); ``R``: ``Float[Array, "3 3"]``.
    - ``static``: the equilibrium at this pose if already solved (e.g. by
      :data:`~stewart_jax.cable_robot._statics.static_equilibrium_jit`); solved here when ``None``.
    - ``tension_floor``: least admissible tension anywhere in a cable (N), 0 by default.
    - ``clearance``: least admissible height of a cable above the reflector (m), 0 by default.

    **Returns:** :class:`CableStatics`. Never raises inside a trace; a position with no
    equilibrium has ``status = 1`` and ``feasible = False`` (its tensions are the last
    Newton iterate, not to be used).
    """
    check_position(position)
    pos = jnp.asarray(position, jnp.float64)
    R = jnp.eye(3, dtype=jnp.float64) if R is None else jnp.asarray(R, jnp.float64)
    st = static_equilibrium(params, pos, R) if static is None else static
    force, s0 = st.force, st.s0
    chord = jnp.linalg.norm(cable_deltas(params, pos, R), axis=-1)
    lower_ends = pos + params.anchors @ R.T
    low_rel, min_tension = lowest_points(params, force, s0)
    profile = cable_profile(params, force, s0) + lower_ends[:, None, :]
    clear = jnp.minimum(jnp.min(reflector_clearance(profile), axis=-1),
                        reflector_clearance(low_rel + lower_ends))
    sag = s0 / chord - 1.0
    ok = st.converged & jnp.all(s0 > 0) & jnp.all(jnp.isfinite(force))
    short = jnp.all(sag <= MAX_SAG_RATIO)
    on_reflector = jnp.any(clear < clearance)
    slack = jnp.any(min_tension < tension_floor)
    status = jnp.where(~ok, 1, jnp.where(~short, 4, jnp.where(on_reflector, 3, jnp.where(slack, 2, 0))))
    m, com = assembly_centre_of_mass(params, pos, R)
    arm = lower_ends - com
    moment = -jnp.sum(jnp.cross(arm, force), axis=0)  # cable forces on the cabin are −F
    # gravity acts at the centre of mass: no moment about it
    return CableStatics(
        static=st,
        tension_n=jnp.linalg.norm(force, axis=-1),
        min_tension_n=min_tension,
        slack_margin_n=jnp.min(min_tension) - tension_floor,
        clearance_m=clear,
        sag_ratio=sag,
        lowest_point_m=low_rel + lower_ends,
        moment_about_com=moment,
        converged=ok,
        short_branch=short,
        feasible=status == 0,
        status=status.astype(jnp.int32),
    )


cabin_statics_jit = jax.jit(cabin_statics)
"""``jax.jit`` of :func:`cabin_statics`."""


def assess(
    params: FastParams,
    position: Float[ArrayLike, "3"],
    R: Float[ArrayLike, "3 3"] | None = None,
    *,
    static: StaticSolution | None = None,
    tension_floor: float = 0.0,
    clearance: float = 0.0,
) -> CableStatics:
    """:func:`cabin_statics` through two compiled functions: the 24×24 solve of
    :data:`~stewart_jax.cable_robot._statics.static_equilibrium_jit` (the one the rest of the package
    compiles; skipped when ``static`` is given) and the tensions/feasibility on its result.

    NOTE: on CPU a ``vmap`` of the 24×24 Newton solve is no faster per position than a loop
    of jitted single solves (≈2 ms each: the batch iterates until its slowest member
    converges), and it costs a compilation of its own (≈20 s); the searches and maps here
    therefore loop over single solves."""
    check_position(position)
    pos = jnp.asarray(position, jnp.float64)
    R = jnp.eye(3, dtype=jnp.float64) if R is None else jnp.asarray(R, jnp.float64)
    st = static_equilibrium_jit(params, pos, R) if static is None else static
    return _assess_jit(params, pos, R, st, jnp.asarray(tension_floor, jnp.float64),
                       jnp.asarray(clearance, jnp.float64))


@jax.jit
def _assess_jit(params, pos, R, st, floor, clearance):
    return cabin_statics(params, pos, R, static=st, tension_floor=floor, clearance=clearance)


def stack(results: list) -> CableStatics:
    """Stack a list of :class:`CableStatics` (or any equal pytrees) along a new leading axis."""
    return jax.tree.map(lambda *a: jnp.stack(a), *results)


def workspace_map(
    params: FastParams,
    positions: Float[ArrayLike, "n 3"],
    attitudes: Float[ArrayLike, "n 3 3"] | None = None,
    *,
    tension_floor: float = 0.0,
    clearance: float = 0.0,
) -> CableStatics:
    """:func:`cabin_statics` at every row of ``positions`` (attitudes identity when ``None``),
    through :func:`assess`; every field gains a leading axis of length ``n``."""
    pos = np.asarray(positions, dtype=np.float64)
    if pos.ndim != 2 or pos.shape[-1] != 3 or not np.all(np.isfinite(pos)):
        raise ValueError(f"positions must be a finite (n, 3) array in metres, got shape {pos.shape}")
    Rs = (np.broadcast_to(np.eye(3), (pos.shape[0], 3, 3)) if attitudes is None
          else np.asarray(attitudes, dtype=np.float64))
    if Rs.shape != (pos.shape[0], 3, 3):
        raise ValueError(f"attitudes must have shape ({pos.shape[0]}, 3, 3), got {Rs.shape}")
    return stack([assess(params, p, R, tension_floor=tension_floor, clearance=clearance)
                  for p, R in zip(pos, Rs, strict=True)])
