"""Stiffness, mass matrix and vibration modes of the FAST cabin hanging on six elastic
catenaries with their unstretched lengths fixed, and where the quasi-static cable assumption
stops holding.

Model: Yin J., Jiang P., Chen M., Yao R., *Dynamic modeling of a cable-driven parallel robot
with a Stewart platform for use in FAST*: cables are quasi-static elastic catenaries (§2,
eqs. 6–13) with ``s0`` fixed after the initial equilibrium (§5); the cabin + upper platform,
the six legs and the lower platform move as one rigid body when the legs are held (eqs.
57–60 with the platform at rest). Taut-string and sag parameters of a cable follow Irvine H. M.,
*Cable structures*, MIT Press, 1981 (the paper's ref. 12), ch. 3–4.

Small motions about a static pose ``(t_C, R_C)`` are ``q = (δt, δφ)``: a displacement of C's
origin and a rotation vector in G, ``R_C(δφ) = exp([δφ]×) R_C``. Then

- **stiffness** ``K = −∂r/∂q`` with ``r`` the static wrench of eqs. 57–58 (force; moment about
  C's origin) — cables, the weight of every body, the legs — with the cable forces at fixed
  ``s0``. Its derivative is exact: the cable forces move by ``dF = J⁻¹ dδ`` (implicit
  function theorem on eqs. 11–13, J from the closed-form
  :func:`~stewart_jax.cable_robot._catenary.catenary_jacobian`), the rest by ``jax.jacfwd``. At an
  equilibrium ``K`` is the Hessian of the potential energy, symmetric
  (the asymmetry is reported; the moment's derivative with respect to the rotation
  coordinates differs from the Hessian by a term proportional to the net moment, zero at
  equilibrium);
- **mass matrix** of the 14 bodies (cabin + upper platform, 12 leg parts, lower platform)
  moving rigidly, about C's origin. The coupled simulation's legs turn without spin about
  their axes (eq. 45); its inertia (:func:`paper_momentum_matrix`) differs by ≈1e-4 of the
  coupling block, far below the 2 % to which the free response is compared;
- **modes**: ``K φ = ω² M φ`` by a Cholesky reduction to a symmetric eigenproblem; shapes are
  M-orthonormal columns ``(δt in m, δφ in rad)``.

NOTE (12 degrees of freedom): in Yin et al. the legs follow prescribed lengths, so the lower
platform is kinematically locked to the cabin and a 12-DOF model with the lower platform as a
second body reduces exactly to this one; the paper gives no actuator stiffness that a
second body would need. See ``docs/cable_robot.md`` for the size of the effect of a finite one.
"""

from __future__ import annotations

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float

from ._catenary import _solve3, catenary_jacobian
from ._scenario import system_momentum
from ._statics import StaticSolution, static_equilibrium, static_equilibrium_jit
from ._system import FastParams, cable_deltas, check_position, static_lower_motion
from ._workspace import assembly_bodies, assembly_centre_of_mass


class CabinModes(NamedTuple):
    """Small vibrations of the cabin about a static pose (:func:`cabin_modes`).

    - ``frequencies_hz``: ``Float[Array, "6"]``, natural frequencies, ascending (Hz); NaN-free:
      an unstable direction (negative eigenvalue) gives ``-√|λ|/2π`` and ``stable = False``.
    - ``shapes``: ``Float[Array, "6 6"]``, column k is mode k, ``(δt (m), δφ (rad))``,
      M-orthonormal.
    - ``stiffness``: ``Float[Array, "6 6"]`` (N/m, N, N·m/rad), symmetrised;
      ``mass``: ``Float[Array, "6 6"]`` (kg, kg·m, kg·m²).
    - ``asymmetry``: ``Float[Array, ""]``, ``|K − Kᵀ|_max / |K|_max`` before symmetrising.
    - ``static``: :class:`~stewart_jax.cable_robot.StaticSolution` at the pose.
    - ``stable``, ``ok``: ``Bool[Array, ""]``; ``ok`` = the static solve converged and the
      frequencies are finite.
    """

    frequencies_hz: Float[Array, "6"]
    shapes: Float[Array, "6 6"]
    stiffness: Float[Array, "6 6"]
    mass: Float[Array, "6 6"]
    asymmetry: Float[Array, ""]
    static: StaticSolution
    stable: Bool[Array, ""]
    ok: Bool[Array, ""]


def _skew(v):
    return jnp.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def _exp(phi):
    # exp([φ]×) to second order plus the exact higher terms; only its derivative at 0 matters.
    a2 = jnp.sum(phi * phi)
    small = a2 < 1e-16
    a = jnp.sqrt(jnp.where(small, 1.0, a2))
    s = jnp.where(small, 1.0 - a2 / 6.0, jnp.sin(a) / a)
    c = jnp.where(small, 0.5 - a2 / 24.0, (1.0 - jnp.cos(a)) / jnp.where(small, 1.0, a2))
    K = _skew(phi)
    return jnp.eye(3) + s * K + c * (K @ K)


def static_wrench(
    params: FastParams,
    position: Float[Array, "3"],
    R: Float[Array, "3 3"],
    cable_forces: Float[Array, "6 3"],
    q: Float[Array, "6"],
) -> Float[Array, "6"]:
    """Net static wrench on the suspended assembly (force; moment about C's origin; N, N·m) at
    the pose displaced by ``q = (δt, δφ)`` with the given lower-end cable forces: the cables'
    ``−F`` at the anchors and the total weight at the assembly's centre of mass. At rest this
    is eqs. 57–58 with the legs' wrench from the momentum balance of legs + lower platform
    (their weights), i.e. :func:`~stewart_jax.cable_robot._system.cabin_residual` at zero motion."""
    pos = position + q[:3]
    Rq = _exp(q[3:]) @ R
    m, com = assembly_centre_of_mass(params, pos, Rq)
    arm = params.anchors @ Rq.T
    weight = m * params.gravity
    force = -jnp.sum(cable_forces, axis=0) + weight
    moment = -jnp.sum(jnp.cross(arm, cable_forces), axis=0) + jnp.cross(com - pos, weight)
    return jnp.concatenate([force, moment])


def cabin_stiffness(
    params: FastParams,
    position: Float[Array, "3"],
    R: Float[Array, "3 3"],
    s0: Float[Array, "6"],
    force: Float[Array, "6 3"],
) -> Float[Array, "6 6"]:
    """``K = −∂(static wrench)/∂q`` at ``q = 0`` (not symmetrised) about an equilibrium
    ``(force, s0)`` of the cables.

    NOTE (implicit differentiation, written out): with ``s0`` fixed, a cable's end condition
    ``end(F, s0) = δ`` (eqs. 11–13) gives ``dF = J⁻¹ dδ`` with ``J = ∂end/∂F`` in closed form
    (:func:`~stewart_jax.cable_robot._catenary.catenary_jacobian`). The cable forces are therefore
    replaced by their exact first-order expansion ``F + J⁻¹ (δ(q) − δ(0))`` and the wrench is
    differentiated by ``jax.jacfwd``: the same derivative as differentiating through
    :func:`~stewart_jax.cable_robot.solve_catenary` (which uses the same implicit rule), without
    tracing a Newton solve (tested against both, and against finite differences)."""
    _, J = catenary_jacobian(params.cable, force, s0)
    d0 = cable_deltas(params, position, R)

    def wrench(q):
        d = cable_deltas(params, position + q[:3], _exp(q[3:]) @ R)
        F = force + _solve3(J, d - d0)
        return static_wrench(params, position, R, F, q)

    return -jax.jacfwd(wrench)(jnp.zeros(6, jnp.float64))


def cabin_mass_matrix(params: FastParams, R: Float[Array, "3 3"]) -> Float[Array, "6 6"]:
    """Generalised mass matrix of cabin + legs + lower platform moving as one rigid body (legs
    held) for ``q̇ = (ṫ_C, ω)``: ``Σ_b [[m I, −m [c]×], [m [c]×, I_b − m [c]×²]]`` over the 14
    bodies (``c`` each centre of mass from C's origin, ``I_b`` central)."""
    b = assembly_bodies(params, R)
    S = jax.vmap(_skew)(b.centre)
    m = b.mass[:, None, None]
    top = jnp.concatenate([jnp.sum(m * jnp.eye(3), 0), -jnp.sum(m * S, 0)], axis=1)
    bottom = jnp.concatenate([jnp.sum(m * S, 0), jnp.sum(b.inertia - m * (S @ S), 0)], axis=1)
    return jnp.concatenate([top, bottom], axis=0)


def paper_momentum_matrix(params: FastParams, R: Float[Array, "3 3"]) -> Float[Array, "6 6"]:
    """``∂(p, h)/∂(ṫ_C, ω)`` of :func:`~stewart_jax.cable_robot._scenario.system_momentum` with the lower
    platform held: the inertia the coupled simulation sees, whose legs turn without spin about
    their axes (eq. 45). It differs from :func:`cabin_mass_matrix` by the legs' spin terms
    (≈1e-4 of the coupling block, off-axis leg centres of mass) and is not exactly symmetric."""
    lower = static_lower_motion(params.h)

    def momentum(v):
        return system_momentum(params, R, v[:3], v[3:], lower)

    return jax.jacfwd(momentum)(jnp.zeros(6, jnp.float64))


def modes_from_matrices(
    K: Float[Array, "6 6"], M: Float[Array, "6 6"]
) -> tuple[Float[Array, "6"], Float[Array, "6 6"], Bool[Array, ""]]:
    """Frequencies (Hz, ascending; negative for unstable directions), M-orthonormal shapes and
    stability of ``K φ = ω² M φ`` (K, M symmetric, M positive definite)."""
    L = jnp.linalg.cholesky(M)
    Li = jax.scipy.linalg.solve_triangular(L, jnp.eye(M.shape[0]), lower=True)
    A = Li @ K @ Li.T
    lam, V = jnp.linalg.eigh(0.5 * (A + A.T))
    shapes = Li.T @ V
    # NOTE: fix the sign of each shape (largest component positive) so that maps and tests
    # compare shapes, not the eigen-solver's arbitrary signs.
    k = jnp.argmax(jnp.abs(shapes), axis=0)
    sign = jnp.sign(shapes[k, jnp.arange(shapes.shape[1])])
    shapes = shapes * jnp.where(sign == 0, 1.0, sign)
    freq = jnp.sign(lam) * jnp.sqrt(jnp.abs(lam)) / (2.0 * jnp.pi)
    return freq, shapes, jnp.all(lam > 0)


def cabin_modes(
    params: FastParams,
    position: Float[ArrayLike, "3"],
    R: Float[ArrayLike, "3 3"] | None = None,
    static: StaticSolution | None = None,
) -> CabinModes:
    """Stiffness, mass matrix, natural frequencies and mode shapes of the cabin at
    ``position`` (m) with attitude ``R`` (identity by default), about the static equilibrium
    (solved here unless ``static`` is given). Traceable: ``vmap`` over a map of poses."""
    check_position(position)
    pos = jnp.asarray(position, jnp.float64)
    R = jnp.eye(3, dtype=jnp.float64) if R is None else jnp.asarray(R, jnp.float64)
    st = static_equilibrium(params, pos, R) if static is None else static
    K = cabin_stiffness(params, pos, R, st.s0, st.force)
    M = cabin_mass_matrix(params, R)
    asym = jnp.max(jnp.abs(K - K.T)) / jnp.max(jnp.abs(K))
    Ks = 0.5 * (K + K.T)
    freq, shapes, stable = modes_from_matrices(Ks, M)
    ok = st.converged & jnp.all(jnp.isfinite(freq))
    return CabinModes(freq, shapes, Ks, M, asym, st, stable, ok)


cabin_modes_jit = jax.jit(cabin_modes)
"""``jax.jit`` of :func:`cabin_modes`."""


@jax.jit
def _modes_batch(params, pos, Rs, statics):
    return jax.vmap(lambda p, R, st: cabin_modes(params, p, R, st))(pos, Rs, statics)


def modes_map(
    params: FastParams,
    positions: Float[ArrayLike, "n 3"],
    attitudes: Float[ArrayLike, "n 3 3"] | None = None,
    statics: StaticSolution | None = None,
) -> CabinModes:
    """:func:`cabin_modes` at every row of ``positions`` (attitudes identity when ``None``):
    the static equilibria (given stacked in ``statics``, or solved one by one with
    :data:`~stewart_jax.cable_robot._statics.static_equilibrium_jit`), then stiffness, mass matrix and
    modes in one ``vmap``-ed, jitted call; every field gains a leading axis ``n``. Positions
    without an equilibrium have ``ok = False``."""
    pos = np.asarray(positions, dtype=np.float64)
    if pos.ndim != 2 or pos.shape[-1] != 3 or not np.all(np.isfinite(pos)):
        raise ValueError(f"positions must be a finite (n, 3) array, got shape {pos.shape}")
    Rs = (np.broadcast_to(np.eye(3), (pos.shape[0], 3, 3)) if attitudes is None
          else np.asarray(attitudes, dtype=np.float64))
    if Rs.shape != (pos.shape[0], 3, 3):
        raise ValueError(f"attitudes must have shape ({pos.shape[0]}, 3, 3), got {Rs.shape}")
    if statics is None:
        sts = [static_equilibrium_jit(params, jnp.asarray(p), jnp.asarray(R))
               for p, R in zip(pos, Rs, strict=True)]
        statics = jax.tree.map(lambda *a: jnp.stack(a), *sts)
    return _modes_batch(params, jnp.asarray(pos), jnp.asarray(Rs), statics)


def cable_inertia_matrix(
    params: FastParams, static: StaticSolution, R: Float[ArrayLike, "3 3"] | None = None
) -> Float[Array, "6 6"]:
    """Rayleigh–Ritz estimate of the cables' own inertia seen by the cabin (kg, kg·m, kg·m²):
    each cable moves in its quasi-static shape for a displaced anchor, taken linear in the
    material coordinate (0 at the tower, the anchor's displacement at the cabin), so its
    kinetic energy is ``½ (ρ s0 / 3) |δ_A|²`` and ``M_c = Σ (ρ s0 / 3) A_iᵀ A_i`` with
    ``δ_A = A_i q = δt − [R r_A]× δφ``. Valid only well below the cables' string frequencies
    (:func:`cable_string_modes`), where the quasi-static shape holds."""
    R = jnp.eye(3, dtype=jnp.float64) if R is None else jnp.asarray(R, jnp.float64)
    r = params.anchors @ R.T
    A = jnp.concatenate([jnp.broadcast_to(jnp.eye(3), (6, 3, 3)), -jax.vmap(_skew)(r)], axis=2)
    m = params.cable.rho * static.s0 / 3.0
    return jnp.einsum("i,iak,ial->kl", m, A, A)


class CableStringModes(NamedTuple):
    """First vibration frequencies of each cable on its own, ends fixed (Irvine 1981).

    - ``taut_string_hz``: ``Float[Array, "6"]``, ``f1 = (1/2ℓ) √(T̄/μ)``: ℓ the stretched arc
      length, T̄ the mean tension along the cable, μ = ρ s0/ℓ the mass per stretched length.
      Out-of-plane and antisymmetric in-plane modes of a sagging cable are at (n × this);
    - ``irvine_lambda2``: ``Float[Array, "6"]``, Irvine's sag–extensibility parameter
      ``λ² = (m g ℓ_h / H)² ℓ_h / (H L_e / EA)`` (``ℓ_h`` the horizontal span, ``L_e ≈ ℓ``);
      above 4π² ≈ 39.5 the first symmetric in-plane mode rises above the antisymmetric one
      (sag-dominated cable).
    """

    taut_string_hz: Float[Array, "6"]
    irvine_lambda2: Float[Array, "6"]


@eqx.filter_jit
def cable_string_modes(
    params: FastParams, position: Float[ArrayLike, "3"], static: StaticSolution,
    R: Float[ArrayLike, "3 3"] | None = None,
) -> CableStringModes:
    """First string frequencies of the six cables at a static pose (see
    :class:`CableStringModes`)."""
    pos = jnp.asarray(position, jnp.float64)
    R = jnp.eye(3, dtype=jnp.float64) if R is None else jnp.asarray(R, jnp.float64)
    c = params.cable
    s0, F = static.s0, static.force
    w = c.rho * jnp.abs(c.g)
    # mean tension along the cable: ∫ K(s) ds / s0 by Simpson's rule on 65 points
    s = jnp.linspace(0.0, 1.0, 65)[:, None] * s0[None, :]
    K = jnp.sqrt(F[None, :, 0] ** 2 + F[None, :, 1] ** 2 + (F[None, :, 2] - w * s) ** 2)
    wts = jnp.ones(65).at[1:-1:2].set(4.0).at[2:-1:2].set(2.0) / (3.0 * 64)
    T_mean = jnp.sum(wts[:, None] * K, axis=0)
    stretched = s0 * (1.0 + T_mean / c.EA)
    mu = c.rho * s0 / stretched
    f1 = jnp.sqrt(T_mean / mu) / (2.0 * stretched)
    delta = cable_deltas(params, pos, R)
    span = jnp.linalg.norm(delta[:, :2], axis=-1)
    H = jnp.linalg.norm(F[:, :2], axis=-1)
    lam2 = (w * span / H) ** 2 * span / (H * stretched / c.EA)
    return CableStringModes(f1, lam2)
