"""The free vibration of the FAST cabin as a superposition of damped modes, on quasi-static
cables and with the cables' own inertia, as a differentiable function of the initial state and
of four physical changes: the share of the cables' mass that moves, the cables' axial
stiffness, the cabin assembly's mass and the damping of each group of modes. It is the model a
record of the cabin's motion is fitted with (:mod:`stewart_jax.discrepancy`).

**Quasi-static cables** (Yin J., Jiang P., Chen M., Yao R., *Dynamic modeling of a cable-driven
parallel robot with a Stewart platform for use in FAST*, §2 and §5): the cabin assembly is one
rigid body with the coordinates ``q = (δt, δφ)`` of :mod:`._modes`, stiffness ``K`` of the
elastic catenaries at fixed unstretched lengths and mass matrix ``M``; its 6 modes solve
``K φ = ω² M φ``.

**Cables with mass** — a Craig–Bampton reduction (Craig R. R., Bampton M. C. C., *Coupling of
substructures for dynamic analyses*, AIAA Journal 6(7), 1968, 1313–1319) of the lumped-mass
cables of :mod:`._lumped` (Hall and Goupee 2015, MoorDyn's discretisation). With the Hessian
``[[K_cc, K_cn], [K_nc, K_nn]]`` of the lumped model about its equilibrium, its node masses
``M_n`` and the mass ``M_a`` of the end nodes riding on the cabin, the nodes are written as

    x = G q + Ψ p,    G = −K_nn⁻¹ K_nc,    K_nn Ψ = M_n Ψ Ω²,  Ψᵀ M_n Ψ = I,

the quasi-static shape the cabin's motion imposes (``G``, the constraint modes) plus every
fixed-interface mode of the cables (``Ψ``, the string modes with the cabin held). The potential
energy is then exactly ``½ qᵀ K_s q + ½ pᵀ Ω² p`` (``K_s = K_cc + K_cn G``, the Schur
complement) and the kinetic energy ``½ q̇ᵀ (M + M_a + Gᵀ M_n G) q̇ + q̇ᵀ Gᵀ M_n Ψ ṗ + ½ ṗᵀ ṗ``.
Nothing is truncated: at mass share 1 the reduced system has the lumped model's modes exactly.

The **mass share** μ scales the inertia of every cable node (their weight, and with it the
statics, are unchanged): ``M_a + Gᵀ M_n G → μ (…)``, the coupling ``→ μ Gᵀ M_n Ψ``, the node
block ``→ μ I``. μ = 0 is the quasi-static model, μ = 1 the lumped-mass model.

The **continuum share** γ carries the cables' blocks from N segments towards continuous cables:
``M_a + Gᵀ M_n G``, ``Gᵀ M_n Ψ``, ``Ω²`` and ``K_s`` are each ``X_N + γ ΔX``, with ``ΔX`` Richardson's
extrapolation from the same blocks at 2N and 4N (:mod:`._cable_continuum`). γ = 0 is the lumped
model at N, γ = 1 continuous cables (to ``O(1/N⁶)``), and ``γ = 1 − (N/N′)²`` the lumped model
at N′ to leading order: a record of real cables, or of a simulator with other segments, is
described by the model at N with the γ the fit finds.

NOTE (μ = 0 and the cabin's stiffness): the cabin block's stiffness is ``K + μ (K_s − K)``: the
catenaries' ``K`` at μ = 0, the lumped model's own ``K_s`` at μ = 1. The two differ by the
lumped statics' discretisation error, ``O(1/N²)`` (0.25–1 % in frequency at N = 10–6); without
the blend the quasi-static limit of the lumped model would not be the paper's model, and with
``K`` throughout the model at μ = 1 would not be the lumped one (at N = 6 the swing modes then
fall 0.7 % below the lumped model's, while the continuum limit lies above both).

NOTE (the limit μ → 0): the node coordinates are scaled, ``r = √μ p``, so that the node block of
the mass matrix is ``I`` and the string modes' stiffness ``Ω²/μ``; as μ → 0 the string modes
leave for infinite frequency while their share of the cabin's motion vanishes as ``μ²``. The
reduced eigenproblem is solved at ``μ₊ = max(μ, 0) + 10⁻⁴`` in those two places only (the
string modes then sit at ≥ 100 × their frequency with a 10⁻⁸ share of the cabin's motion), and
the cabin's added mass is ``μ (M_a + Gᵀ M_n G)`` for any μ: smooth through μ = 0 with the exact
first derivative there, the added mass of the cables moving in their quasi-static shape
(Rayleigh's estimate; the coupling adds only ``O(μ²)``), and defined for μ < 0, where a fit on
noise may step.

**Axial stiffness and cabin mass.** A cable stiffness ``EA (1 + κ)`` or a cabin assembly whose
every mass and inertia is ``(1 + κ_m)`` times the paper's changes the statics: the winches still
hold the cabin where it is, so the unstretched lengths and tensions are solved again
(:func:`~stewart_jax.cable_robot.static_equilibrium`), and with them ``K``. ``K(κ)`` and
``K(κ_m)`` are tabulated at the Chebyshev points of ``ea_range``/``mass_range`` and interpolated
by a Chebyshev series (degree 8: within 1e-6 of |K| inside the ranges, checked in the tests; continued
linearly outside them, a fit's excursion, not a model); the mass
matrix scales exactly, ``M (1 + κ_m)``. The cables' own inertia (μ's part) is kept at the paper's
EA and masses.

**Damping.** Modal damping (classical damping in modal form, as :mod:`._lumped_time`): each
mode m decays at its ratio ``ζ_m = ζ + Σ_g δζ_g s_g(m)``, with ``s_g(m)`` the share of the mode's
cabin kinetic energy (diagonal of ``M``) in the group's coordinates: ``swing`` (δt_x, δt_y),
``heave`` (δt_z), ``rotation`` (δφ). A cable mode that hardly moves the cabin takes the ratios of
the cabin motion it carries.

**Free response.** From a cabin displaced by ``q0`` and moving at ``v0``, the cables' nodes at
``(1 − β)`` times the quasi-static shape and velocity this imposes (β = 0, ``p = ṗ = 0``: released
from a static offset under a load, or any state the cables followed quasi-statically; β = 1, the
nodes at rest in the static pose: a cabin displaced or struck faster than the string modes can
follow), each mode evolves as the damped oscillator
``η(t) = e^{−ζωt} (η₀ cos ω_d t + (η̇₀ + ζ ω η₀)/ω_d sin ω_d t)``, ``ω_d = ω √(1 − ζ²)``,
``η₀ = φᵀ M y₀``.
"""

from __future__ import annotations

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ._cable_continuum import ContinuumChange, as_arrays, continuum_change, craig_bampton
from ._lumped import MAX_SEGMENTS
from ._modes import cabin_mass_matrix, cabin_stiffness
from ._statics import static_equilibrium
from ._system import FastParams, check_position

DAMPING_GROUPS = ("swing", "heave", "rotation")
"""The mode groups of the damping effect, by the cabin coordinates whose kinetic energy they
carry: horizontal translation, vertical translation, rotation."""
_GROUP_OF_COORDINATE = (0, 0, 1, 2, 2, 2)
MU_FLOOR = 1e-4
"""Mass share at which the string modes are evaluated when μ ≤ 0 (see the module's NOTE)."""
CHEBYSHEV_DEGREE = 8


class CabinVariation(NamedTuple):
    """Changes from the paper's quasi-static model (all 0: the paper's model).

    - ``cable_mass_share``: μ, the share of the cables' mass that moves (0 quasi-static, 1 the
      lumped-mass cables).
    - ``ea_change``: κ, the cables' axial stiffness is ``EA (1 + κ)``.
    - ``mass_change``: κ_m, every mass and inertia of the cabin assembly is ``(1 + κ_m)`` ×.
    - ``damping_change``: ``Float[Array, "3"]``, δζ per group of :data:`DAMPING_GROUPS`.
    - ``node_lag``: β, how far the cables' nodes lag the cabin's initial state: they start at
      ``(1 − β)`` × the quasi-static shape and velocity of the cabin's initial displacement and
      velocity (0: released from a static offset, the cables in equilibrium with the cabin held
      by a load; 1: the cables at rest in the static pose, as after an impulse on the cabin).

    - ``continuum``: γ, how near continuous the cables are: the cables' blocks are those at N
      segments plus γ × their extrapolation to continuous cables (0: the lumped model at N;
      1: continuous cables; γ stands for ``N / √(1 − γ)`` segments,
      :mod:`._cable_continuum`).
    """

    cable_mass_share: Float[ArrayLike, ""] = 0.0
    ea_change: Float[ArrayLike, ""] = 0.0
    mass_change: Float[ArrayLike, ""] = 0.0
    damping_change: Float[ArrayLike, "3"] = (0.0, 0.0, 0.0)
    node_lag: Float[ArrayLike, ""] = 0.0
    continuum: Float[ArrayLike, ""] = 0.0


class CabinModalModel(eqx.Module):
    """The matrices of the cabin's small vibrations at one static pose (:func:`cabin_modal_model`);
    SI units, cabin coordinates ``(δt (m), δφ (rad))`` in G.

    - ``position``: ``Float[Array, "3"]``, ``G t_C`` (m); ``R``: ``Float[Array, "3 3"]``.
    - ``mass``, ``stiffness``: ``Float[Array, "6 6"]``, the quasi-static model's ``M``, ``K``.
    - ``ea_coef``, ``mass_coef``: ``Float[Array, "d+1 6 6"]``, Chebyshev coefficients of
      ``K(κ) − K`` and ``K(κ_m) − K`` on ``ea_range``/``mass_range``.
    - ``added_mass``: ``Float[Array, "6 6"]``, ``M_a + Gᵀ M_n G`` (kg, kg·m, kg·m²).
    - ``coupling``: ``Float[Array, "6 n"]``, ``Gᵀ M_n Ψ``; ``string_omega2``:
      ``Float[Array, "n"]``, ``Ω²`` (rad²/s²): the ``n = 18 (N − 1)`` fixed-interface modes,
      cable by cable.
    - ``lumped_stiffness_change``: ``Float[Array, "6 6"]``, ``K_s − K``.
    - ``continuum``: :class:`~._cable_continuum.ContinuumChange`, the changes that carry the
      added mass, ``coupling``, ``string_omega2`` and ``K_s`` to continuous cables.
    - ``segments``, ``ea_range``, ``mass_range``: static.
    """

    position: Float[Array, "3"]
    R: Float[Array, "3 3"]
    mass: Float[Array, "6 6"]
    stiffness: Float[Array, "6 6"]
    ea_coef: Float[Array, "d 6 6"]
    mass_coef: Float[Array, "d 6 6"]
    added_mass: Float[Array, "6 6"]
    coupling: Float[Array, "6 n"]
    string_omega2: Float[Array, " n"]
    lumped_stiffness_change: Float[Array, "6 6"]
    continuum: ContinuumChange
    segments: int = eqx.field(static=True)
    ea_range: tuple[float, float] = eqx.field(static=True)
    mass_range: tuple[float, float] = eqx.field(static=True)

    def modes(self, variation: CabinVariation | None = None) -> CabinModalModes:
        """The modes of the cabin (and the cables' fixed-interface modes, with inertia) under
        ``variation`` (default: the paper's model), ascending (:class:`CabinModalModes`)."""
        return cabin_modal_modes(self, CabinVariation() if variation is None else variation)


def scaled_params(params: FastParams, ea_factor=1.0, mass_factor=1.0) -> FastParams:
    """``params`` with the cables' ``EA × ea_factor`` and every mass and inertia of the cabin
    assembly (cabin + upper platform, the legs' parts, the lower platform) ``× mass_factor``."""
    sp = params.stewart
    sp = eqx.tree_at(lambda s: (s.m_U, s.m_D, s.I_U, s.I_D, s.m_P, s.I_P), sp,
                     (sp.m_U * mass_factor, sp.m_D * mass_factor, sp.I_U * mass_factor,
                      sp.I_D * mass_factor, sp.m_P * mass_factor, sp.I_P * mass_factor))
    return eqx.tree_at(lambda p: (p.cable.EA, p.stewart, p.m_CB, p.I_CB), params,
                       (params.cable.EA * ea_factor, sp, params.m_CB * mass_factor, params.I_CB * mass_factor))


@jax.jit
def _stiffness_at(params, position, R, ea_factor, mass_factor):
    p = scaled_params(params, ea_factor, mass_factor)
    st = static_equilibrium(p, position, R)
    K = cabin_stiffness(p, position, R, st.s0, st.force)
    return 0.5 * (K + K.T), st.converged, st.s0, st.force


def _chebyshev_nodes(lo: float, hi: float, n: int) -> np.ndarray:
    x = np.cos(np.pi * (np.arange(n) + 0.5) / n)
    return 0.5 * (lo + hi) + 0.5 * (hi - lo) * x


def _chebyshev_table(params, position, R, K0, lo, hi, which: str) -> np.ndarray:
    nodes = _chebyshev_nodes(lo, hi, CHEBYSHEV_DEGREE + 1)
    values = []
    for k in nodes:
        ea, mass = (1.0 + k, 1.0) if which == "ea" else (1.0, 1.0 + k)
        K, ok, _, _ = _stiffness_at(params, position, R, ea, mass)
        if not bool(ok):
            raise ValueError(f"no static equilibrium at {np.asarray(position).tolist()} m with the "
                             f"{'cables’ EA' if which == 'ea' else 'cabin mass'} × {1.0 + k:.3g}: narrow the range")
        values.append(np.asarray(K) - K0)
    t = (2.0 * nodes - (lo + hi)) / (hi - lo)
    coef = np.polynomial.chebyshev.chebfit(t, np.stack(values).reshape(len(nodes), -1), CHEBYSHEV_DEGREE)
    return coef.reshape(CHEBYSHEV_DEGREE + 1, 6, 6)


def _clenshaw(coef, t):
    # Σ c_k T_k(t) by Clenshaw's recurrence.
    b1 = jnp.zeros_like(coef[0])
    b2 = jnp.zeros_like(coef[0])
    for c in coef[:0:-1]:
        b1, b2 = 2.0 * t * b1 - b2 + c, b1
    return t * b1 - b2 + coef[0]


def _chebyshev_eval(coef, lo, hi, x):
    # The series at the position t of x in [lo, hi]; continued linearly (value and slope at the
    # end) outside, where a polynomial would run away.
    t = (2.0 * x - (lo + hi)) / (hi - lo)
    tc = jnp.clip(t, -1.0, 1.0)
    value, slope = jax.jvp(lambda u: _clenshaw(coef, u), (tc,), (jnp.ones_like(tc),))
    return value + (t - tc) * slope


def cabin_modal_model(
    params: FastParams,
    position: Float[ArrayLike, "3"],
    n_segments: int,
    R: Float[ArrayLike, "3 3"] | None = None,
    *,
    ea_range: tuple[float, float] = (-0.5, 1.0),
    mass_range: tuple[float, float] = (-0.3, 0.5),
) -> CabinModalModel:
    """The :class:`CabinModalModel` at ``position`` (m) and attitude ``R`` (identity by default):
    the quasi-static model, the Craig–Bampton blocks of the lumped cables with ``n_segments``
    segments (:func:`~stewart_jax.cable_robot.lumped_modes`, whose errors it raises), and the
    stiffness tables over the relative changes ``ea_range`` of EA and ``mass_range`` of the
    cabin assembly's mass (each an interval around 0)."""
    check_position(position)
    for name, (lo, hi) in (("ea_range", ea_range), ("mass_range", mass_range)):
        if not (np.isfinite(lo) and np.isfinite(hi) and -1.0 < lo < 0.0 < hi):
            raise ValueError(f"{name} must be an interval (lo, hi) with -1 < lo < 0 < hi, got {(lo, hi)}")
    pos = jnp.asarray(position, jnp.float64)
    R = jnp.eye(3, dtype=jnp.float64) if R is None else jnp.asarray(R, jnp.float64)
    K0, ok, s0, force = _stiffness_at(params, pos, R, 1.0, 1.0)
    if not bool(ok):
        raise ValueError(f"no static equilibrium of the elastic catenaries at {np.asarray(position).tolist()} m")
    K0 = np.asarray(K0)
    M = np.asarray(cabin_mass_matrix(params, R))
    from ._statics import StaticSolution

    static = StaticSolution(s0, force, jnp.zeros((6, 2)), jnp.asarray(True), jnp.zeros(24))
    levels = tuple(craig_bampton(params, pos, R, static, f * n_segments) for f in (1, 2, 4)
                   if f == 1 or f * n_segments <= MAX_SEGMENTS)
    coarse, change = levels[0], continuum_change(levels)
    return CabinModalModel(
        position=pos, R=R, mass=jnp.asarray(M), stiffness=jnp.asarray(K0),
        ea_coef=jnp.asarray(_chebyshev_table(params, pos, R, K0, *ea_range, "ea")),
        mass_coef=jnp.asarray(_chebyshev_table(params, pos, R, K0, *mass_range, "mass")),
        added_mass=jnp.asarray(coarse.added_mass), coupling=jnp.asarray(coarse.coupling),
        string_omega2=jnp.asarray(coarse.omega2), lumped_stiffness_change=jnp.asarray(coarse.stiffness - K0),
        continuum=as_arrays(change),
        segments=int(n_segments), ea_range=(float(ea_range[0]), float(ea_range[1])),
        mass_range=(float(mass_range[0]), float(mass_range[1])),
    )


class CableBlocks(NamedTuple):
    """The cables' blocks at a continuum share (:func:`cable_blocks`): ``added_mass`` (6 × 6),
    ``coupling`` (6 × n), ``omega2`` (n) and ``stiffness_change`` (6 × 6, ``K_s − K``)."""

    added_mass: Float[Array, "6 6"]
    coupling: Float[Array, "6 n"]
    omega2: Float[Array, " n"]
    stiffness_change: Float[Array, "6 6"]


def cable_blocks(model: CabinModalModel, continuum) -> CableBlocks:
    """The cables' blocks at the continuum share γ = ``continuum`` (the model's own at 0; the
    added mass as in :class:`~._cable_continuum.ContinuumChange`'s NOTE)."""
    g = jnp.asarray(continuum, jnp.float64)
    c = model.continuum
    coupling = model.coupling + g * c.coupling
    return CableBlocks(model.added_mass + g * c.added_mass, coupling, model.string_omega2 + g * c.omega2,
                       model.lumped_stiffness_change + g * c.stiffness)


def cabin_matrices(model: CabinModalModel, variation: CabinVariation) -> tuple[Array, Array]:
    """Stiffness and mass matrices of the reduced system, coordinates ``(q (6), r (n))`` with
    ``r = √μ₊ p`` (see the module's NOTE): ``((6+n) × (6+n), (6+n) × (6+n))``."""
    mu = jnp.asarray(variation.cable_mass_share, jnp.float64)
    ea = jnp.asarray(variation.ea_change, jnp.float64)
    km = jnp.asarray(variation.mass_change, jnp.float64)
    mu_p = jnp.maximum(mu, MU_FLOOR)
    cables = cable_blocks(model, variation.continuum)
    Kc = (model.stiffness + _chebyshev_eval(model.ea_coef, *model.ea_range, ea)
          + _chebyshev_eval(model.mass_coef, *model.mass_range, km) + mu * cables.stiffness_change)
    Mc = (1.0 + km) * model.mass + mu * cables.added_mass
    n = cables.omega2.shape[0]
    B = jnp.sqrt(mu_p) * cables.coupling
    K = jnp.zeros((6 + n, 6 + n)).at[:6, :6].set(Kc).at[6:, 6:].set(jnp.diag(cables.omega2 / mu_p))
    M = jnp.zeros((6 + n, 6 + n)).at[:6, :6].set(Mc).at[:6, 6:].set(B).at[6:, :6].set(B.T)
    M = M.at[6:, 6:].set(jnp.eye(n))
    return 0.5 * (K + K.T), 0.5 * (M + M.T)


class CabinModalModes(NamedTuple):
    """Modes of the reduced system (:func:`cabin_modal_modes`), ascending.

    - ``frequencies_hz``: ``Float[Array, "n"]``; negative for an unstable direction.
    - ``shapes``: ``Float[Array, "n n"]``, M-orthonormal columns.
    - ``cabin_energy_share``: ``Float[Array, "n"]``: the cabin's share of each mode's kinetic
      energy.
    - ``group_share``: ``Float[Array, "n 3"]``, ``s_g(m)`` of :data:`DAMPING_GROUPS`.
    - ``mass``: the reduced mass matrix.
    """

    frequencies_hz: Float[Array, " n"]
    shapes: Float[Array, "n n"]
    cabin_energy_share: Float[Array, " n"]
    group_share: Float[Array, "n 3"]
    mass: Float[Array, "n n"]


def damping_group_shares(cabin_shapes: Float[Array, "6 n"], mass_diagonal: Float[Array, "6"]) -> Float[Array, "n 3"]:
    """``s_g(m)``: the share of mode m's cabin kinetic energy (diagonal masses) in each group of
    :data:`DAMPING_GROUPS`; rows sum to 1 (0 for a mode that does not move the cabin)."""
    e = mass_diagonal[:, None] * cabin_shapes**2
    onehot = jnp.asarray(np.eye(len(DAMPING_GROUPS))[list(_GROUP_OF_COORDINATE)])
    return (onehot.T @ e).T / (jnp.sum(e, axis=0)[:, None] + 1e-30)


def cabin_modal_modes(model: CabinModalModel, variation: CabinVariation) -> CabinModalModes:
    """Every mode of the reduced system under ``variation``."""
    K, M = cabin_matrices(model, variation)
    L = jnp.linalg.cholesky(M)
    Li = jax.scipy.linalg.solve_triangular(L, jnp.eye(M.shape[0]), lower=True)
    lam, V = jnp.linalg.eigh(0.5 * (Li @ K @ Li.T + (Li @ K @ Li.T).T))
    shapes = Li.T @ V
    freq = jnp.sign(lam) * jnp.sqrt(jnp.abs(lam)) / (2.0 * jnp.pi)
    cab = shapes[:6]
    share = jnp.einsum("km,kl,lm->m", cab, M[:6, :6], cab)
    groups = damping_group_shares(cab, jnp.diagonal(model.mass))
    return CabinModalModes(freq, shapes, share, groups, M)


TIME_CHUNK = 2048
"""Samples per block in which :func:`free_response` sums the modes (its memory, with the
Jacobian's tangents, is that of one block, whatever the record's length)."""


def free_response(
    model: CabinModalModel,
    variation: CabinVariation,
    damping_ratio: Float[ArrayLike, ""],
    q0: Float[ArrayLike, "6"],
    v0: Float[ArrayLike, "6"],
    time: Float[ArrayLike, " m"],
) -> Float[Array, "m 6"]:
    """The cabin's free response ``q(t)`` (m, rad; G) at the times ``time`` (s) from ``q0``
    (m, rad) and ``v0`` (m/s, rad/s) at ``t = 0``, the cables' nodes at ``(1 − β)`` × the
    quasi-static shape and velocity these impose (β = ``variation.node_lag``), every mode damped
    at ``damping_ratio`` plus its group's ``variation.damping_change`` (see the module
    docstring). Differentiable in every argument; evaluated in blocks of :data:`TIME_CHUNK`
    samples (time and memory linear in the record's length)."""
    modes = cabin_modal_modes(model, variation)
    stable = modes.frequencies_hz > 0
    w = 2.0 * jnp.pi * jnp.where(stable, modes.frequencies_hz, 1.0)
    zeta = damping_ratio + modes.group_share @ jnp.asarray(variation.damping_change, jnp.float64)
    wd = w * jnp.sqrt(jnp.maximum(1.0 - zeta**2, 1e-6))
    # NOTE (node state): the nodes x_n = G q + Ψ p start at (1 − β) G q0, so p0 = −β Ψᵀ M_n G q0
    # = −β (Gᵀ M_n Ψ)ᵀ q0, and r0 = √μ₊ p0 in the scaled coordinates (likewise the velocity).
    mu_p = jnp.maximum(jnp.asarray(variation.cable_mass_share, jnp.float64), MU_FLOOR)
    coupling = cable_blocks(model, variation.continuum).coupling
    lag = -jnp.asarray(variation.node_lag, jnp.float64) * jnp.sqrt(mu_p) * coupling.T
    q0 = jnp.asarray(q0, jnp.float64)
    v0 = jnp.asarray(v0, jnp.float64)
    PM = modes.shapes.T @ modes.mass
    eta0 = PM @ jnp.concatenate([q0, lag @ q0])
    deta0 = PM @ jnp.concatenate([v0, lag @ v0])
    # NOTE: a direction with K φ = −s² M φ (stiffness changed beyond stability) grows as cosh/sinh:
    # such a model cannot describe a decaying record, and a fit that steps there sees it (an
    # overflow is an infinite χ², refused by the fits' line search).
    s = 2.0 * jnp.pi * jnp.where(stable, 1e-4, -modes.frequencies_hz)  # finite where unused
    cabin = modes.shapes[:6].T

    def block(t):
        t = t[:, None]
        env = jnp.exp(-zeta * w * t)
        eta = env * (eta0 * jnp.cos(wd * t) + (deta0 + zeta * w * eta0) / wd * jnp.sin(wd * t))
        grow = eta0 * jnp.cosh(s * t) + deta0 / s * jnp.sinh(s * t)
        return jnp.where(stable, eta, grow) @ cabin

    t = jnp.asarray(time, jnp.float64)
    m = t.shape[0]
    if m <= TIME_CHUNK:
        return block(t)
    pad = (-m) % TIME_CHUNK
    tp = jnp.concatenate([t, jnp.broadcast_to(t[-1], (pad,))]).reshape(-1, TIME_CHUNK)
    return jax.lax.map(block, tp).reshape(-1, 6)[:m]
