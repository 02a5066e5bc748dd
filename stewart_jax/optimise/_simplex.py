"""Nelder–Mead simplex operations: on the worst nests of a population (SMCS, VSA-SMCS), and
a standalone bounded Nelder–Mead.

Nelder J. A., Mead R., "A simplex method for function minimization", Computer Journal 7
(1965) 308–313; coefficients and acceptance rules as in Lagarias J. C. et al., SIAM J.
Optim. 9 (1998) 112–147. The population version updates several worst vertices at once,
each against the centroid of the kept vertices, as in Lee D., Wiswall M., "A parallel
implementation of the simplex function minimization routine", Computational Economics 30
(2007) 171–187 — the form Wang et al. (2018) §2.1/§2.3 step (4) needs (37 nests = a simplex in 36
dimensions; its 12 worst vertices are improved by reflection, expansion, contraction and
shrink).

The standalone :class:`NelderMead` is bounded by projection (see its docstring, which also
says why it does not wrap ``optimistix.NelderMead``).
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from ._driver import AbstractSolver, evaluate, nan_to_inf
from ._result import RESULTS


class SimplexCoefficients(eqx.Module):
    """Nelder–Mead coefficients; the standard values (Nelder & Mead 1965, Lagarias et al.
    1998), which Wang et al. (2018) do not restate.

    - ``reflection`` α = 1, ``expansion`` γ = 2, ``contraction`` ρ = 0.5, ``shrink`` σ = 0.5.
    """

    reflection: float = 1.0
    expansion: float = 2.0
    contraction: float = 0.5
    shrink: float = 0.5


STANDARD_COEFFICIENTS = SimplexCoefficients()
"""α = 1, γ = 2, ρ = 0.5, σ = 0.5."""


def simplex_on_worst(
    fn,
    nests: Float[Array, "n d"],
    fitness: Float[Array, " n"],
    n_worst: int,
    coefficients: SimplexCoefficients = STANDARD_COEFFICIENTS,
    lower: Float[Array, " d"] | None = None,
    upper: Float[Array, " d"] | None = None,
) -> tuple[Float[Array, "n d"], Float[Array, " n"]]:
    """One parallel Nelder–Mead iteration on the ``n_worst`` worst nests (3 calls per nest).

    The population is read as a simplex; the ``n_worst`` worst vertices are updated in
    parallel (vmapped), each against the centroid ``c`` of the kept vertices, with
    ``f_b`` the best and ``f_k`` the worst kept value (Lee & Wiswall 2007):

    - reflection ``x_r = c + α(c − x_w)``;
    - ``f_r < f_b``: expansion ``x_e = c + γ(x_r − c)``, keep the better of ``x_e``, ``x_r``;
    - ``f_b ≤ f_r < f_k``: keep ``x_r``;
    - ``f_k ≤ f_r < f_w``: outside contraction ``c + ρ(x_r − c)``, kept if not worse than ``x_r``;
    - ``f_r ≥ f_w``: inside contraction ``c + ρ(x_w − c)``, kept if better than ``x_w``;
    - otherwise shrink towards the best nest, ``x_b + σ(x_w − x_b)``.

    Without bounds the steps are unbounded (SMCS as Wang et al. (2018) §2.1 describes it). With
    ``lower``/``upper`` every trial point is clipped to Ω before it is evaluated (Wang et al. 2018,
    eq. 13, VSA-SMCS). Branch-free: every nest evaluates its reflection, one second point
    (expansion or a contraction) and its shrink point.
    """
    n = nests.shape[0]
    if not 0 < n_worst < n:
        raise ValueError(f"n_worst must lie in [1, {n - 1}] for {n} nests, got {n_worst}")
    a, g, r, s = (coefficients.reflection, coefficients.expansion, coefficients.contraction,
                  coefficients.shrink)
    order = jnp.argsort(fitness)
    keep, worst = order[: n - n_worst], order[n - n_worst:]
    centroid = jnp.mean(nests[keep], axis=0)
    x_best, f_best = nests[order[0]], fitness[order[0]]
    f_kept_worst = fitness[keep[-1]]
    bound = (lambda x: jnp.clip(x, lower, upper)) if lower is not None else (lambda x: x)

    x_w, f_w = nests[worst], fitness[worst]
    # reflections and shrink points do not depend on each other: one evaluation for both
    x_r = bound(centroid + a * (centroid - x_w))
    x_s = bound(x_best + s * (x_w - x_best))
    f_rs = evaluate(fn, jnp.concatenate([x_r, x_s]))
    f_r, f_s = f_rs[:n_worst], f_rs[n_worst:]
    expand = f_r < f_best
    outside = (f_r >= f_kept_worst) & (f_r < f_w)
    inside = f_r >= f_w
    x_2 = jnp.where(expand[:, None], centroid + g * (x_r - centroid),
                    jnp.where(outside[:, None], centroid + r * (x_r - centroid),
                              centroid + r * (x_w - centroid)))
    x_2 = bound(x_2)
    f_2 = evaluate(fn, x_2)
    accept_reflection = (~expand & ~outside & ~inside) | (expand & (f_2 >= f_r))
    accept_second = (expand & (f_2 < f_r)) | (outside & (f_2 <= f_r)) | (inside & (f_2 < f_w))
    x_new = jnp.where(accept_reflection[:, None], x_r, jnp.where(accept_second[:, None], x_2, x_s))
    f_new = jnp.where(accept_reflection, f_r, jnp.where(accept_second, f_2, f_s))
    return nests.at[worst].set(x_new), fitness.at[worst].set(f_new)


class NelderMeadState(eqx.Module):
    """State of :class:`NelderMead`.

    - ``simplex``: ``Float[Array, "d+1 d"]``, vertices in the unbounded space ``y``.
    - ``values``: ``Float[Array, "d+1"]``, the projected-penalised objective ``g`` there.
    - ``best_x``: the best vertex projected onto Ω; ``best_f``: ``g`` there (``f`` after the
      final step). ``n_evals``: objective calls. ``converged``: the simplex test passed.
    - ``step``: ``Float[Array, "d"]``, the initial simplex's edge along each axis (the unit of
      ``xtol``).
    """

    simplex: Float[Array, "k d"]
    values: Float[Array, " k"]
    best_x: Float[Array, " d"]
    best_f: Float[Array, ""]
    n_evals: Array
    converged: Array
    step: Float[Array, " d"]


class NelderMead(AbstractSolver):
    """Bounded Nelder–Mead on the projected objective
    ``g(y) = f(clip(y)) + λ·(1 + |f(clip(y))|)·Σ((y − clip(y)) / (upper − lower))²``.

    Every evaluated point ``clip(y)`` lies in Ω; the simplex itself lives in the unbounded
    space, so it cannot collapse onto a face of the box, and the penalty (zero inside Ω)
    pulls it back, so ``argmin g = argmin_Ω f`` exactly. One step is one Nelder–Mead
    iteration with Lagarias et al.'s acceptance rules (those of ``scipy.optimize``).

    NOTE: ``optimistix.NelderMead`` (0.1.0) was the intended base, but its ``y0_simplex``
    option rejects any simplex in more than one dimension, and on the 36-parameter problem
    of Wang et al. (2018) it collapses to a degenerate simplex at S ≈ 0.04 mm² after ~2 800
    evaluations, where scipy's Nelder–Mead and this one keep descending. So this is a
    small own implementation; what it adds over optimistix's is bounds, a box-scaled initial
    simplex, dimension-adaptive coefficients and an exact evaluation count.

    - ``coefficients``: ``None`` (default) means the dimension-adaptive values of Gao F.,
      Han L., Comput. Optim. Appl. 51 (2012) 259–277 — α = 1, γ = 1 + 2/d,
      ρ = 0.75 − 1/(2d), σ = 1 − 1/d, the standard values in 2 dimensions, and far less
      prone to stagnate in 36; or a :class:`SimplexCoefficients`.
    - ``xtol``, ``ftol``: converged when every vertex lies within ``xtol`` (in units of the
      initial step) of the best and every value within ``ftol·(1 + |f_best|)`` of the best:
      1e-10 and 1e-14.
    - ``initial_scale``: the initial simplex is ``x0`` plus ``initial_scale·(upper − lower)``
      along each axis (towards the farther bound); 0.1 — a tenth of the box.
    - ``penalty`` λ = 1: any positive value makes the box minimiser exact; 1 charges a vertex
      a full box width outside twice the objective's own scale.
    - ``target``: stop once the best value is at or below it (status ``target_reached``); ``None``
      (default): stop on the simplex test (status ``successful``) or the budget.

    The start point is :func:`~stewart_jax.optimise.minimise`'s ``y0`` (default: the centre of
    the box; ``calibrate`` passes the nominal parameters).

    Evaluations: ``d + 1`` at init; per step two (the reflection and one of expansion or
    contraction, the latter computed even when the reflection is accepted), plus ``d`` on a
    shrink; one at the end (``f`` at the projected best vertex).
    """

    coefficients: SimplexCoefficients | None = None
    xtol: float = 1e-10
    ftol: float = 1e-14
    initial_scale: float = 0.1
    penalty: float = 1.0
    target: float | None = None

    def __check_init__(self):
        self.check_field("xtol", self.xtol >= 0, ">= 0")
        self.check_field("ftol", self.ftol >= 0, ">= 0")
        self.check_field("initial_scale", self.initial_scale > 0, "> 0")
        self.check_field("penalty", self.penalty > 0, "> 0")

    def _coefficients(self, d: int) -> SimplexCoefficients:
        if self.coefficients is not None:
            return self.coefficients
        return SimplexCoefficients(1.0, 1.0 + 2.0 / d, 0.75 - 0.5 / d, 1.0 - 1.0 / d)

    def _step_size(self, y0, lower, upper):
        x0 = 0.5 * (lower + upper) if y0 is None else jnp.asarray(y0, jnp.float64)
        step = self.initial_scale * (upper - lower)
        return x0, jnp.where(upper - x0 >= x0 - lower, step, -step)

    def _objective(self, fn, lower, upper):
        fn = nan_to_inf(fn)
        width = upper - lower

        def g(y):
            x = jnp.clip(y, lower, upper)
            f = fn(x)
            return f + self.penalty * (1.0 + jnp.abs(f)) * jnp.sum(((y - x) / width) ** 2)

        return g

    def _state(self, simplex, values, n_evals, lower, upper, step):
        order = jnp.argsort(values)
        simplex, values = simplex[order], values[order]
        dx = jnp.max(jnp.abs((simplex[1:] - simplex[0]) / step))
        df = jnp.max(jnp.abs(values[1:] - values[0]))
        converged = (dx <= self.xtol) & (df <= self.ftol * (1.0 + jnp.abs(values[0])))
        return NelderMeadState(simplex, values, jnp.clip(simplex[0], lower, upper), values[0],
                               jnp.asarray(n_evals, jnp.int32), converged, step)

    def init(self, fn, y0, lower, upper, key):
        del key  # deterministic
        x0, step = self._step_size(y0, lower, upper)
        simplex = jnp.concatenate([x0[None], x0[None] + jnp.diag(step)], axis=0)
        values = jax.vmap(self._objective(fn, lower, upper))(simplex)
        return self._state(simplex, values, simplex.shape[0], lower, upper, step)

    def step(self, fn, state, lower, upper, key):
        del key
        g = self._objective(fn, lower, upper)
        d = lower.shape[-1]
        a, gam, rho, sig = (lambda c: (c.reflection, c.expansion, c.contraction, c.shrink))(
            self._coefficients(d))
        x, f = state.simplex, state.values  # sorted, best first
        c = jnp.mean(x[:-1], axis=0)
        x_w, f_w, f_b, f_sw = x[-1], f[-1], f[0], f[-2]
        x_r = c + a * (c - x_w)
        f_r = g(x_r)
        expand = f_r < f_b
        outside = (f_r >= f_sw) & (f_r < f_w)
        inside = f_r >= f_w
        x_2 = jnp.where(expand, c + gam * (x_r - c),
                        jnp.where(outside, c + rho * (x_r - c), c - rho * (c - x_w)))
        f_2 = g(x_2)
        take_2 = (expand & (f_2 < f_r)) | (outside & (f_2 <= f_r)) | (inside & (f_2 < f_w))
        take_r = ~take_2 & (f_r < f_sw)
        shrink = ~take_2 & ~take_r
        x_new = jnp.where(take_2, x_2, x_r)
        f_new = jnp.where(take_2, f_2, f_r)

        def do_shrink(_):
            xs = x[0] + sig * (x[1:] - x[0])
            return (jnp.concatenate([x[:1], xs]),
                    jnp.concatenate([f[:1], jax.vmap(g)(xs)]))

        def replace_worst(_):
            return x.at[-1].set(x_new), f.at[-1].set(f_new)

        x, f = jax.lax.cond(shrink, do_shrink, replace_worst, None)
        return self._state(x, f, state.n_evals + 2 + jnp.where(shrink, d, 0), lower, upper, state.step)

    def terminate(self, state):
        reached = self.target_reached(state)
        return reached | state.converged, RESULTS.where(reached, RESULTS.target_reached, RESULTS.successful)

    def postprocess(self, fn, state, lower, upper):
        # best_f is g, which exceeds f where the best vertex lies outside Ω; report f at the
        # projected best vertex (one more call).
        f = nan_to_inf(fn)(state.best_x)
        return eqx.tree_at(lambda s: (s.best_f, s.n_evals), state, (f, state.n_evals + 1))

    def init_evaluations(self, n_dim):
        return n_dim + 1

    def final_evaluations(self, n_dim):
        return 1

    def step_evaluations(self, n_dim):
        return 2, n_dim + 2
