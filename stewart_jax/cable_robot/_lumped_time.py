"""Free and forced response of the FAST cabin on lumped-mass cables in the time domain.

The model is :mod:`._lumped`'s (the lumped-mass discretisation of Hall M., Goupee A.,
*Validation of a lumped-mass mooring line model with DeepCwind semisubmersible model test data*,
Ocean Engineering 104 (2015) 590–603, MoorDyn): coordinates ``y = (q, X)``, the cabin's offset
``q = (δt, δφ)`` from its static pose and every free node ``X``; equations of motion

    M ÿ = −∇V(y) − C ẏ + f(t),

with the exact nonlinear elastic and gravity forces ``−∇V`` (segments go slack when they
shorten below ``l0``), the mass matrix ``M`` of the static pose and ``f`` a generalised force
on the cabin's six coordinates (N, N·m).

NOTE (inertia): ``M`` is constant — the cabin's rotational inertia is taken at the static
attitude and the gyroscopic term ``ω × I ω`` is dropped. For the millimetre and
milliradian motions simulated here these are second-order small (relative size ``|δφ|`` and
``|ω|²/ω_mode²`` ≲ 1e-3), far below the differences this model is built to show.

Damping: the structural damping is set by one modal damping ratio ζ, ``C = M Φ diag(2 ζ ω_m) Φᵀ
M`` with the M-orthonormal modes ``Φ`` of the static pose (Rayleigh's classical damping in
modal form): every mode of the linearised system decays at ζ. (The modes' rotation coordinates
are measured from the requested attitude, the simulation's from the lumped equilibrium's, which
differ by the equilibrium's tilt, ~1e-5 rad: negligible in C.)

Cost per step: the segment forces (automatic differentiation of the energy, a sum over
segments) and ``M⁻¹`` (block diagonal: the cabin's 6×6 and a point mass per node, applied by
blocks) are ``O(n)`` in the ``n = 6 + 18(N − 1)`` coordinates, as in MoorDyn. The modal damping
is not: ``M⁻¹C = Φ diag(2ζω) Φᵀ M`` is a dense ``n × n`` product per step (``O(n²)``; Φ is dense,
so exact modal damping has no sparse form). With ``damping_ratio = 0`` it is skipped.

Integrator: velocity Verlet inside ``lax.scan`` (second order; symplectic when ζ = 0), the
damping evaluated at the predicted velocity ``v + a dt``. Stable for ``dt < 2/ω_max``;
:func:`simulate_lumped` refuses ``dt > 1.9/ω_max`` (ω_max: the highest mode, an axial wave in a
segment, ≈ (2/l0) √(EA/ρ)).
"""

from __future__ import annotations

from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ._lumped import LumpedModes, _potential, _segments
from ._modes import _exp
from ._workspace import assembly_centre_of_mass


class LumpedTrajectory(NamedTuple):
    """Output of :func:`simulate_lumped` (a leading batch axis when batched).

    - ``time``: ``Float[Array, "T+1"]`` (s).
    - ``cabin``: ``Float[Array, "T+1 6"]``, the cabin's offset from its static pose,
      ``(δt (m), δφ (rad))``, G.
    - ``cabin_velocity``: ``Float[Array, "T+1 6"]`` (m/s, rad/s).
    - ``anchor_tension_n``: ``Float[Array, "T+1 6"]``, tension of each cable's segment at the
      cabin (N).
    - ``max_stretch``: ``Float[Array, ""]``, largest segment strain met, a check on the
      linear-elastic range.
    """

    time: Float[Array, " T+1"]
    cabin: Float[Array, "T+1 6"]
    cabin_velocity: Float[Array, "T+1 6"]
    anchor_tension_n: Float[Array, "T+1 6"]
    max_stretch: Float[Array, ""]


def _damping(modes: LumpedModes, ratio):
    # M⁻¹ C = Φ diag(2ζω) Φᵀ M (Φ M-orthonormal); unstable or zero modes get none.
    w = 2.0 * jnp.pi * jnp.maximum(modes.frequencies_hz, 0.0)
    phi = modes.shapes
    return (phi * (2.0 * ratio * w)) @ (phi.T @ modes.mass)


def _run(params, modes: LumpedModes, y0, v0, dt, force, ratio, damped=True):
    st = modes.statics
    n_seg = st.nodes.shape[1] - 1
    pos, R, s0 = st.position, st.R, st.s0
    m, com = assembly_centre_of_mass(params, pos, R)
    com_C = R.T @ (com - pos)
    y_eq = jnp.concatenate([jnp.zeros(6), st.nodes[:, 1:-1].reshape(-1)])
    # M is block diagonal (the cabin's 6×6, a point mass per node): its inverse by blocks, O(n)
    # per step where the dense inverse costs O(n²)
    Mcc_inv = jnp.linalg.inv(modes.mass[:6, :6])
    node_inv = 1.0 / jnp.diagonal(modes.mass)[6:]
    B = _damping(modes, ratio) if damped else None
    grad = jax.grad(lambda yy: _potential(params, pos, R, s0, yy[:6], yy[6:].reshape(6, n_seg - 1, 3), m, com_C))

    def acc(y, v, f):
        gen = -grad(y)
        a = jnp.concatenate([Mcc_inv @ (gen[:6] + f), node_inv * gen[6:]])
        # NOTE: the modal damping is a dense n×n product (O(n²) per step); with ζ = 0 it is
        # skipped, not multiplied by zero
        return a - B @ v if damped else a

    def observe(y):
        nodes = jnp.concatenate([
            (pos + y[:3] + params.anchors @ (_exp(y[3:6]) @ R).T)[:, None],
            y[6:].reshape(6, n_seg - 1, 3), params.towers[:, None]], axis=1)
        _, length, tension = _segments(params, s0, nodes)
        return tension[:, 0], jnp.max(length / (s0 / n_seg)[:, None] - 1.0)

    def step(carry, f_pair):
        y, v, a = carry
        f_next = f_pair
        y1 = y + v * dt + 0.5 * a * dt**2
        a1 = acc(y1, v + a * dt, f_next)
        v1 = v + 0.5 * (a + a1) * dt
        T, strain = observe(y1)
        return (y1, v1, a1), (y1[:6], v1[:6], T, strain)

    y = y_eq + y0
    a0 = acc(y, v0, force[0])
    T0, s_0 = observe(y)
    _, (q, qd, T, strain) = jax.lax.scan(step, (y, v0, a0), force[1:])
    cat = lambda a, b: jnp.concatenate([a[None], b], axis=0)  # noqa: E731
    n = force.shape[0]
    return LumpedTrajectory(jnp.arange(n) * dt, cat(y[:6], q), cat(v0[:6], qd), cat(T0, T),
                            jnp.maximum(s_0, jnp.max(strain)))


_run_jit = jax.jit(_run, static_argnames=("damped",))


@partial(jax.jit, static_argnames=("damped",))
def _run_batch(params, modes, y0, v0, dt, force, ratio, damped=True):
    return jax.vmap(partial(_run, damped=damped), in_axes=(None, 0, 0, 0, None, 0, None))(
        params, modes, y0, v0, dt, force, ratio)


def _check(modes: LumpedModes, dt, n_steps, damping_ratio, batched):
    if not (isinstance(n_steps, int | np.integer) and n_steps >= 1):
        raise ValueError(f"n_steps must be a positive integer, got {n_steps!r}")
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive time step in s, got {dt}")
    if not (np.isfinite(damping_ratio) and 0 <= damping_ratio < 1):
        raise ValueError(f"damping_ratio must be in [0, 1), got {damping_ratio}")
    f = np.asarray(modes.frequencies_hz)
    if not np.all(np.asarray(modes.ok)) or not np.all(np.asarray(modes.stable)):
        raise ValueError("the lumped modes are not a stable, converged equilibrium; nothing to simulate")
    w_max = 2.0 * np.pi * float(np.max(f))
    if dt > 1.9 / w_max:
        raise ValueError(f"dt = {dt} s is above the explicit integrator's stability limit 1.9/ω_max = "
                         f"{1.9 / w_max:.3g} s (highest mode {np.max(f):.4g} Hz, an axial wave in a segment)")


def simulate_lumped(
    params,
    modes: LumpedModes,
    dt: float,
    n_steps: int,
    *,
    displacement: Float[ArrayLike, " n"] | None = None,
    velocity: Float[ArrayLike, " n"] | None = None,
    force: Float[ArrayLike, "n_steps+1 6"] | None = None,
    damping_ratio: float = 0.0,
) -> LumpedTrajectory:
    """Response of the cabin and its lumped cables from the static pose of ``modes``
    (:func:`~stewart_jax.cable_robot.lumped_modes`) displaced by ``displacement`` and moving at
    ``velocity`` (coordinates as ``modes.shapes``' rows: cabin ``(m, rad)``, then nodes (m);
    zero by default), under the generalised force ``force`` on the cabin sampled at ``k dt``
    (N, N·m; none by default), with modal damping ratio ``damping_ratio``, for ``n_steps``
    steps of ``dt`` seconds.

    A batch: ``modes`` stacked over positions (same number of segments; every field with a
    leading axis), ``displacement``/``velocity``/``force`` with the same leading axis; the
    positions run in one ``vmap``.
    """
    freq = np.asarray(modes.frequencies_hz)
    batched = freq.ndim == 2
    _check(modes, dt, n_steps, damping_ratio, batched)
    shape = freq.shape
    y0 = jnp.zeros(shape) if displacement is None else jnp.asarray(displacement, jnp.float64)
    v0 = jnp.zeros(shape) if velocity is None else jnp.asarray(velocity, jnp.float64)
    lead = shape[:-1]
    f = (jnp.zeros((*lead, n_steps + 1, 6)) if force is None else jnp.asarray(force, jnp.float64))
    if y0.shape != shape or v0.shape != shape:
        raise ValueError(f"displacement and velocity must have shape {shape}, got {y0.shape} and {v0.shape}")
    if f.shape != (*lead, n_steps + 1, 6):
        raise ValueError(f"force must have shape {(*lead, n_steps + 1, 6)} (one row per time k dt), got {f.shape}")
    run = _run_batch if batched else _run_jit
    return run(params, modes, y0, v0, jnp.asarray(dt, jnp.float64), f, jnp.asarray(damping_ratio, jnp.float64),
               damped=bool(damping_ratio > 0))
