"""Fast paths for large batches: polynomial-trig 6-PSS IK (one device or sharded) and
fixed-step Newton FK (any mechanism).

Same mathematics as the 6-PSS inverse kinematics of Wang et al. (2018) (eq. 4 in its
cancellation-free form) and the forward kinematics (eqs. 5–6 by Newton's method),
arranged for throughput on CPU. ``benchmarks/kinematics.py`` measures these against
:meth:`~stewart_jax.mechanism.PSSMechanism.solve_inverse_kinematics` /
:func:`~stewart_jax.forward_kinematics` and NumPy (results in ``benchmarks/results/``).

What the measurements say (2-core AMD EPYC, float64, XLA:CPU of jax 0.10):

- XLA:CPU turns a batched IK into one elementwise loop per output array and evaluates every
  output element (one leg of one pose) on its own, so the pose's rotation — three
  ``sin``/``cos`` pairs — is recomputed for each of the 6 legs, and XLA's general
  ``sin``/``cos`` (argument reduction) cost ~8 ns each. Replacing them by a Taylor
  polynomial that is exact to 1 ulp for ``|angle| ≤ 0.5`` rad is the main gain (~5× on
  its own); storing poses as six rows of ``N`` (``(6, N)``) instead of ``(N, 6)`` gains ~2×
  with ``jnp.sin`` but nothing more once the polynomial is used (XLA fuses a transpose of
  the input into the same loop), so ``inverse_kinematics_soa(g, poses.T)`` inside ``jit``
  is as fast as feeding ``(6, N)``.
- That loop runs on one core. :func:`inverse_kinematics_sharded` splits the batch over
  several XLA host devices (``jax_num_cpu_devices``) to use the others.
- Each extra output is a separate loop that recomputes the rotation: strokes + margin cost
  about twice strokes alone. Under ``jit`` unused outputs are dropped.
- For outputs above glibc's mmap threshold (≤ 32 MiB, e.g. ``N ≳ 7e5`` poses for strokes)
  every call gets freshly mapped memory and the page faults can cost as much as the
  arithmetic; batches of ~1e5–5e5 poses avoid it.
"""

from __future__ import annotations

import functools
import math

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, PartitionSpec
from jaxtyping import Array, ArrayLike, Float

from .._checks import MAX_ANGLE_RAD, check_array, check_poses
from ._abstract import AbstractMechanism, IKSolution
from ._kinematics import FKSolution, ik_and_jacobian
from ._pss import PSSMechanism, slider_leg

# Taylor coefficients of sin(x)/x and cos(x) in x²: through x¹³ and x¹⁴. For |x| ≤ 0.5 the
# truncation error is < 5e-17 and the Horner evaluation agrees with libm to 1 ulp (checked
# on a 2e5-point grid); beyond _POLY_RANGE the exact jnp.sin/jnp.cos are used instead. The
# range is this polynomial's own, not MAX_ANGLE_RAD (which happens to equal it).
_POLY_RANGE = 0.5
_SIN_COEFFS = tuple((-1) ** k / math.factorial(2 * k + 1) for k in range(7))
_COS_COEFFS = tuple((-1) ** k / math.factorial(2 * k) for k in range(8))


def _horner(coeffs, x2):
    acc = coeffs[-1]
    for c in coeffs[-2::-1]:
        acc = acc * x2 + c
    return acc


def _sincos_poly(x):
    x2 = x * x
    return x * _horner(_SIN_COEFFS, x2), _horner(_COS_COEFFS, x2)


def _sincos_exact(x):
    return jnp.sin(x), jnp.cos(x)


def _rotation_rows(angles, sincos):
    """The nine entries of ``T = Rz(ψ)·Ry(θ)·Rx(φ)`` (eq. 1, its (2,2) sign corrected), row-major."""
    sf, cf = sincos(angles[0])
    st, ct = sincos(angles[1])
    sp, cp = sincos(angles[2])
    return (
        cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf,
        sp * ct, sp * st * sf + cp * cf, sp * st * cf - cp * sf,
        -st, ct * sf, ct * cf,
    )  # fmt: skip


def _ik_rows(geometry: PSSMechanism, poses_soa, sincos):
    """Eq. 4 leg by leg on rows (the mechanism's own leg, :func:`~stewart_jax.mechanism._pss.slider_leg`);
    returns (readings, margin) as lists of 6 rows."""
    r = _rotation_rows(poses_soa[3:6], sincos)
    t = [r[0:3], r[3:6], r[6:9]]
    d = [poses_soa[0], poses_soa[1], poses_soa[2]]
    upper = geometry.upper
    e = upper + geometry.v0 - geometry.lower
    legs = [slider_leg(t, d, [upper[i, k] for k in range(3)], [e[i, k] for k in range(3)]) for i in range(6)]
    return [leg.readings for leg in legs], [leg.margin for leg in legs]


def inverse_kinematics_soa(geometry: PSSMechanism, poses_soa: Float[Array, "6 ..."]) -> IKSolution:
    """Eq. 4 for poses in structure-of-arrays layout: the fast path for large batches.

    ``poses_soa[k]`` is pose component ``k`` of ``[dx, dy, dz, φ, θ, ψ]`` (mm, rad) for every
    pose, i.e. the transpose ``poses.T`` of the ``(N, 6)`` array that
    :meth:`~stewart_jax.mechanism.PSSMechanism.solve_inverse_kinematics` takes; any trailing batch shape is
    allowed. Returns an :class:`~stewart_jax.mechanism.IKSolution` in the same layout:
    ``readings`` and ``margin`` of shape ``(6, *batch)`` (leg first), ``reachable`` of shape
    ``batch``. Pure and jittable; batch over geometries with ``jax.vmap``.

    Agrees with :meth:`~stewart_jax.mechanism.PSSMechanism.solve_inverse_kinematics` to ~1e-13 mm (float64
    rounding). When every angle is within ±0.5 rad (``MAX_ANGLE_RAD``, the library's limit
    for a pose) the sines and cosines come from a 1-ulp polynomial; otherwise the whole
    batch uses ``jnp.sin``/``jnp.cos``, the slow but general path (one ``lax.cond``; under a
    ``vmap`` over poses it becomes a select that evaluates both).

    Use it when IK runs on many poses at once (a sweep of the workspace, Monte-Carlo
    tolerance studies): on the benchmark machine, strokes alone run at ~1.5–2e8 legs/s on
    one core (10–20× ``jax.jit(solve_inverse_kinematics)`` and NumPy), strokes + margin +
    reachability at ~0.5–1e8 (``benchmarks/kinematics.py``). Poses held as ``(N, 6)`` can be
    passed as ``poses.T`` inside the same ``jit`` at no extra cost. For a handful of poses,
    or inside ``jax.jacfwd``/``grad`` of a calibration residual, the plain function is as
    good. Under ``jit``, outputs that are not used are not computed, so
    ``inverse_kinematics_soa(g, p).readings`` costs only the readings.
    """
    if not isinstance(geometry, PSSMechanism) or not geometry.is_paper_model:
        raise TypeError("inverse_kinematics_soa is the fast path of Wang et al. (2018)'s 6-PSS (vertical sliders, "
                        f"rod lengths from the zero pose), got a {type(geometry).__name__}"
                        f"{'' if not isinstance(geometry, PSSMechanism) else ' with axes or rod lengths'}; "
                        "use solve_inverse_kinematics")
    poses_soa = jnp.asarray(poses_soa)
    if poses_soa.shape[:1] != (6,):
        raise ValueError(
            f"poses_soa must have a first axis of 6 (dx, dy, dz, φ, θ, ψ), got shape {poses_soa.shape}"
        )

    def solve(sincos):
        def branch(p):
            readings, margins = _ik_rows(geometry, p, sincos)
            margin = jnp.stack(margins)
            valid = jnp.all(jnp.isfinite(p), axis=0) & jnp.all(jnp.abs(p[3:]) <= MAX_ANGLE_RAD, axis=0)
            return IKSolution(jnp.stack(readings), margin, jnp.all(margin >= 0.0, axis=0) & valid)

        return branch

    small = jnp.all(jnp.abs(poses_soa[3:]) <= _POLY_RANGE)
    return jax.lax.cond(small, solve(_sincos_poly), solve(_sincos_exact), poses_soa)


def inverse_kinematics_sharded(
    geometry: PSSMechanism, poses_soa: Float[Array, "6 N"], mesh: Mesh | None = None
) -> IKSolution:
    """:func:`inverse_kinematics_soa` with the batch split over several devices.

    XLA:CPU runs one elementwise kernel on one core; to use the other cores of a CPU host
    the host must be split into several XLA devices **before JAX initialises**, e.g.
    ``jax.config.update("jax_num_cpu_devices", os.cpu_count())`` (or
    ``XLA_FLAGS=--xla_force_host_platform_device_count=N``). This function then maps
    :func:`inverse_kinematics_soa` over ``mesh`` (default: every device of the default
    backend on one axis) with ``jax.shard_map``, one contiguous block of poses per device;
    the result is sharded the same way. ``N`` that is not a multiple of the device count is
    padded with zero poses (a copy of the input) and trimmed again. With a single device it
    is :func:`inverse_kinematics_soa`. Jittable; ``poses_soa`` must be ``(6, N)``.
    """
    poses_soa = jnp.asarray(poses_soa)
    if poses_soa.ndim != 2 or poses_soa.shape[0] != 6:
        raise ValueError(f"poses_soa must have shape (6, N), got {poses_soa.shape}")
    if mesh is None:
        mesh = Mesh(np.array(jax.devices()), ("batch",))
    if mesh.size == 1:
        return inverse_kinematics_soa(geometry, poses_soa)
    axes = mesh.axis_names
    n = poses_soa.shape[1]
    pad = -n % mesh.size
    if pad:
        poses_soa = jnp.pad(poses_soa, ((0, 0), (0, pad)))
    rows, cols = PartitionSpec(None, axes), PartitionSpec(axes)
    sol = jax.shard_map(
        inverse_kinematics_soa,
        mesh=mesh,
        in_specs=(PartitionSpec(), rows),
        out_specs=IKSolution(rows, rows, cols),
    )(geometry, poses_soa)
    if pad:
        sol = IKSolution(sol.readings[:, :n], sol.margin[:, :n], sol.reachable[:n])
    return sol


# --------------------------------------------------------------------------------------------
# Forward kinematics
# --------------------------------------------------------------------------------------------


def _solve_near_identity(a, b):
    """Solve ``A x = b`` elementwise (entries of any batch shape) by Gaussian elimination without
    pivoting, unrolled; meant for ``A = J0⁻¹·J ≈ I`` where every pivot is near 1."""
    a = [list(row) for row in a]
    b = list(b)
    for k in range(6):
        inv = 1.0 / a[k][k]
        for i in range(k + 1, 6):
            f = a[i][k] * inv
            for j in range(k + 1, 6):
                a[i][j] = a[i][j] - f * a[k][j]
            b[i] = b[i] - f * b[k]
    x = [None] * 6
    for i in range(5, -1, -1):
        s = b[i]
        for j in range(i + 1, 6):
            s = s - a[i][j] * x[j]
        x[i] = s / a[i][i]
    return x


def _fk_newton(geometry: AbstractMechanism, q, p0, steps: int, tol: float):
    """Fixed-step Newton for readings ``q`` (n, 6) from poses ``p0`` (n, 6)."""
    jac0 = ik_and_jacobian(geometry, jnp.zeros(6, q.dtype))[2]
    # Precondition by the zero-pose Jacobian: J0⁻¹·J stays near I over the travel, so the
    # unpivoted elimination is stable and needs no pivot search (selects) per pose.
    j0inv = jnp.linalg.inv(jac0)

    def step(_, p):
        readings, _, jac = ik_and_jacobian(geometry, p)
        m = j0inv @ jac
        rhs = (readings - q) @ j0inv.T
        x = _solve_near_identity(
            [[m[..., i, j] for j in range(6)] for i in range(6)], [rhs[..., i] for i in range(6)]
        )
        return p - jnp.stack(x, axis=-1)

    p = jax.lax.fori_loop(0, steps, step, p0)
    readings, margin, _ = ik_and_jacobian(geometry, p)
    res = jnp.max(jnp.abs(readings - q), axis=-1)
    return p, res, (res <= tol) & jnp.all(margin >= 0.0, axis=-1)


def forward_kinematics_newton(
    geometry: AbstractMechanism,
    readings: ArrayLike,
    initial_pose: ArrayLike | None = None,
    *,
    steps: int = 4,
    tol: float = 1e-11,
    chunk_size: int = 1024,
) -> FKSolution:
    """Forward kinematics by a fixed number of full Newton steps: the fast batched path.

    Same problem and result type as :func:`~stewart_jax.forward_kinematics` (readings
    ``(..., 6)`` in mm → :class:`~stewart_jax.mechanism.FKSolution`), solved differently: exactly
    ``steps`` Newton steps from ``initial_pose`` (default the zero pose) with the analytic
    6×6 Jacobian, no line search and no data-dependent loop, then one residual evaluation.
    ``converged`` is ``max |IK(P) − q| ≤ tol`` with every leg reachable; ``steps`` in the
    result is the fixed count.

    Newton converges quadratically from the zero pose in the ±1 mm / ±1° travel: 3 steps
    reach ~1e-13 mm, so the default 4 leaves a margin. Where a pose is far outside the
    travel it may not converge in ``steps``; it is then reported (``converged`` False, never
    a silent NaN) and :func:`~stewart_jax.forward_kinematics` (line search, up to 30 steps)
    is the robust fallback for those poses. The batch is processed ``chunk_size`` poses at
    a time (``lax.map``) so that the intermediates stay in cache.
    """
    q = check_array(readings, "readings", last_dim=6)
    p0 = jnp.zeros(6) if initial_pose is None else check_poses(initial_pose)
    return _fk_newton_jit(geometry, q, p0, steps, tol, chunk_size)


@functools.partial(jax.jit, static_argnums=(3, 4, 5))
def _fk_newton_jit(geometry, q, p0, steps, tol, chunk_size):
    batch = q.shape[:-1]
    n = math.prod(batch)
    flat_q = q.reshape(n, 6)
    flat_p0 = jnp.broadcast_to(p0, q.shape).reshape(n, 6)
    chunk = max(1, min(chunk_size, n))
    n_chunks = -(-n // chunk)
    pad = n_chunks * chunk - n
    if pad:
        # Padded poses repeat the last real one (they converge; their results are dropped).
        flat_q = jnp.concatenate([flat_q, jnp.broadcast_to(flat_q[-1:], (pad, 6))])
        flat_p0 = jnp.concatenate([flat_p0, jnp.broadcast_to(flat_p0[-1:], (pad, 6))])

    if n_chunks == 1:
        poses, res, ok = _fk_newton(geometry, flat_q, flat_p0, steps, tol)
    else:
        poses, res, ok = jax.lax.map(
            lambda a: _fk_newton(geometry, a[0], a[1], steps, tol),
            (flat_q.reshape(n_chunks, chunk, 6), flat_p0.reshape(n_chunks, chunk, 6)),
        )
    poses = poses.reshape(-1, 6)[:n]
    res = res.reshape(-1)[:n]
    ok = ok.reshape(-1)[:n]
    return FKSolution(
        poses.reshape(*batch, 6),
        ok.reshape(batch),
        res.reshape(batch),
        jnp.full(batch, steps),
    )
