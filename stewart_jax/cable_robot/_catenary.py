"""Elastic catenary cable of the FAST feed support (Yin et al., §2, eqs. 6–13).

Each cable hangs from its tower top (upper end) and holds a cabin anchor (lower end). In the
cable's frame A (origin at the lower end, axes parallel to the global frame G) the
unknowns are the force ``F = (Fx, Fy, Fz)`` that the cabin exerts on the cable at its lower
end and the unstretched length ``s0``. Equilibrium of the piece of cable between the lower
end and the material point ``s`` (eqs. 6–9) and Hooke's law (eq. 10) give the tangent

    dr/ds = -(F + ρ g s e_z) / K(s) · (1 + K(s)/EA),   K(s) = |F + ρ g s e_z|,

whose integral over ``s ∈ [0, s0]`` is the closed form of eqs. 11–13. ``g = -9.8 m/s²`` as
Table 1 writes it (the weight of a length ``s`` of cable is ``ρ g s e_z``, downwards). The
force the cable exerts on the cabin is ``-F``.

- :func:`catenary_upper_end` — eqs. 11–13: ``(F, s0) ↦`` upper end relative to the lower end.
- :func:`solve_catenary` — the inverse: both ends and ``s0`` given, ``F`` by a batched Newton
  solve from the Peyrot–Goulois start (or a warm start), differentiated implicitly.
"""

from __future__ import annotations

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Int


class CableParams(eqx.Module):
    """Material of one cable (Yin et al., Table 1); SI units. A pytree of scalars.

    - ``EA``: axial stiffness ``E·A`` (N), 1.243e8.
    - ``rho``: unstretched linear density (kg/m), 13.898.
    - ``g``: signed gravitational acceleration along ``+z`` (m/s²), ``-9.8`` as in Table 1.
    """

    EA: Float[Array, ""] = eqx.field(converter=lambda x: jnp.asarray(x, jnp.float64), default=1.243e8)
    rho: Float[Array, ""] = eqx.field(converter=lambda x: jnp.asarray(x, jnp.float64), default=13.898)
    g: Float[Array, ""] = eqx.field(converter=lambda x: jnp.asarray(x, jnp.float64), default=-9.8)

    def __check_init__(self):
        from ._inputs import check_cable_material

        check_cable_material(self.EA, self.rho, self.g)


class CatenarySolution(NamedTuple):
    """Result of :func:`solve_catenary`; leading axes are the batch of cables.

    - ``force``: ``Float[Array, "... 3"]``, lower-end force ``F`` on the cable (N, frame G).
    - ``converged``: ``Bool[Array, "..."]``, Newton met the tolerance for this cable.
    - ``steps``: ``Int[Array, ""]``, Newton iterations taken by the batch.
    - ``residual``: ``Float[Array, "..."]``, ``|upper_end(F, s0) - delta|`` at the end (m).
    """

    force: Float[Array, "... 3"]
    converged: Bool[Array, "..."]
    steps: Int[Array, ""]
    residual: Float[Array, "..."]


def _asinh_difference(a: Array, b: Array, h: Array) -> Array:
    # arcsinh(a/h) - arcsinh(b/h); the library arcsinh is accurate for negative arguments,
    # where the textbook log(x + sqrt(x² + 1)) cancels catastrophically (here Fz < 0).
    return jnp.arcsinh(a / h) - jnp.arcsinh(b / h)


def catenary_upper_end(
    cable: CableParams, force: Float[Array, "... 3"], s0: Float[Array, "..."]
) -> Float[Array, "... 3"]:
    """Position of the upper end relative to the lower end, eqs. 11–13.

    **Arguments:**

    - ``cable``: :class:`CableParams`.
    - ``force``: ``Float[Array, "... 3"]``, lower-end force ``F`` on the cable (N).
    - ``s0``: ``Float[Array, "..."]``, unstretched length (m), broadcast against ``force[..., 0]``.

    **Returns:** ``Float[Array, "... 3"]``, ``(AX, AY, AZ)`` in metres.
    """
    fx, fy, fz = force[..., 0], force[..., 1], force[..., 2]
    s0 = jnp.asarray(s0, force.dtype)
    EA, rho_g = cable.EA, cable.rho * cable.g
    top = fz + rho_g * s0
    h2 = fx**2 + fy**2
    # NOTE: H = sqrt(Fx² + Fy²) → 0 (a vertical cable) makes arcsinh(·/H) → ±∞ while the
    # factor Fx/(ρg) → 0; the product tends to 0 like H·log(1/H). Where H is below 1e-300 N
    # the term is replaced by its limit 0, and the division uses a safe H so that neither
    # branch produces NaN under differentiation (the double-`where` pattern).
    vertical = h2 < 1e-300
    h = jnp.sqrt(jnp.where(vertical, 1.0, h2))
    d_asinh = jnp.where(vertical, 0.0, _asinh_difference(top, fz, h))
    x = -fx / EA * s0 - fx / rho_g * d_asinh  # eq. 11
    y = -fy / EA * s0 - fy / rho_g * d_asinh  # eq. 12
    k_top = jnp.sqrt(h2 + top**2)
    k_bottom = jnp.sqrt(h2 + fz**2)
    z = -fz / EA * s0 - rho_g / (2.0 * EA) * s0**2 - (k_top - k_bottom) / rho_g  # eq. 13
    return jnp.stack([x, y, z], axis=-1)


def _end_and_jacobian(cable: CableParams, fx, fy, fz, s0):
    # Eqs. 11–13 and their derivatives in closed form, one component array per quantity.
    # With w = ρg, T = Fz + w s0 (force at the upper end), H² = Fx² + Fy², k_T = |(Fx, Fy, T)|,
    # k_B = |F| and d = arcsinh(T/H) − arcsinh(Fz/H):
    #   ∂d/∂Fz = 1/k_T − 1/k_B,  ∂d/∂Fx = Fx q,  ∂d/∂Fy = Fy q,  q = (Fz/k_B − T/k_T)/H²;
    # the Jacobian is symmetric (∂x/∂Fz = ∂z/∂Fx = −Fx (1/k_T − 1/k_B)/w, and so on).
    #
    # NOTE (speed): XLA:CPU gives every square root, division or logarithm with more than
    # one user a kernel of its own, and on six cables the launch costs far more than the
    # arithmetic. So the step has three such operations, each on a stacked array: one rsqrt
    # gives k_T, k_B, H and their reciprocals; one log gives d through
    # arcsinh(a/H) = sign(a) log((|a| + √(a² + H²))/H), which sums positive terms only (as
    # accurate as the library arcsinh, and no cancellation for a < 0); the caller's solve has
    # the third.
    # NOTE (vertical cable, H → 0): the log(H) terms cancel when T and Fz share a sign (a
    # hanging cable), H d → 0 and q → sign(Fz) (1/T² − 1/Fz²)/2; below H² = 1e-300 N² the
    # limit of q is used and H is replaced by 1 where it would give log(0) or 0/0.
    EA, w = cable.EA, cable.rho * cable.g
    top = fz + w * s0
    h2 = fx * fx + fy * fy
    vertical = h2 < 1e-300
    h2_safe = jnp.where(vertical, 1.0, h2)
    sq = jnp.stack([h2 + top * top, h2 + fz * fz, h2_safe])
    inv = jax.lax.rsqrt(sq)
    k_top, k_bot = sq[0] * inv[0], sq[1] * inv[1]
    inv_top, inv_bot, inv_h = inv[0], inv[1], inv[2]
    s_top, s_bot = jnp.sign(top), jnp.sign(fz)
    logs = jnp.log(jnp.stack([jnp.abs(top) + k_top, jnp.abs(fz) + k_bot, sq[2]]))
    d = s_top * logs[0] - s_bot * logs[1] + 0.5 * (s_bot - s_top) * logs[2]
    q = jnp.where(vertical, 0.5 * s_bot * (inv_top * inv_top - inv_bot * inv_bot),
                  (fz * inv_bot - top * inv_top) * inv_h * inv_h)
    inv_w = 1.0 / w
    x = -fx / EA * s0 - fx * inv_w * d  # eq. 11
    y = -fy / EA * s0 - fy * inv_w * d  # eq. 12
    z = -fz / EA * s0 - w / (2.0 * EA) * s0**2 - (k_top - k_bot) * inv_w  # eq. 13
    dd_z = inv_top - inv_bot
    diag = -s0 / EA - d * inv_w
    jxx = diag - fx * fx * q * inv_w
    jyy = diag - fy * fy * q * inv_w
    jxy = -fx * fy * q * inv_w
    jxz = -fx * dd_z * inv_w
    jyz = -fy * dd_z * inv_w
    jzz = -s0 / EA - (top * inv_top - fz * inv_bot) * inv_w
    return (x, y, z), (jxx, jxy, jxz, jyy, jyz, jzz)


def catenary_jacobian(
    cable: CableParams, force: Float[Array, "... 3"], s0: Float[Array, "..."]
) -> tuple[Float[Array, "... 3"], Float[Array, "... 3 3"]]:
    """Upper end (eqs. 11–13) and its Jacobian ``∂(AX, AY, AZ)/∂F`` per cable, in closed form
    (symmetric; see the comments in the source).

    **Returns:** ``(end, J)`` with ``end``: ``Float[Array, "... 3"]`` and ``J``:
    ``Float[Array, "... 3 3"]`` (``J[..., i, k] = ∂end_i/∂F_k``).
    """
    s0 = jnp.asarray(s0, force.dtype)
    end, (xx, xy, xz, yy, yz, zz) = _end_and_jacobian(
        cable, force[..., 0], force[..., 1], force[..., 2], s0
    )
    J = jnp.stack(
        [jnp.stack([xx, xy, xz], -1), jnp.stack([xy, yy, yz], -1), jnp.stack([xz, yz, zz], -1)],
        -2,
    )
    return jnp.stack(end, -1), J


def _newton_step(cable, F, delta, s0):
    # One Newton step for every cable. ``F``: ``Float[Array, "3 n"]`` (force components first).
    # Returns ``Float[Array, "4 n"]``: F − J⁻¹ misfit (3×3 symmetric solve by the adjugate)
    # and, last, the squared end-point misfit at F; one array, so that XLA writes it in one
    # kernel.
    (x, y, z), (a, b, c, e, f, i) = _end_and_jacobian(cable, F[0], F[1], F[2], s0)
    rx, ry, rz = x - delta[0], y - delta[1], z - delta[2]
    A, B, C = e * i - f * f, c * f - b * i, b * f - c * e
    D, E, H = a * i - c * c, b * c - a * f, a * e - b * b
    inv_det = 1.0 / (a * A + b * B + c * C)
    return jnp.stack([
        F[0] - (A * rx + B * ry + C * rz) * inv_det,
        F[1] - (B * rx + D * ry + E * rz) * inv_det,
        F[2] - (C * rx + E * ry + H * rz) * inv_det,
        rx * rx + ry * ry + rz * rz,
    ])


def _solve3(J: Float[Array, "... 3 3"], r: Float[Array, "... 3"]) -> Float[Array, "... 3"]:
    """``J⁻¹ r`` for a batch of 3×3 systems by the adjugate (elementwise, fusable)."""
    a, b, c = J[..., 0, 0], J[..., 0, 1], J[..., 0, 2]
    d, e, f = J[..., 1, 0], J[..., 1, 1], J[..., 1, 2]
    g, h, i = J[..., 2, 0], J[..., 2, 1], J[..., 2, 2]
    A, B, C = e * i - f * h, -(d * i - f * g), d * h - e * g
    det = a * A + b * B + c * C
    adj = jnp.stack(
        [
            jnp.stack([A, -(b * i - c * h), b * f - c * e], -1),
            jnp.stack([B, a * i - c * g, -(a * f - c * d)], -1),
            jnp.stack([C, -(a * h - b * g), a * e - b * d], -1),
        ],
        -2,
    )
    return jnp.sum(adj * r[..., None, :], axis=-1) / det[..., None]


def peyrot_goulois_start(
    cable: CableParams, delta: Float[Array, "... 3"], s0: Float[Array, "..."]
) -> Float[Array, "... 3"]:
    """Initial guess of the lower-end force from Peyrot & Goulois (1979), as in mooring codes
    (e.g. MAP++, MoorPy).

    With horizontal span ``l``, rise ``z`` and weight per length ``w = ρ|g|``: ``λ0 =
    sqrt(3((s0² - z²)/l² - 1))`` (0.2 when the cable is taut, ``s0² ≤ l² + z²``; 1e6 for a
    vertical span), upper-end horizontal force ``w·l/(2λ0)``, upper-end vertical force
    ``w/2·(z·coth λ0 + s0)``. Converted to the force at the lower end:
    ``F_h = -H·(horizontal chord direction)``, ``Fz = w·s0 - V_top``.
    """
    w = cable.rho * jnp.abs(cable.g)
    l2 = delta[..., 0] ** 2 + delta[..., 1] ** 2
    span = jnp.sqrt(jnp.where(l2 > 0, l2, 1.0))
    z = delta[..., 2]
    taut = s0**2 <= l2 + z**2
    lam = jnp.where(
        l2 > 0,
        jnp.where(taut, 0.2, jnp.sqrt(3.0 * jnp.maximum((s0**2 - z**2) / span**2 - 1.0, 1e-12))),
        1e6,
    )
    h_top = jnp.maximum(jnp.abs(0.5 * w * jnp.where(l2 > 0, span, 0.0) / lam), 1e-6 * w * s0)
    v_top = 0.5 * w * (z / jnp.tanh(lam) + s0)
    u = jnp.where(l2[..., None] > 0, delta[..., :2] / span[..., None], 0.0)
    return jnp.concatenate([-h_top[..., None] * u, (w * s0 - v_top)[..., None]], axis=-1)


def straight_bar_start(
    cable: CableParams, delta: Float[Array, "... 3"], s0: Float[Array, "..."]
) -> Float[Array, "... 3"]:
    """Naive initial guess: a weightless elastic bar along the chord, ``T = EA(|δ|/s0 - 1)``
    (floored at 1 N). Kept for comparison: Newton from it diverges for slack cables."""
    chord = jnp.linalg.norm(delta, axis=-1)
    tension = jnp.maximum(cable.EA * (chord / s0 - 1.0), 1.0)
    return -tension[..., None] * delta / chord[..., None]


def _newton(cable, delta, s0, force0, tol, max_steps):
    # NOTE: the iteration runs on component arrays (cables along the last axis) and a cable's
    # misfit is measured at the start of each step, at the point whose Jacobian the step uses:
    # one closed-form evaluation per step (squared misfits, no square root in the loop).
    # A step stops moving a cable once it has converged, so a batch finishes together
    # without perturbing solutions that already meet the tolerance; the first step is taken
    # unconditionally (a warm start from the previous time step needs exactly one).
    delta_c = jnp.moveaxis(delta, -1, 0)
    bound2 = (tol * jnp.maximum(jnp.sqrt(jnp.sum(delta_c * delta_c, axis=0)), 1.0)) ** 2
    F1 = _newton_step(cable, jnp.moveaxis(force0, -1, 0), delta_c, s0)[:3]
    out1 = _newton_step(cable, F1, delta_c, s0)

    def cond(carry):
        _, out, step = carry
        return (step < max_steps) & jnp.any(~(out[3] <= bound2))

    def body(carry):
        F, out, step = carry
        F = jnp.where(out[3] <= bound2, F, out[:3])
        return F, _newton_step(cable, F, delta_c, s0), step + 1

    F, out, steps = jax.lax.while_loop(cond, body, (F1, out1, jnp.asarray(1)))
    return jnp.moveaxis(F, 0, -1), jnp.sqrt(out[3]), steps, out[3] <= bound2


def solve_catenary(
    cable: CableParams,
    delta: Float[Array, "... 3"],
    s0: Float[Array, "..."],
    force0: Float[Array, "... 3"] | None = None,
    *,
    tol: float = 1e-13,
    max_steps: int = 50,
) -> CatenarySolution:
    """Lower-end force ``F`` with ``catenary_upper_end(F, s0) = delta`` (inverse of eqs. 11–13).

    Newton's method on the three force components of every cable at once (3×3 Jacobians and
    their solves in closed form), stopping when every cable's end-point error is
    below ``tol·max(|delta|, 1 m)`` or after ``max_steps``.

    Derivatives (``jax.grad``/``jacfwd`` with respect to ``delta``, ``s0`` or ``cable``) use the
    implicit-function theorem via ``jax.lax.custom_root``: ``dF = -J⁻¹ ∂end/∂(δ, s0, ...)``;
    the Newton iterations are never unrolled.

    **Arguments:**

    - ``cable``: :class:`CableParams`.
    - ``delta``: ``Float[Array, "... 3"]``, upper end minus lower end (eq. 1), metres.
    - ``s0``: ``Float[Array, "..."]``, unstretched lengths (m).
    - ``force0``: ``Float[Array, "... 3"]`` or ``None``: warm start (e.g. the previous time
      step); ``None`` uses :func:`peyrot_goulois_start`.
    - ``tol``: relative end-point tolerance.
    - ``max_steps``: Newton iteration budget.

    **Returns:** :class:`CatenarySolution`; a cable that did not converge has
    ``converged = False`` (its ``force`` is the last iterate, not NaN-masked).
    """
    if not isinstance(delta, jax.core.Tracer) and not isinstance(s0, jax.core.Tracer):
        check_cable_inputs(delta, s0)
    delta = jnp.asarray(delta, jnp.float64)
    s0 = jnp.broadcast_to(jnp.asarray(s0, jnp.float64), delta.shape[:-1])
    if force0 is None:
        force0 = peyrot_goulois_start(cable, delta, s0)
    force0 = jnp.broadcast_to(jnp.asarray(force0, jnp.float64), delta.shape)

    def f(F):
        return catenary_upper_end(cable, F, s0) - delta

    def solve(_f, x0):
        F, res, steps, ok = _newton(cable, delta, s0, x0, tol, max_steps)
        # NOTE: custom_root's JVP rule mishandles integer/bool auxiliary outputs (it gives
        # them same-dtype tangents instead of float0), so they travel as floats.
        return F, (ok.astype(F.dtype), steps.astype(F.dtype), res)

    def tangent_solve(g, y):
        # g is the linearisation of f at the root: cable-wise (block diagonal), so its
        # 3×3 blocks are its images of the three broadcast unit vectors.
        eye = jnp.eye(3, dtype=y.dtype)
        J = jnp.stack([g(jnp.broadcast_to(e, y.shape)) for e in eye], axis=-1)
        return _solve3(J, y)

    F, (ok, steps, res) = jax.lax.custom_root(
        f, jax.lax.stop_gradient(force0), solve, tangent_solve, has_aux=True
    )
    aux = jax.lax.stop_gradient((ok, steps, res))
    return CatenarySolution(F, aux[0] > 0.5, aux[1].astype(jnp.int32), aux[2])


def check_cable_inputs(delta: ArrayLike, s0: ArrayLike) -> None:
    """Raise ``ValueError`` on wrong shapes or non-finite values (called before tracing)."""
    d = np.asarray(delta, dtype=np.float64)
    s = np.asarray(s0, dtype=np.float64)
    if d.ndim < 1 or d.shape[-1] != 3:
        raise ValueError(f"delta must have a last axis of 3, got shape {d.shape}")
    if not (np.all(np.isfinite(d)) and np.all(np.isfinite(s))):
        raise ValueError("delta and s0 must be finite")
    if np.any(s <= 0):
        raise ValueError("unstretched lengths s0 must be positive")
