"""The reachable workspace of a mechanism under its limits, measured along rays in pose space.

For a centre pose ``c`` and a unit direction ``u`` in the 6-D pose space ``[dx, dy, dz, φ, θ,
ψ]`` (mm, rad), the *extent* along ``u`` is the largest ``s ≤ max_extent`` such that every pose
``c + t·u``, ``0 ≤ t ≤ s``, is reachable: every leg's inverse-kinematics margin
(:meth:`AbstractMechanism.solve_inverse_kinematics`) is ≥ 0. Only the margin is used, so the
measurement works for every family and every limit a family encodes in its margin (the 6-PSS
square-root argument of Wang et al. 2018, eq. 4; the 6-UPS stroke and joint-angle limits).

How (per ray, ``jax.vmap`` over rays):

1. a coarse scan evaluates the margin at ``t_k = k·max_extent/n_scan``, ``k = 0 … n_scan``;
   the first unreachable ``t_k`` brackets the *first* exit ``[t_{k−1}, t_k]`` (a ray that leaves
   the workspace and re-enters it reports where it leaves; a ray reachable at every ``t_k``
   reports ``max_extent``);
2. bisection of that bracket with a fixed number of halvings (``lax.fori_loop``; the count
   follows from ``tol`` and ``n_scan`` alone, so it is static) down to a width of
   ``tol·max_extent``. The reported extent is the reachable end of the final bracket.

The leg whose margin is smallest at the unreachable end of the final bracket is the *binding*
leg; its reading at the extent (``readings``) tells which of its limits binds (for a 6-UPS with
stroke limits, a reading at ``min`` or ``max``).

NOTE: the scan is what makes "first exit" well defined; an excursion out of the workspace
shorter than ``max_extent/n_scan`` between two scan points can be missed. The 6-D directions mix
mm and rad, so a direction is a unit vector of the numbers as given: translation-only and
rotation-only rays (:func:`translation_envelope`, :func:`orientation_envelope`,
:func:`max_travel`) keep the units apart. Rotation rays are straight lines in the Euler angles
``(φ, θ, ψ)`` of ``T = Rz(ψ)·Ry(θ)·Rx(φ)``. The workspace is that of the model's margin only:
a family without stroke limits (the 6-PSS sliders of Wang et al. 2018, a 6-UPS built without
limits) is unbounded along some rays, which then report ``max_extent``; collisions are not
modelled.
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Int

from .._checks import MAX_ANGLE_RAD, check_poses
from ._abstract import AbstractMechanism

DEFAULT_N_SCAN = 64
DEFAULT_TOL = 1e-10
DEFAULT_MAX_ITER = 64
DEFAULT_TRAVEL_FACTOR = 4.0
"""Without an explicit ``max_extent`` the envelopes search up to this multiple of the
mechanism's published travel (:attr:`AbstractMechanism.travel_half_widths`)."""

MAX_TRAVEL_RAYS = ("+x", "-x", "+y", "-y", "+z", "-z", "+φ", "-φ", "+θ", "-θ", "+ψ", "-ψ")
"""The rays of :func:`max_travel`, in the order of ``MaxTravel.rays``."""

_UNIT_RTOL = 1e-6
_PLANES = {"xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}


class RayExtents(NamedTuple):
    """The workspace along ``n`` rays from ``centre``.

    - ``extent``: ``Float[Array, "n"]``, the largest ``s`` with ``centre + t·direction``
      reachable for all ``t ∈ [0, s]`` (units of the direction: mm, rad); 0 where the centre
      itself is unreachable.
    - ``hit_max``: ``Bool[Array, "n"]``, every scanned pose up to ``max_extent`` is reachable;
      ``extent == max_extent`` there and no limit was found.
    - ``binding_leg``: ``Int[Array, "n"]``, the leg (0–5) with the smallest margin just beyond
      the extent (the leg whose limit ends the ray; of legs meeting their limits together, the
      lowest index); −1 where ``hit_max`` or the centre is unreachable.
    - ``readings``: ``Float[Array, "n 6"]``, the actuator readings at the extent (mm).
    - ``margin``: ``Float[Array, "n 6"]``, the legs' margins at the extent (≥ 0; the binding
      leg's is ≈ 0).
    - ``converged``: ``Bool[Array, "n"]``, the final bracket is at most ``tol·max_extent`` wide
      (or ``hit_max``); False where the centre is unreachable or ``max_iter`` cut bisection short.
    - ``directions``: ``Float[Array, "n 6"]``, the unit directions.
    - ``centre``: ``Float[Array, "6"]``, the pose the rays start from.
    - ``max_extent``: ``Float[Array, "n"]``, the search limit per ray.
    """

    extent: Float[Array, " n"]
    hit_max: Bool[Array, " n"]
    binding_leg: Int[Array, " n"]
    readings: Float[Array, "n 6"]
    margin: Float[Array, "n 6"]
    converged: Bool[Array, " n"]
    directions: Float[Array, "n 6"]
    centre: Float[Array, "6"]
    max_extent: Float[Array, " n"]


class MaxTravel(NamedTuple):
    """The extents along ±x, ±y, ±z (mm) and ±φ, ±θ, ±ψ (rad) from a centre pose.

    - ``plus``, ``minus``: ``Float[Array, "6"]``, the extent along the positive and the negative
      axis of each pose component (both ≥ 0).
    - ``half_widths``: ``Float[Array, "6"]``, ``min(plus, minus)``: the symmetric travel,
      comparable with :attr:`AbstractMechanism.travel_half_widths`.
    - ``rays``: the :class:`RayExtents` of the 12 rays, in the order :data:`MAX_TRAVEL_RAYS`.
    """

    plus: Float[Array, "6"]
    minus: Float[Array, "6"]
    half_widths: Float[Array, "6"]
    rays: RayExtents


# ---- the measurement --------------------------------------------------------------------------


def workspace_along_rays(
    mechanism: AbstractMechanism,
    directions: ArrayLike,
    *,
    centre: ArrayLike | None = None,
    max_extent: ArrayLike,
    n_scan: int = DEFAULT_N_SCAN,
    tol: float = DEFAULT_TOL,
    max_iter: int = DEFAULT_MAX_ITER,
) -> RayExtents:
    """The reachable extent of ``mechanism`` along each of ``directions`` from ``centre``.

    - ``directions``: ``(n, 6)`` unit vectors in pose space ``[dx, dy, dz, φ, θ, ψ]``.
    - ``centre``: the pose the rays start from (mm, rad); default the zero pose.
    - ``max_extent``: a positive number, or one per ray (``(n,)``): where the search stops.
    - ``n_scan``: scan points per ray before bisection (static).
    - ``tol``: final bracket width relative to ``max_extent`` (static).
    - ``max_iter``: at most this many halvings (static); ``converged`` says whether they sufficed.

    Pure and jittable (``jax.jit`` with the mechanism and the arrays as arguments; ``jax.vmap``
    over mechanisms, centres or directions); the inputs are checked (shapes, unit norm, positive
    extents) wherever their values are concrete, before tracing.
    """
    dirs, centre_arr, extent_arr = _check_inputs(directions, centre, max_extent, n_scan, tol, max_iter)
    n_halvings = _n_halvings(n_scan, tol, max_iter)
    return _rays(mechanism, centre_arr, dirs, extent_arr, int(n_scan), float(tol), n_halvings)


@functools.partial(jax.jit, static_argnums=(4, 5, 6))
def _rays(mechanism, centre, directions, max_extent, n_scan: int, tol: float, n_halvings: int) -> RayExtents:
    """The rays of :func:`workspace_along_rays`, one function per ray, ``jax.vmap`` over rays."""

    def one_ray(direction, max_extent):
        def solve(t):
            poses = centre + t[..., None] * direction
            return mechanism.solve_inverse_kinematics(poses)

        # 1. coarse scan: the first unreachable scan point brackets the first exit
        ts = max_extent * jnp.arange(n_scan + 1, dtype=jnp.float64) / n_scan
        ok = solve(ts).reachable
        first_bad = jnp.argmin(ok)  # first False; 0 if all True (then ok[0] is True)
        all_ok = jnp.all(ok)
        centre_ok = ok[0]
        lo = jnp.where(first_bad > 0, ts[jnp.maximum(first_bad - 1, 0)], 0.0)
        hi = jnp.where(all_ok, max_extent, ts[first_bad])

        # 2. bisection of [lo, hi] with a static number of halvings
        def halve(_, bracket):
            a, b = bracket
            mid = 0.5 * (a + b)
            good = solve(mid).reachable
            return jnp.where(good, mid, a), jnp.where(good, b, mid)

        lo, hi = jax.lax.fori_loop(0, n_halvings, halve, (lo, hi))
        lo = jnp.where(all_ok, max_extent, jnp.where(centre_ok, lo, 0.0))

        at = solve(lo)
        beyond = solve(hi)
        bracketed = centre_ok & ~all_ok
        binding = jnp.where(bracketed, jnp.argmin(beyond.margin), -1)
        converged = all_ok | (bracketed & (hi - lo <= tol * max_extent * (1.0 + 1e-12)))
        return RayExtents(
            extent=lo,
            hit_max=all_ok,
            binding_leg=binding.astype(jnp.int32),
            readings=at.readings,
            margin=at.margin,
            converged=converged,
            directions=direction,
            centre=centre,
            max_extent=max_extent,
        )

    return jax.vmap(one_ray)(directions, max_extent)._replace(centre=centre)


def _n_halvings(n_scan: int, tol: float, max_iter: int) -> int:
    """Halvings that take a bracket of ``max_extent/n_scan`` down to ``tol·max_extent``."""
    return int(min(max_iter, max(0, math.ceil(math.log2(1.0 / (n_scan * tol))))))


# ---- the envelopes ----------------------------------------------------------------------------


def fibonacci_sphere(n: int) -> np.ndarray:
    """``n`` nearly uniformly spread unit vectors on the sphere (the Fibonacci lattice):
    ``z_i = 1 − (2i + 1)/n``, azimuth ``i·π(3 − √5)``; shape ``(n, 3)``."""
    n = _check_count(n, "n")
    i = np.arange(n, dtype=np.float64)
    z = 1.0 - (2.0 * i + 1.0) / n
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    az = i * np.pi * (3.0 - np.sqrt(5.0))
    return np.stack([r * np.cos(az), r * np.sin(az), z], axis=-1)


def translation_envelope(
    mechanism: AbstractMechanism,
    n_directions: int,
    *,
    orientation: ArrayLike = (0.0, 0.0, 0.0),
    translation: ArrayLike = (0.0, 0.0, 0.0),
    plane: str | None = None,
    max_extent: float | None = None,
    n_scan: int = DEFAULT_N_SCAN,
    tol: float = DEFAULT_TOL,
    max_iter: int = DEFAULT_MAX_ITER,
) -> RayExtents:
    """The translational workspace at a fixed ``orientation`` ``(φ, θ, ψ)`` (rad): extents (mm)
    along ``n_directions`` Fibonacci-sphere directions in ``(x, y, z)`` from ``translation``
    (mm), or, with ``plane`` one of ``"xy"``, ``"xz"``, ``"yz"``, along ``n_directions``
    equally spaced directions in that plane (a section through the centre; the angle runs from
    the plane's first axis towards its second). ``max_extent`` (mm) defaults to
    :data:`DEFAULT_TRAVEL_FACTOR` times the largest published translation half-width of the
    mechanism."""
    n = _check_count(n_directions, "n_directions")
    dirs = np.zeros((n, 6))
    if plane is None:
        dirs[:, :3] = fibonacci_sphere(n)
    elif plane in _PLANES:
        a, b = _PLANES[plane]
        alpha = 2.0 * np.pi * np.arange(n) / n
        dirs[:, a] = np.cos(alpha)
        dirs[:, b] = np.sin(alpha)
    else:
        raise ValueError(f"plane must be None (the whole sphere) or one of {sorted(_PLANES)}, got {plane!r}")
    centre = _centre(translation, orientation)
    if max_extent is None:
        max_extent = _default_extent(mechanism, slice(0, 3), "mm")
    return workspace_along_rays(
        mechanism, dirs, centre=centre, max_extent=max_extent, n_scan=n_scan, tol=tol, max_iter=max_iter
    )


def orientation_envelope(
    mechanism: AbstractMechanism,
    n_directions: int,
    *,
    translation: ArrayLike = (0.0, 0.0, 0.0),
    orientation: ArrayLike = (0.0, 0.0, 0.0),
    max_extent: float | None = None,
    n_scan: int = DEFAULT_N_SCAN,
    tol: float = DEFAULT_TOL,
    max_iter: int = DEFAULT_MAX_ITER,
) -> RayExtents:
    """The rotational workspace at a fixed ``translation`` (mm): extents (rad) along
    ``n_directions`` tilt directions ``(cos α, sin α)`` in ``(φ, θ)``, ``α = 2πk/n``, then along
    ``+ψ`` and ``−ψ`` (``n_directions + 2`` rays), from ``orientation`` (rad). ``max_extent``
    (rad, ≤ 0.5) defaults to :data:`DEFAULT_TRAVEL_FACTOR` times the largest published angular
    half-width, capped at 0.5 rad."""
    n = _check_count(n_directions, "n_directions")
    alpha = 2.0 * np.pi * np.arange(n) / n
    dirs = np.zeros((n + 2, 6))
    dirs[:n, 3] = np.cos(alpha)
    dirs[:n, 4] = np.sin(alpha)
    dirs[n, 5] = 1.0
    dirs[n + 1, 5] = -1.0
    centre = _centre(translation, orientation)
    if max_extent is None:
        max_extent = min(MAX_ANGLE_RAD, _default_extent(mechanism, slice(3, 6), "rad"))
    _check_angle_extent(max_extent)
    return workspace_along_rays(
        mechanism, dirs, centre=centre, max_extent=max_extent, n_scan=n_scan, tol=tol, max_iter=max_iter
    )


def max_travel(
    mechanism: AbstractMechanism,
    *,
    centre: ArrayLike | None = None,
    max_extent_mm: float | None = None,
    max_extent_rad: float | None = None,
    n_scan: int = DEFAULT_N_SCAN,
    tol: float = DEFAULT_TOL,
    max_iter: int = DEFAULT_MAX_ITER,
) -> MaxTravel:
    """The extents along ±x, ±y, ±z (mm, up to ``max_extent_mm``) and ±φ, ±θ, ±ψ (rad, up to
    ``max_extent_rad``) from ``centre`` (default the zero pose), one axis at a time: the
    counterpart of a hexapod's published per-axis travel. The defaults are
    :data:`DEFAULT_TRAVEL_FACTOR` times the mechanism's published travel (angles capped at
    0.5 rad)."""
    if max_extent_mm is None:
        max_extent_mm = _default_extent(mechanism, slice(0, 3), "mm", arg="max_extent_mm")
    if max_extent_rad is None:
        max_extent_rad = min(MAX_ANGLE_RAD, _default_extent(mechanism, slice(3, 6), "rad", arg="max_extent_rad"))
    _check_positive_scalar(max_extent_mm, "max_extent_mm")
    _check_angle_extent(max_extent_rad, "max_extent_rad")
    dirs = np.zeros((12, 6))
    dirs[np.arange(12), np.repeat(np.arange(6), 2)] = np.tile([1.0, -1.0], 6)
    limits = np.repeat([float(max_extent_mm)] * 3 + [float(max_extent_rad)] * 3, 2)
    rays = workspace_along_rays(
        mechanism, dirs, centre=centre, max_extent=limits, n_scan=n_scan, tol=tol, max_iter=max_iter
    )
    pm = rays.extent.reshape(6, 2)
    return MaxTravel(plus=pm[:, 0], minus=pm[:, 1], half_widths=jnp.min(pm, axis=1), rays=rays)


# ---- checks -----------------------------------------------------------------------------------


def _check_inputs(directions, centre, max_extent, n_scan, tol, max_iter):
    if not isinstance(n_scan, (int, np.integer)) or isinstance(n_scan, bool) or n_scan < 1:
        raise ValueError(f"n_scan must be a positive int (static), got {n_scan!r}")
    if not isinstance(max_iter, (int, np.integer)) or isinstance(max_iter, bool) or max_iter < 0:
        raise ValueError(f"max_iter must be a non-negative int (static), got {max_iter!r}")
    if not isinstance(tol, (int, float, np.floating)) or not (0.0 < float(tol) < 1.0):
        raise ValueError(f"tol must be a number in (0, 1) (static, relative to max_extent), got {tol!r}")
    if isinstance(directions, jax.core.Tracer):
        dirs = directions
        shape = dirs.shape
    else:
        dirs = np.asarray(directions, dtype=np.float64)
        shape = dirs.shape
    if len(shape) != 2 or shape[1] != 6 or shape[0] < 1:
        raise ValueError(
            f"directions must have shape (n, 6) (unit vectors in [dx, dy, dz, φ, θ, ψ]), got {shape}"
        )
    n = shape[0]
    if not isinstance(dirs, jax.core.Tracer):
        if not np.all(np.isfinite(dirs)):
            raise ValueError("directions contain NaN or inf")
        norms = np.linalg.norm(dirs, axis=1)
        bad = np.flatnonzero(np.abs(norms - 1.0) > _UNIT_RTOL)
        if bad.size:
            raise ValueError(
                f"directions must be unit vectors; row {int(bad[0])} has norm {norms[bad[0]]:.6g} "
                f"({bad.size} such rows): divide by np.linalg.norm(directions, axis=1, keepdims=True)"
            )
        dirs = jnp.asarray(dirs)
    centre_arr = jnp.zeros(6) if centre is None else check_poses(centre, "centre")
    if centre_arr.shape != (6,):
        raise ValueError(f"centre must be one pose of shape (6,) (mm, rad), got {centre_arr.shape}")
    if isinstance(max_extent, jax.core.Tracer):
        ext = max_extent
        if ext.shape not in ((), (n,)):
            raise ValueError(f"max_extent must be a number or one per direction ({n},), got shape {ext.shape}")
    else:
        ext = np.asarray(max_extent, dtype=np.float64)
        if ext.shape not in ((), (n,)):
            raise ValueError(f"max_extent must be a number or one per direction ({n},), got shape {ext.shape}")
        if not np.all(np.isfinite(ext) & (ext > 0)):
            raise ValueError(f"max_extent must be positive and finite, got {ext.tolist()}")
    ext = jnp.broadcast_to(jnp.asarray(ext, dtype=jnp.float64), (n,))
    return dirs, centre_arr, ext


def _check_count(n, name: str) -> int:
    if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < 1:
        raise ValueError(f"{name} must be a positive int, got {n!r}")
    return int(n)


def _check_positive_scalar(x, name: str) -> None:
    if isinstance(x, jax.core.Tracer):
        return
    a = np.asarray(x, dtype=np.float64)
    if a.shape != () or not (np.isfinite(a) and a > 0):
        raise ValueError(f"{name} must be one positive finite number, got {x!r}")


def _check_angle_extent(x, name: str = "max_extent") -> None:
    _check_positive_scalar(x, name)
    if not isinstance(x, jax.core.Tracer) and float(x) > MAX_ANGLE_RAD:
        raise ValueError(
            f"{name} = {float(x):.4g} rad ({np.degrees(float(x)):.4g}°) exceeds {MAX_ANGLE_RAD} rad; "
            "angles are radians — were degrees passed?"
        )


def _centre(translation, orientation) -> Array:
    t = np.asarray(translation, dtype=np.float64)
    o = np.asarray(orientation, dtype=np.float64)
    if t.shape != (3,):
        raise ValueError(f"translation must be (dx, dy, dz) in mm, got shape {t.shape}")
    if o.shape != (3,):
        raise ValueError(f"orientation must be (φ, θ, ψ) in rad, got shape {o.shape}")
    return check_poses(np.concatenate([t, o]), "centre")


def _default_extent(mechanism: AbstractMechanism, part: slice, unit: str, arg: str = "max_extent") -> float:
    half = mechanism.travel_half_widths
    if half is None:
        raise ValueError(
            f"{type(mechanism).__name__} has no published travel (travel_half_widths is None): "
            f"give {arg} ({unit})"
        )
    return DEFAULT_TRAVEL_FACTOR * float(np.max(np.asarray(half, dtype=np.float64)[part]))
