"""The sparsity of the lumped-mass cables (:mod:`._lumped`): the Hessian of the potential energy
by blocks, and linear solves and products that use them.

The system is a star of six chains joined at the cabin. In the coordinates ``y = (q, X)`` of
:mod:`._lumped` (the cabin's six, then each cable's ``N − 1`` free nodes, cable-major) the
Hessian ``K = ∇²V`` is an *arrow of block-tridiagonal chains*:

- ``K_cc`` (6×6), the cabin: its weight and, per cable, the anchor segment and the anchor end
  node's weight;
- ``C_i`` (6×3), cabin – first free node of cable ``i`` (the anchor segment only);
- per cable, the 3×3 diagonal blocks ``D_ij`` of node ``j`` and the off-diagonal blocks
  ``E_ij`` between nodes ``j`` and ``j + 1`` (one segment each).

A segment of unstretched length ``l0`` and axial stiffness ``k = EA/l0`` between nodes ``a`` and
``b`` stores ``½ k (|d| − l0)²`` when taut (``d = b − a``, ``u = d/|d|``); its Hessian in ``d``
is the material plus the geometric stiffness

    h = k [ u uᵀ + (1 − l0/|d|) (I − u uᵀ) ] = k [ (1 − l0/|d|) I + (l0/|d|) u uᵀ ],

and 0 when slack; it enters ``+h`` on the diagonal blocks of both ends and ``−h`` between them.
The terms in the cabin's coordinates (the anchor moves with the cabin's rotation) come from
automatic differentiation of each cable's anchor segment, 9 coordinates at a time.

Solves with ``K − σ M`` (``M`` block diagonal: ``M_cc`` and ``m_i I₃`` per free node) eliminate
each chain from the tower end towards the cabin (block Gaussian elimination, ``O(N)`` per
cable), then the cabin's 6×6 Schur complement ``S(σ) = K_cc − σ M_cc − Σ_i C_i P_i1⁻¹ C_iᵀ``
(``P_i1`` the first node's pivot after the chain's elimination).

NOTE (pivoting): the chains are eliminated block by block without pivoting across blocks (each
3×3 pivot block is inverted by cofactors). For the static Newton matrix (positive
definite near a stable equilibrium, Marquardt-damped elsewhere) this is stable. For the shifted,
indefinite ``K − σ M`` of inverse iteration a pivot can be near singular; the solve is then
inaccurate but the results are checked (:func:`~stewart_jax.cable_robot.lumped_low_modes`
verifies every mode's residual and falls back on no silent error).
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ._modes import _exp


class ArrowBlocks(NamedTuple):
    """A symmetric matrix with the lumped cables' sparsity (6 cables, ``N − 1`` free nodes each).

    - ``cc``: ``Float[Array, "6 6"]``, the cabin's block.
    - ``cn``: ``Float[Array, "6 6 3"]``, per cable the 6×3 block cabin – first free node.
    - ``diag``: ``Float[Array, "6 N-1 3 3"]``, the nodes' diagonal blocks.
    - ``off``: ``Float[Array, "6 N-2 3 3"]``, block (node j, node j + 1) of each cable.
    """

    cc: Float[Array, "6 6"]
    cn: Float[Array, "6 6 3"]
    diag: Float[Array, "6 N-1 3 3"]
    off: Float[Array, "6 N-2 3 3"]


def segment_hessian(d: Float[Array, "... 3"], l0: Float[Array, "..."], EA) -> Float[Array, "... 3 3"]:
    """Hessian in ``d`` of one segment's strain energy ``½ (EA/l0) max(|d| − l0, 0)²``."""
    length = jnp.linalg.norm(d, axis=-1)
    u = d / length[..., None]
    k = EA / l0
    r = l0 / length
    uu = u[..., :, None] * u[..., None, :]
    h = k[..., None, None] * ((1.0 - r)[..., None, None] * jnp.eye(3) + r[..., None, None] * uu)
    return jnp.where((length > l0)[..., None, None], h, 0.0)


def potential_blocks(params, position, R, s0, q, X, m, com_C) -> ArrowBlocks:
    """``∇²V`` of :func:`~stewart_jax.cable_robot._lumped._potential` at ``(q, X)`` by blocks."""
    n = X.shape[1] + 1
    l0 = s0 / n
    EA = params.cable.EA
    g = params.gravity
    rho = params.cable.rho

    def cabin_weight(qq):
        Rq = _exp(qq[3:]) @ R
        return -m * jnp.dot(position + qq[:3] + Rq @ com_C, g)

    def anchor_energy(z, a_C, l0_i):
        qq, x1 = z[:6], z[6:]
        anchor = position + qq[:3] + (_exp(qq[3:]) @ R) @ a_C
        stretch = jnp.maximum(jnp.linalg.norm(x1 - anchor) - l0_i, 0.0)
        return 0.5 * EA / l0_i * stretch**2 - 0.5 * rho * l0_i * jnp.dot(anchor, g)

    z = jnp.concatenate([jnp.broadcast_to(q, (6, 6)), X[:, 0]], axis=1)
    H9 = jax.vmap(jax.hessian(anchor_energy))(z, params.anchors, l0)
    H9 = 0.5 * (H9 + jnp.swapaxes(H9, -1, -2))
    cc = jax.hessian(cabin_weight)(q) + jnp.sum(H9[:, :6, :6], axis=0)
    cc = 0.5 * (cc + cc.T)
    cn = H9[:, :6, 6:]
    # segments 1 … N−1: free node j to j+1, the last to the tower top
    ends = jnp.concatenate([X, params.towers[:, None]], axis=1)
    h = segment_hessian(jnp.diff(ends, axis=1), jnp.broadcast_to(l0[:, None], (6, n - 1)), EA)
    prev = jnp.concatenate([H9[:, None, 6:, 6:], h[:, :-1]], axis=1)
    return ArrowBlocks(cc, cn, h + prev, -h[:, :-1])


def dense(blocks: ArrowBlocks) -> Float[Array, "n n"]:
    """The full symmetric matrix, coordinates as :mod:`._lumped`'s ``y`` (cabin, then cable-major
    nodes)."""
    nc, nn = blocks.diag.shape[:2]
    n = 6 + 3 * nc * nn
    j = np.arange(nn)
    base = 6 + 3 * nn * np.arange(nc)[:, None] + 3 * j[None, :]          # (6, N-1)
    r3 = np.arange(3)
    K = jnp.zeros((n, n)).at[:6, :6].set(blocks.cc)
    rows = base[:, :, None, None] + r3[:, None]
    cols = base[:, :, None, None] + r3[None, :]
    K = K.at[rows, cols].set(blocks.diag)
    K = K.at[rows[:, :-1], cols[:, 1:]].set(blocks.off)
    K = K.at[cols[:, 1:], rows[:, :-1]].set(blocks.off)
    kk = np.arange(6)[None, :, None]
    cn_cols = base[:, 0][:, None, None] + r3[None, None, :]                 # (6 cables, 1, 3)
    K = K.at[kk, cn_cols].set(blocks.cn)
    K = K.at[cn_cols, kk].set(blocks.cn)
    return K


def matvec(blocks: ArrowBlocks, x_c: Float[Array, "6"], x_n: Float[Array, "6 N-1 3"]):
    """``K x`` for ``x = (x_c, x_n)``: ``(y_c (6,), y_n (6, N−1, 3))`` in ``O(N)``."""
    y_c = blocks.cc @ x_c + jnp.einsum("ikl,il->k", blocks.cn, x_n[:, 0])
    y_n = jnp.einsum("ijkl,ijl->ijk", blocks.diag, x_n)
    y_n = y_n.at[:, :-1].add(jnp.einsum("ijkl,ijl->ijk", blocks.off, x_n[:, 1:]))
    y_n = y_n.at[:, 1:].add(jnp.einsum("ijlk,ijl->ijk", blocks.off, x_n[:, :-1]))
    y_n = y_n.at[:, 0].add(jnp.einsum("ilk,l->ik", blocks.cn, x_c))
    return y_c, y_n


class ArrowFactor(NamedTuple):
    """Block elimination of an :class:`ArrowBlocks` matrix (:func:`factor`)."""

    pivot_inv: Float[Array, "6 N-1 3 3"]
    schur: Float[Array, "6 6"]
    blocks: ArrowBlocks


def shifted(blocks: ArrowBlocks, shift, mass_cc, node_mass) -> ArrowBlocks:
    """``K − σ M`` for ``M`` = ``mass_cc`` on the cabin, ``node_mass[i] I₃`` on cable i's nodes."""
    return blocks._replace(cc=blocks.cc - shift * mass_cc,
                           diag=blocks.diag - (shift * node_mass)[:, None, None, None] * jnp.eye(3))


def _inv3(A):
    # 3×3 inverses by cofactors (batched elementwise arithmetic, far cheaper than a batched LU
    # on the CPU): inv(A) = adj(A)/det(A), the rows of adj(A) the cross products of A's columns.
    a, b, c = A[..., :, 0], A[..., :, 1], A[..., :, 2]
    adj = jnp.stack([jnp.cross(b, c), jnp.cross(c, a), jnp.cross(a, b)], axis=-2)
    det = jnp.sum(a * adj[..., 0, :], axis=-1)
    X = adj / det[..., None, None]
    # one Newton–Schulz step, X ← X (2I − A X), squares the cofactors' rounding error
    return 2.0 * X - X @ A @ X


def factor(blocks: ArrowBlocks) -> ArrowFactor:
    """Eliminate every chain from the tower end towards the cabin; the cabin's Schur complement."""

    def step(P_next_inv, de):
        D, E = de                                     # D_j (6,3,3), E_j between j and j+1
        P = D - E @ P_next_inv @ jnp.swapaxes(E, -1, -2)
        P_inv = _inv3(P)
        return P_inv, P_inv

    last_inv = _inv3(blocks.diag[:, -1])
    D = jnp.moveaxis(blocks.diag[:, :-1], 1, 0)[::-1]
    E = jnp.moveaxis(blocks.off, 1, 0)[::-1]
    _, invs = jax.lax.scan(step, last_inv, (D, E))
    pivot_inv = jnp.concatenate([jnp.moveaxis(invs[::-1], 0, 1), last_inv[:, None]], axis=1)
    first = pivot_inv[:, 0]
    schur = blocks.cc - jnp.einsum("ikl,ilm,ipm->kp", blocks.cn, first, blocks.cn)
    return ArrowFactor(pivot_inv, schur, blocks)


def solve(f: ArrowFactor, r_c: Float[Array, "6"], r_n: Float[Array, "6 N-1 3"]):
    """``(K) x = r`` with the elimination ``f`` of :func:`factor`: ``(x_c, x_n)``."""
    b = f.blocks

    # forward: y_j = r_j − E_j P_{j+1}⁻¹ y_{j+1}, from the tower end
    def fwd(y_next, args):
        r, E, P_next_inv = args
        y = r - jnp.einsum("ikl,ilm,im->ik", E, P_next_inv, y_next)
        return y, y

    r_last = r_n[:, -1]
    _, ys = jax.lax.scan(fwd, r_last, (jnp.moveaxis(r_n[:, :-1], 1, 0)[::-1], jnp.moveaxis(b.off, 1, 0)[::-1],
                                       jnp.moveaxis(f.pivot_inv[:, 1:], 1, 0)[::-1]))
    y = jnp.concatenate([jnp.moveaxis(ys[::-1], 0, 1), r_last[:, None]], axis=1)
    rhs = r_c - jnp.einsum("ikl,ilm,im->k", b.cn, f.pivot_inv[:, 0], y[:, 0])
    x_c = jnp.linalg.solve(f.schur, rhs)
    x0 = jnp.einsum("ikl,il->ik", f.pivot_inv[:, 0], y[:, 0] - jnp.einsum("ilk,l->ik", b.cn, x_c))

    # back: x_{j+1} = P_{j+1}⁻¹ (y_{j+1} − E_jᵀ x_j)
    def back(x_prev, args):
        yj, E, P_inv = args
        x = jnp.einsum("ikl,il->ik", P_inv, yj - jnp.einsum("ilk,il->ik", E, x_prev))
        return x, x

    _, xs = jax.lax.scan(back, x0, (jnp.moveaxis(y[:, 1:], 1, 0), jnp.moveaxis(b.off, 1, 0),
                                    jnp.moveaxis(f.pivot_inv[:, 1:], 1, 0)))
    x_n = jnp.concatenate([x0[:, None], jnp.moveaxis(xs, 0, 1)], axis=1)
    return x_c, x_n


def band_order(n_cables: int, n_nodes: int) -> np.ndarray:
    """Where each coordinate of :mod:`._lumped`'s ``y`` (cabin, then cable-major nodes) goes in
    the banded ordering: cables 1–3 from the tower end towards the cabin, level by level (node
    ``N − 1`` of the three, then node ``N − 2``, …), the cabin, then cables 4–6 from the cabin
    outwards level by level. A level of three cables is 9 coordinates and the cabin couples to
    the first level on either side, so the half-bandwidth is 14 (ordering all six cables
    level by level after the cabin gives 23)."""
    half = n_cables // 2
    i, j, a = np.meshgrid(np.arange(n_cables), np.arange(n_nodes), np.arange(3), indexing="ij")
    w = 3 * half
    first = (n_nodes - 1 - j) * w + 3 * i + a
    second = w * n_nodes + 6 + j * 3 * (n_cables - half) + 3 * (i - half) + a
    nodes = np.where(i < half, first, second)
    return np.concatenate([w * n_nodes + np.arange(6), nodes.ravel()])


BANDWIDTH = 14
"""Half-bandwidth of :func:`band_standard_form` (six cables)."""


def band_standard_form(blocks: ArrowBlocks, mass_cc, node_mass):
    """Upper banded storage (LAPACK's ``AB``, for :func:`scipy.linalg.eigvals_banded`) of
    ``L⁻¹ K L⁻ᵀ`` with ``M = L Lᵀ`` (``L`` the Cholesky factor of ``M_cc`` on the cabin and
    ``√m_i I₃`` on the nodes): the standard symmetric eigenproblem with the eigenvalues ``ω²``
    of ``K φ = ω² M φ``, in the ordering of :func:`band_order` (half-bandwidth 14).

    Returns ``(ab (15, n), Lc)``, ``Lc`` the cabin's Cholesky factor."""
    nc, nn = blocks.diag.shape[:2]
    n = 6 + 3 * nc * nn
    bw = BANDWIDTH
    Lc = jnp.linalg.cholesky(mass_cc)
    Lci = jax.scipy.linalg.solve_triangular(Lc, jnp.eye(6), lower=True)
    s = 1.0 / jnp.sqrt(node_mass)                                           # (6,)
    acc = Lci @ blocks.cc @ Lci.T
    acn = jnp.einsum("kl,ilm->ikm", Lci, blocks.cn) * s[:, None, None]     # (6 cables, 6, 3)
    adiag = blocks.diag * (s**2)[:, None, None, None]
    aoff = blocks.off * (s**2)[:, None, None, None]
    pos = band_order(nc, nn)
    node = pos[6:].reshape(nc, nn, 3)
    rows = node[:, :, :, None] + 0 * node[:, :, None, :]                    # (6, N-1, 3, 3)
    cols = node[:, :, None, :] + 0 * node[:, :, :, None]
    cab = pos[:6]
    # diagonal blocks (both triangles listed: keep the upper one), then blocks listed once
    r_sym = np.concatenate([np.repeat(cab, 6), rows.ravel()])
    c_sym = np.concatenate([np.tile(cab, 6), cols.ravel()])
    v_sym = jnp.concatenate([acc.ravel(), adiag.ravel()])
    keep = r_sym <= c_sym
    r_one = np.concatenate([rows[:, :-1].ravel(), np.broadcast_to(cab[None, :, None], (nc, 6, 3)).ravel()])
    c_one = np.concatenate([cols[:, 1:].ravel(), np.broadcast_to(node[:, 0, None, :], (nc, 6, 3)).ravel()])
    v_one = jnp.concatenate([aoff.ravel(), acn.ravel()])
    r = np.concatenate([r_sym[keep], np.minimum(r_one, c_one)])
    c = np.concatenate([c_sym[keep], np.maximum(r_one, c_one)])
    v = jnp.concatenate([v_sym[keep], v_one])
    if int(np.max(c - r)) > bw:
        raise AssertionError("band ordering wider than its bandwidth")
    ab = jnp.zeros((bw + 1, n)).at[bw + r - c, c].set(v)
    return ab, Lc
