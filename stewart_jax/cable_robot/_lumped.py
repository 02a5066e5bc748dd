"""Lumped-mass cables for the FAST feed support: statics of the cables' nodes and the cabin
together, and the small vibrations of the whole system about that equilibrium.

The discretisation is the one of the lumped-mass mooring codes: Hall M., Goupee A., *Validation
of a lumped-mass mooring line model with DeepCwind semisubmersible model test data*, Ocean
Engineering 104 (2015) 590–603 (MoorDyn), §2. Each cable is cut into ``N`` straight segments of
equal unstretched length ``l0 = s0/N``; a segment carries an axial force only,

    T = EA (l/l0 − 1) when l > l0,  T = 0 when slack (no compression, no bending),

and the cable's mass sits on its ``N + 1`` nodes: ``ρ l0`` on each of the ``N − 1`` free nodes,
``ρ l0 / 2`` on each end node. The end node at the tower top is fixed; the one at the cabin anchor
rides on the cabin. The cabin assembly (cabin + upper platform, six held legs, lower platform;
Yin J., Jiang P., Chen M., Yao R., *Dynamic modeling of a cable-driven parallel robot with a
Stewart platform for use in FAST*, Table 1) is one rigid body with the coordinates of
:mod:`._modes`: ``q = (δt, δφ)``, a displacement of C's origin and a rotation vector in G.

Everything follows from the potential energy

    V(q, X) = Σ_segments ½ (EA/l0) max(l − l0, 0)² − Σ_masses m g·r,

(cabin assembly at its centre of mass, anchor end nodes at the anchors, free nodes ``X``):

- **statics** — Newton on ``∇V = 0`` in all ``18(N−1) + 6`` unknowns at once, from the elastic
  catenary (:mod:`._catenary`) sampled at the nodes' material coordinates, with the unstretched
  lengths ``s0`` of the catenary statics at the chosen pose (as in Yin et al., §5). The lumped
  statics converge to the catenary's as ``O(1/N²)``: each segment's direction is the continuous
  cable's force at its material midpoint, a midpoint rule for the catenary's integral;
- **modes** — ``K φ = ω² M φ`` with ``K = ∇²V`` at the equilibrium (exact by automatic
  differentiation; symmetric) and ``M`` block diagonal: the cabin assembly's 6×6 rigid-body mass
  plus the anchor end nodes' point masses, and ``ρ l0 I₃`` per free node.

Modal bookkeeping (what a structural-dynamics engineer reads off a modal analysis): with
M-orthonormal shapes ``φ_m`` and ``ω_m``,

- the cabin's share of mode m's kinetic energy is ``φ_m,cᵀ M_cc φ_m,c`` (``c`` the cabin's six
  coordinates, ``M_cc`` its block, anchor end nodes included); 1 − that share is in the cables;
- the static compliance of cabin coordinate k (unit generalised force on k, every node free to
  settle) is ``(K⁻¹)_kk = Σ_m φ_m,k² / ω_m²``; mode m's share of it is ``φ_m,k² / ω_m² / (K⁻¹)_kk``,
  and the shares over all modes sum to one. The cabin-dominant mode of a coordinate is the one
  with the largest share. A mode whose cabin kinetic-energy share is below ``string_share`` is
  a string mode of the cables.
"""

from __future__ import annotations

from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Int

from . import _lumped_blocks as _blocks
from ._catenary import catenary_upper_end
from ._modes import _exp, _skew, cabin_mass_matrix, modes_from_matrices
from ._statics import StaticSolution, static_equilibrium_jit
from ._system import FastParams, check_position
from ._workspace import assembly_centre_of_mass

CABIN_COORDINATES = ("swing_x", "swing_y", "heave", "roll", "pitch", "yaw")
"""Names of the cabin's coordinates ``q = (δt_x, δt_y, δt_z, δφ_x, δφ_y, δφ_z)`` (G)."""


class LumpedStatics(NamedTuple):
    """Static equilibrium of the cabin on lumped-mass cables (:func:`lumped_statics`).

    - ``position``: ``Float[Array, "3"]``, ``G t_C`` at equilibrium (m); ``R``:
      ``Float[Array, "3 3"]``, ``G R_C`` at equilibrium.
    - ``q``: ``Float[Array, "6"]``, the equilibrium's offset from the requested pose
      ``(δt (m), δφ (rad))`` — the sag the lumped cables add to the catenary statics.
    - ``nodes``: ``Float[Array, "6 N+1 3"]``, every node of every cable in G, from the cabin
      anchor (node 0) to the tower top (node N).
    - ``segment_tension_n``: ``Float[Array, "6 N"]``, axial force of each segment (N), 0 if slack.
    - ``anchor_force_n``: ``Float[Array, "6 3"]``, force of each cable on the cabin (N, G): the
      first segment's pull plus the weight of the end node riding on the cabin (the continuous
      cable's ``−F`` of eqs. 6–13).
    - ``anchor_tension_n``, ``top_tension_n``: ``Float[Array, "6"]``, ``|anchor force|`` and
      the force on the tower top (last segment plus the fixed end node's weight), N.
    - ``s0``: ``Float[Array, "6"]``, unstretched lengths (m).
    - ``residual_n``: ``Float[Array, ""]``, largest ``|∇V|`` component at the end (N, N·m).
    - ``steps``: ``Int[Array, ""]``, Newton steps taken.
    - ``converged``: ``Bool[Array, ""]``; ``slack``: ``Bool[Array, "6"]``, a cable with a slack
      segment at the solution.
    """

    position: Float[Array, "3"]
    R: Float[Array, "3 3"]
    q: Float[Array, "6"]
    nodes: Float[Array, "6 N+1 3"]
    segment_tension_n: Float[Array, "6 N"]
    anchor_force_n: Float[Array, "6 3"]
    anchor_tension_n: Float[Array, "6"]
    top_tension_n: Float[Array, "6"]
    s0: Float[Array, "6"]
    residual_n: Float[Array, ""]
    steps: Int[Array, ""]
    converged: Bool[Array, ""]
    slack: Bool[Array, "6"]


class LumpedModes(NamedTuple):
    """Vibration modes of the cabin and its lumped-mass cables (:func:`lumped_modes`), all
    ``n = 18(N−1) + 6`` of them, ascending.

    - ``frequencies_hz``: ``Float[Array, "n"]`` (negative for an unstable direction).
    - ``shapes``: ``Float[Array, "n n"]``, column m is mode m, M-orthonormal; rows 0–5 are the
      cabin's ``(δt (m), δφ (rad))``, then each cable's free nodes (m), cable-major.
    - ``cabin_energy_share``: ``Float[Array, "n"]``, the cabin's share of each mode's kinetic
      energy.
    - ``compliance_share``: ``Float[Array, "n 6"]``, each mode's share of each cabin
      coordinate's static compliance (columns sum to 1 over all modes).
    - ``compliance``: ``Float[Array, "6"]``, the static compliances ``(K⁻¹)_kk`` (m/N, rad/(N·m)).
    - ``stiffness``: ``Float[Array, "n n"]``; ``mass``: ``Float[Array, "n n"]``.
    - ``statics``: :class:`LumpedStatics`; ``stable``, ``ok``: ``Bool[Array, ""]``.
    """

    frequencies_hz: Float[Array, " n"]
    shapes: Float[Array, "n n"]
    cabin_energy_share: Float[Array, " n"]
    compliance_share: Float[Array, "n 6"]
    compliance: Float[Array, "6"]
    stiffness: Float[Array, "n n"]
    mass: Float[Array, "n n"]
    statics: LumpedStatics
    stable: Bool[Array, ""]
    ok: Bool[Array, ""]


MAX_SEGMENTS = 200
"""Most segments per cable: the lowest modes converge as O(1/N²) (the cabin's swing moves by
less than 10⁻⁴ from N = 20 to 40), while the statics, modes and the explicit integrator's step
cost grow as N and N² (an N of thousands ran for minutes with no answer)."""


def check_segments(n_segments) -> int:
    """``n_segments`` as an int, or ``ValueError`` unless it is an integer in 2 … :data:`MAX_SEGMENTS`."""
    if isinstance(n_segments, bool) or not isinstance(n_segments, int | np.integer):
        raise ValueError(f"the number of cable segments must be an integer, got {n_segments!r}")
    if n_segments < 2:
        raise ValueError(f"the number of cable segments must be at least 2 (one free node per cable), "
                         f"got {n_segments}")
    if n_segments > MAX_SEGMENTS:
        raise ValueError(f"{n_segments} segments per cable: at most {MAX_SEGMENTS} (the lowest modes converge as "
                         "1/N²; the cabin's swing moves by less than 1e-4 from 20 to 40 segments, and the cost grows "
                         "as N²)")
    return int(n_segments)


def _cabin_pose(position, R, q):
    return position + q[:3], _exp(q[3:]) @ R


def _nodes(params: FastParams, position, R, q, X):
    # All nodes, anchor (0) to tower top (N): Float[Array, "6 N+1 3"].
    p, Rq = _cabin_pose(position, R, q)
    anchors = p + params.anchors @ Rq.T
    return jnp.concatenate([anchors[:, None], X, params.towers[:, None]], axis=1)


def _segments(params, s0, nodes):
    n = nodes.shape[1] - 1
    l0 = s0 / n
    vec = jnp.diff(nodes, axis=1)
    length = jnp.linalg.norm(vec, axis=-1)
    tension = params.cable.EA * jnp.maximum(length / l0[:, None] - 1.0, 0.0)
    return vec, length, tension


def lumped_potential(
    params: FastParams, position: Float[Array, "3"], R: Float[Array, "3 3"], s0: Float[Array, "6"],
    q: Float[Array, "6"], X: Float[Array, "6 N-1 3"],
) -> Float[Array, ""]:
    """Potential energy ``V(q, X)`` (J) of the cabin assembly and the lumped cables: strain
    energy of the taut segments and the weight of every mass, up to a constant. ``X`` holds the
    free nodes (``N − 1`` per cable) in G; ``q`` is the cabin's offset from ``(position, R)``."""
    # NOTE: the assembly is rigid (legs held), so its centre of mass is fixed in C: evaluated
    # once at the requested attitude and carried by the rotation (no leg kinematics traced
    # inside the Hessian or the time loop).
    m, com0 = assembly_centre_of_mass(params, position, R)
    return _potential(params, position, R, s0, q, X, m, R.T @ (com0 - position))


def _potential(params, position, R, s0, q, X, m, com_C):
    n = X.shape[1] + 1
    l0 = s0 / n
    nodes = _nodes(params, position, R, q, X)
    _, length, _ = _segments(params, s0, nodes)
    stretch = jnp.maximum(length - l0[:, None], 0.0)
    strain = jnp.sum(0.5 * params.cable.EA / l0[:, None] * stretch**2)
    p, Rq = _cabin_pose(position, R, q)
    com = p + Rq @ com_C
    g = params.gravity
    rho = params.cable.rho
    weight = (-m * jnp.dot(com, g) - jnp.sum(0.5 * rho * l0 * (nodes[:, 0] @ g))
              - jnp.sum(rho * l0[:, None] * (X @ g)))
    return strain + weight


def catenary_nodes(
    params: FastParams, position: Float[Array, "3"], R: Float[Array, "3 3"], static: StaticSolution,
    n_segments: int,
) -> Float[Array, "6 N-1 3"]:
    """The elastic catenary (eqs. 11–13 with ``s0`` replaced by ``s``) at the free nodes'
    material coordinates ``s = j s0/N``, ``j = 1 … N−1``, in G: the continuous cable the
    lumped statics converge to, and their Newton start."""
    frac = jnp.arange(1, n_segments) / n_segments
    rel = jax.vmap(lambda f: catenary_upper_end(params.cable, static.force, f * static.s0), out_axes=1)(frac)
    anchors = position + params.anchors @ R.T
    return anchors[:, None] + rel


def _unpack(y, n_segments):
    return y[:6], y[6:].reshape(6, n_segments - 1, 3)


def _blocks_at(params, position, R, s0, y, n_segments):
    q, X = _unpack(y, n_segments)
    m, com0 = assembly_centre_of_mass(params, position, R)
    return _blocks.potential_blocks(params, position, R, s0, q, X, m, R.T @ (com0 - position))


def _statics(params, position, R, static, n_segments, max_steps, tol_m):
    s0 = static.s0
    X0 = catenary_nodes(params, position, R, static, n_segments)
    y_ref = jnp.concatenate([jnp.zeros(6), X0.reshape(-1)])

    def energy(y):
        q, X = _unpack(y, n_segments)
        return lumped_potential(params, position, R, s0, q, X)

    grad = jax.grad(energy)
    val_grad = jax.value_and_grad(energy)

    alphas = 0.5 ** jnp.arange(16.0)

    def cond(c):
        _, i, step, lam = c
        return (i < max_steps) & (step > tol_m) & (lam < 1e6)

    # NOTE: Newton on ∇V = 0 with Marquardt's damping, (H + λ diag H) dy = −∇V, and a
    # backtracking (Armijo) line search on V itself. Near a slack segment a node has (almost)
    # no transverse stiffness and the plain Newton step is huge; a step that lowers V by no
    # fraction of its first-order prediction (up to the rounding of V, 1e-13 |V|) is refused
    # and λ grows a hundredfold (towards scaled steepest descent); an accepted full step
    # shrinks it tenfold, down to 1e-12, so the end is Newton's. λ ≥ 1e6 stops the iteration
    # as stalled: a status, not a NaN. The damping changes the path, never the solution (the
    # gradient is exact). H is assembled by blocks and the step solved chain by chain
    # (:mod:`._lumped_blocks`): O(N) per step, where a dense Hessian and solve cost O(N³).
    def body(c):
        y, i, _, lam = c
        v, g = val_grad(y)
        H = _blocks_at(params, position, R, s0, y, n_segments)
        d_c = jnp.abs(jnp.diag(H.cc))
        d_n = jnp.abs(jnp.diagonal(H.diag, axis1=-2, axis2=-1))
        floor = 1e-9 * jnp.maximum(jnp.max(d_c), jnp.max(d_n))
        d_c, d_n = jnp.maximum(d_c, floor), jnp.maximum(d_n, floor)
        damped = H._replace(cc=H.cc + lam * jnp.diag(d_c),
                            diag=H.diag + lam * d_n[..., None] * jnp.eye(3))
        g_c, g_n = _unpack(g, n_segments)
        dq, dX = _blocks.solve(_blocks.factor(damped), -g_c, -g_n)
        dy = jnp.concatenate([dq, dX.reshape(-1)])
        slope = jnp.dot(g, dy)
        trial = jax.vmap(lambda a: energy(y + a * dy))(alphas)
        good = jnp.isfinite(trial) & (trial <= v + 1e-4 * alphas * slope + 1e-13 * jnp.abs(v)) & (slope < 0)
        k = jnp.argmax(good)
        ok = jnp.any(good)
        alpha = jnp.where(ok, alphas[k], 0.0)
        # a Newton step at a minimum too small to lower V in floating point is converged
        tiny = (jnp.max(jnp.abs(dy)) <= tol_m) & (lam <= 1e-9)
        y_new = y + jnp.where(tiny, dy, alpha * dy)
        step = jnp.where(tiny, 0.0, jnp.where(ok, jnp.max(jnp.abs(alpha * dy)), jnp.inf))
        lam = jnp.where(ok & (k == 0), jnp.maximum(lam / 10.0, 1e-12), jnp.where(ok, lam, lam * 100.0))
        return y_new, i + 1, step, lam

    y, steps, last, lam = jax.lax.while_loop(
        cond, body, (y_ref, jnp.asarray(0), jnp.asarray(jnp.inf), jnp.asarray(1e-9)))
    stalled = lam >= 1e6
    g = grad(y)
    q, X = _unpack(y, n_segments)
    nodes = _nodes(params, position, R, q, X)
    vec, length, tension = _segments(params, s0, nodes)
    unit = vec / length[..., None]
    l0 = s0 / n_segments
    half_weight = (0.5 * params.cable.rho * l0)[:, None] * params.gravity
    anchor_force = tension[:, 0, None] * unit[:, 0] + half_weight
    top_force = tension[:, -1, None] * unit[:, -1] - half_weight
    p, Rq = _cabin_pose(position, R, q)
    slack = jnp.any(length <= l0[:, None], axis=1)
    converged = (last <= tol_m) & ~stalled & jnp.all(jnp.isfinite(y)) & ~jnp.any(slack)
    return LumpedStatics(
        p, Rq, q, nodes, tension, anchor_force, jnp.linalg.norm(anchor_force, axis=-1),
        jnp.linalg.norm(top_force, axis=-1), s0, jnp.max(jnp.abs(g)), steps, converged, slack,
    ), y


@partial(jax.jit, static_argnames=("n_segments", "max_steps"))
def _statics_jit(params, position, R, static, n_segments, max_steps=100, tol_m=1e-10):
    return _statics(params, position, R, static, n_segments, max_steps, tol_m)[0]


def _continuous_statics(params, position, R, static):
    check_position(position)
    pos = jnp.asarray(position, jnp.float64)
    R = jnp.eye(3, dtype=jnp.float64) if R is None else jnp.asarray(R, jnp.float64)
    st = static_equilibrium_jit(params, pos, R) if static is None else static
    return pos, R, st


def _raise_if_failed(st: LumpedStatics, position, static: StaticSolution) -> None:
    if not bool(static.converged):
        raise ValueError(f"no static equilibrium of the elastic catenaries at {np.asarray(position).tolist()} m: "
                         "the lumped cables' unstretched lengths come from it")
    slack = np.flatnonzero(np.asarray(st.slack))
    names = ", ".join(f"cable {i + 1}" for i in slack)
    where = np.asarray(position).tolist()
    if not bool(st.converged) and not (slack.size and float(st.residual_n) < 1e-3):
        raise ValueError(f"the lumped-mass statics found no equilibrium near {where} m (Newton stopped after "
                         f"{int(st.steps)} steps, largest force residual {float(st.residual_n):.3g} N)"
                         + (f"; slack segments at the last iterate in {names}" if slack.size else ""))
    if slack.size:
        raise ValueError(f"slack segment in {names} at the lumped-mass equilibrium near {where} m: "
                         "the cables cannot hold the cabin there")


def lumped_statics(
    params: FastParams,
    position: Float[ArrayLike, "3"],
    n_segments: int,
    R: Float[ArrayLike, "3 3"] | None = None,
    static: StaticSolution | None = None,
) -> LumpedStatics:
    """Static equilibrium of the cabin and the ``N = n_segments`` lumped segments per cable,
    with the unstretched lengths of the elastic-catenary statics at ``position`` (m) and
    attitude ``R`` (identity by default; ``static`` if already solved).

    Raises ``ValueError`` for ``N < 2``, for a pose without a catenary equilibrium, for a
    slack cable at the lumped equilibrium (naming the cables) and when Newton does not converge.
    """
    n = check_segments(n_segments)
    pos, R, st = _continuous_statics(params, position, R, static)
    out = _statics_jit(params, pos, R, st, n)
    _raise_if_failed(out, position, st)
    return out


def _mass_matrix(params, st: LumpedStatics, n_segments):
    l0 = st.s0 / n_segments
    r = (st.nodes[:, 0] - st.position)
    A = jnp.concatenate([jnp.broadcast_to(jnp.eye(3), (6, 3, 3)), -jax.vmap(_skew)(r)], axis=2)
    M_c = cabin_mass_matrix(params, st.R) + jnp.einsum("i,iak,ial->kl", 0.5 * params.cable.rho * l0, A, A)
    node_mass = jnp.repeat(params.cable.rho * l0, 3 * (n_segments - 1))
    n = 6 + node_mass.shape[0]
    return jnp.zeros((n, n)).at[:6, :6].set(M_c).at[6:, 6:].set(jnp.diag(node_mass))


def _modes(params, position, R, static, n_segments):
    st, y = _statics(params, position, R, static, n_segments, 100, 1e-10)

    # NOTE: the Hessian at the equilibrium in the coordinates about the *requested* pose; at an
    # equilibrium the second variation does not depend on where the rotation vector is
    # measured from (the gradient, which would couple the two, vanishes). Assembled from its
    # blocks (:mod:`._lumped_blocks`), equal to ``jax.hessian`` of the energy to rounding.
    K = _blocks.dense(_blocks_at(params, position, R, st.s0, y, n_segments))
    M = _mass_matrix(params, st, n_segments)
    freq, shapes, stable = modes_from_matrices(K, M)
    cab = shapes[:6]
    energy_share = jnp.einsum("km,kl,lm->m", cab, M[:6, :6], cab)
    lam = jnp.sign(freq) * (2.0 * jnp.pi * freq) ** 2
    contrib = (cab**2 / lam[None, :]).T
    compliance = jnp.sum(contrib, axis=0)
    ok = st.converged & jnp.all(jnp.isfinite(freq))
    return LumpedModes(freq, shapes, energy_share, contrib / compliance, compliance, K, M, st, stable, ok)


_modes_jit = jax.jit(_modes, static_argnames=("n_segments",))


def lumped_modes(
    params: FastParams,
    position: Float[ArrayLike, "3"],
    n_segments: int,
    R: Float[ArrayLike, "3 3"] | None = None,
    static: StaticSolution | None = None,
) -> LumpedModes:
    """Every vibration mode of the cabin on ``N = n_segments`` lumped-mass segments per cable,
    about the lumped statics at ``position`` (see :func:`lumped_statics`, whose errors it
    raises). Jitted per ``N``."""
    n = check_segments(n_segments)
    pos, R, st = _continuous_statics(params, position, R, static)
    out = _modes_jit(params, pos, R, st, n)
    _raise_if_failed(out.statics, position, st)
    return out


def lumped_stiffness_schur(modes: LumpedModes) -> Float[Array, "6 6"]:
    """The cabin's static stiffness with every cable node free to settle, ``K_cc − K_cn K_nn⁻¹
    K_nc`` (N/m, N, N·m/rad): the stiffness the quasi-static cables give
    (``cabin_modes(...).stiffness``, :func:`~stewart_jax.cable_robot.cabin_modes`) as ``N → ∞``."""
    K = modes.stiffness
    return K[:6, :6] - K[:6, 6:] @ jnp.linalg.solve(K[6:, 6:], K[6:, :6])
