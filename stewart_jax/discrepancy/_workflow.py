"""Detect, name, add, show: the model-discrepancy workflow (``docs/discrepancy.md``), for any
:class:`~stewart_jax.discrepancy._registry.AbstractDiscrepancyModel`.

1. **Detect.** Fit the base model on a training part (weighted least squares with the model's
   whitener); test the held-out residuals against the noise alone (a χ² test that includes the
   uncertainty of the fitted parameters) at false-alarm level ``alpha``; report per factor and
   output how the held-out residuals depend on the factors ("where").
2. **Name.** Fit base + each candidate effect on the training part (optimistix
   Levenberg–Marquardt); per candidate: likelihood-ratio test against the base model with the
   effect's *identifiable* degrees of freedom, BIC, held-out χ², and how much of its signature
   the base parameters absorb. Name the best significant candidate; candidates that the data
   cannot reject against the named one (encompassing test) are ``indistinguishable_from``.
3. **Add.** The named effect's fit is the augmented model (:class:`FittedModel`), usable for
   control (:meth:`FittedModel.commanded`).
4. **Show.** Held-out residual RMS before/after against the noise floor, derived errors
   (6-PSS: pose errors) before/after, the "where" analysis after the fix.

Every fit is the same jitted function of a 0/1 mask over the effects (inactive parameters do
not enter the prediction), so the base model, single candidates and candidate pairs share one
compiled kernel, and many data sets are analysed at once with ``jax.vmap``
(:func:`diagnose_many`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import lineax as lx
import numpy as np
import optimistix as optx
from jax.scipy.special import betainc, gammaincc
from jaxtyping import Array, Float

from ._registry import AbstractDiscrepancyModel, Effect, effects_for

MIN_DOF = 6
"""Fewest residual degrees of freedom a fit must keep (data rows × outputs − parameters)."""
RANK_RTOL = 1e-9
"""Relative singular-value threshold for the numerical rank of whitened, column-normalised
Jacobians (float64 rounding of these is ~1e-13)."""
SINE_TOL = 1e-7
"""An effect direction whose principal-angle sine to the base span is below this counts as
absorbed (not identifiable): the rounding of the projection is ~cond(G)·1e-16 ≲ 1e-9 here."""
MAX_STEPS = 100
GN_STEPS = 4
GN_TOL = 1e-8
"""Relative χ² change of the last Gauss–Newton step below which a fit counts as converged."""
GN_RIDGE = 1e-12
"""Levenberg damping of the Gauss–Newton normal equations (columns normalised to 1): keeps the
step finite when a candidate pair is collinear given the base parameters."""


# ---------------------------------------------------------------------------- statistics


def chi2_sf(x: float, dof: float) -> float:
    """``P(χ²_dof > x)``."""
    if dof <= 0:
        return 1.0
    return float(gammaincc(dof / 2.0, max(float(x), 0.0) / 2.0))


def f_sf(x: float, d1: float, d2: float) -> float:
    """``P(F(d1, d2) > x)``."""
    if d1 <= 0 or d2 <= 0:
        return 1.0
    x = max(float(x), 0.0)
    return float(betainc(d2 / 2.0, d1 / 2.0, d2 / (d2 + d1 * x)))


def _nested_p(chi2_small: float, chi2_big: float, df: int, dof_big: int, known: bool) -> float:
    """p-value of "the bigger model explains nothing more": χ² test of the drop with ``df``
    degrees of freedom when σ is known, F test (σ² estimated from the bigger model) otherwise."""
    if df <= 0:
        return 1.0
    drop = max(chi2_small - chi2_big, 0.0)
    if known:
        return chi2_sf(drop, df)
    return f_sf((drop / df) / (chi2_big / dof_big), df, dof_big)


def _normalised(a: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(a, axis=0)
    return a / np.where(n > 0, n, 1.0)


def _rank(a: np.ndarray) -> int:
    if a.shape[1] == 0:
        return 0
    s = np.linalg.svd(_normalised(a), compute_uv=False)
    return int(np.sum(s > RANK_RTOL * s[0])) if s[0] > 0 else 0


def _basis(a: np.ndarray) -> np.ndarray:
    u, s, _ = np.linalg.svd(_normalised(a), full_matrices=False)
    return u[:, s > RANK_RTOL * s[0]] if s.size and s[0] > 0 else u[:, :0]


@dataclasses.dataclass(frozen=True)
class Absorption:
    """How much of an effect's signature the base parameters can absorb (whitened training
    Jacobian at the base fit).

    - ``absorbed_fraction``: ``1 − ‖(I − P_G) J_e‖²_F / ‖J_e‖²_F`` with ``J_e`` in the fit's
      scaled units: the expected share of the signature of an effect with random (isotropic)
      parameters that a refit of the base parameters removes.
    - ``sines``: sines of the principal angles between the effect's and the base columns'
      spans, largest first (1: orthogonal, 0: inside the base span).
    - ``identifiable_rank``: ``rank([G, E]) − rank(G)``, the effect directions the data can see.
    """

    absorbed_fraction: float
    sines: tuple[float, ...]
    identifiable_rank: int

    @property
    def completely_absorbed(self) -> bool:
        return self.identifiable_rank == 0


def absorption(
    base_columns: np.ndarray, effect_columns: np.ndarray, base_basis: np.ndarray | None = None
) -> Absorption:
    """:class:`Absorption` of ``effect_columns`` (n × k) by ``base_columns`` (n × p);
    ``base_basis``, an orthonormal basis of the base columns' span, may be passed to save work."""
    q = _basis(base_columns) if base_basis is None else base_basis
    perp = effect_columns - q @ (q.T @ effect_columns)
    total = float(np.sum(effect_columns**2))
    frac = 1.0 - float(np.sum(perp**2)) / total if total > 0 else 1.0
    sines = _sines(q, effect_columns)
    rank = int(np.sum(sines > SINE_TOL))
    return Absorption(float(np.clip(frac, 0.0, 1.0)), tuple(float(x) for x in sines), rank)


def _sines(q: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """Sines of the principal angles between span(columns) and span(q) (q orthonormal)."""
    ue = _basis(columns)
    if not ue.shape[1]:
        return np.zeros(0)
    return np.clip(np.linalg.svd(ue - q @ (q.T @ ue), compute_uv=False), 0.0, 1.0)


# ---------------------------------------------------------------------------- jitted kernels


def _unpack(model, effects, z, mask):
    nb = model.base_initial.shape[0]
    base = model.base_initial + model.base_scale * z[:nb]
    thetas, off = [], nb
    for i, e in enumerate(effects):
        thetas.append(z[off : off + e.n_params] * jnp.asarray(e.scale) * mask[i])
        off += e.n_params
    return base, thetas


def _raw_residual(z, model, effects, mask, data):
    base, thetas = _unpack(model, effects, z, mask)
    return model.observed(data) - model.predict(base, effects, thetas, data)


def _white_residual(z, args):
    model, effects, mask, data, w = args
    r = _raw_residual(z, model, effects, mask, data)
    return jnp.einsum("mij,mj->mi", w, r).reshape(-1)


def _keep(model, effects, mask):
    nb = model.base_initial.shape[0]
    return jnp.concatenate([jnp.ones(nb)] + [jnp.full(e.n_params, mask[i]) for i, e in enumerate(effects)])


def _fit_lm(model, effects, data):
    """Base fit from the model's starting parameters: optimistix Levenberg–Marquardt on the
    residuals whitened at the starting parameters (base parameters only).

    NOTE: the damped steps are solved through the normal equations (``lineax.Normal`` with
    Cholesky) rather than the default QR, ~20× faster on CPU at these sizes; the damping keeps
    them well posed."""
    none = jnp.zeros(len(effects))
    nb = model.base_initial.shape[0]
    n_eff = sum(e.n_params for e in effects)
    w0 = model.whitener(model.base_initial, data)
    residual = lambda zb, args: _white_residual(jnp.concatenate([zb, jnp.zeros(n_eff)]), args)
    sol = optx.least_squares(
        residual,
        optx.LevenbergMarquardt(rtol=1e-10, atol=1e-10, linear_solver=lx.Normal(lx.Cholesky())),
        jnp.zeros(nb),
        args=(model, effects, none, data, w0),
        max_steps=MAX_STEPS,
        throw=False,
    )
    return jnp.concatenate([sol.value, jnp.zeros(n_eff)]), sol.result == optx.RESULTS.successful


def _fit_gn(model, effects, mask, train, w_tr, test, z0):
    """Gauss–Newton refinement of base + the effects in ``mask`` from ``z0`` (the base fit).

    NOTE: started at the base optimum with the effect parameters at 0, every augmented problem
    is linear to within (effect size / lever arm) ~1e-4, so Gauss–Newton converges in two or
    three steps; a fixed number of steps in a ``lax.scan`` keeps the kernel cheap to compile
    and to batch over candidates, pairs and data sets (a batched trust-region solver compiles
    ~10× slower here). The last step's size is returned as the convergence check. Inactive
    parameters get an identity row and active ones a tiny ridge (on unit-normalised columns),
    so each step is a full-rank solve even when two effects are collinear. The normal equations
    (Cholesky, ~1 ms) replace QR (~50 ms on CPU for these sizes): they square the condition
    number (~1e5 → 1e10 here), which costs accuracy in the step, not in the fixed point — the
    next step corrects it.
    """
    keep = _keep(model, effects, mask)
    args = (model, effects, mask, train, w_tr)

    def step(carry, _):
        z, _ = carry
        r = _white_residual(z, args)
        jac = jax.jacfwd(_white_residual)(z, args) * keep
        norms = jnp.linalg.norm(jac, axis=0)
        d = jnp.where(norms > 0, norms, 1.0)
        a = jac / d
        normal = a.T @ a + jnp.diag(jnp.where(keep > 0, GN_RIDGE, 1.0))
        dz = -jax.scipy.linalg.cho_solve(jax.scipy.linalg.cho_factor(normal), a.T @ r) / d * keep
        return (z + dz, jnp.sum(r**2)), None

    (z, chi2_prev), _ = jax.lax.scan(step, (z0 * keep, jnp.inf), None, length=GN_STEPS)
    chi2 = jnp.sum(_white_residual(z, args) ** 2)
    converged = jnp.abs(chi2_prev - chi2) <= GN_TOL * jnp.maximum(chi2, 1.0)
    raw_te = _raw_residual(z, model, effects, mask, test)
    return z, chi2, converged, raw_te


def _prepare(model, effects, train, test, z_base):
    """Whiteners at the base fit and the whitened Jacobians (all effect columns at 0)."""
    none = jnp.zeros(len(effects))
    base_fit, _ = _unpack(model, effects, z_base, none)
    w_tr = model.whitener(base_fit, train)
    w_te = model.whitener(base_fit, test)
    every = jnp.ones(len(effects))
    jac_tr = jax.jacfwd(_white_residual)(z_base, (model, effects, every, train, w_tr))
    jac_te = jax.jacfwd(_white_residual)(z_base, (model, effects, every, test, w_te))
    return w_tr, w_te, jac_tr, jac_te


def _fit_masks(model, effects, masks, train, w_tr, test, z0):
    return jax.lax.map(lambda m: _fit_gn(model, effects, m, train, w_tr, test, z0), masks)


def _map_datasets(fn, in_axes):
    """``fn`` over a leading data-set axis with ``lax.map``.

    NOTE: not ``vmap``: batched QR on CPU is ~100× slower than LAPACK's unbatched one here, and
    every fit is a handful of small QR solves; ``lax.map`` keeps one compiled loop body."""

    def mapped(*args):
        fixed = [a if ax is None else None for a, ax in zip(args, in_axes, strict=True)]
        moving = [a if ax is not None else None for a, ax in zip(args, in_axes, strict=True)]

        def body(xs):
            full = [f if ax is None else x for f, x, ax in zip(fixed, xs, in_axes, strict=True)]
            return fn(*full)

        return jax.lax.map(body, moving)

    return mapped


_base_fit = eqx.filter_jit(_fit_lm)
_prepare_many = eqx.filter_jit(eqx.filter_vmap(_prepare, in_axes=(None, None, 0, 0, 0)))
_fit_masks_many = eqx.filter_jit(_map_datasets(_fit_masks, (None, None, 0, 0, 0, 0, 0)))


def _run_stage1(model, effects, train_list, trains, tests):
    k = len(effects)
    # NOTE: the base fits run one data set at a time: a vmapped trust-region solver costs
    # several times the compile time of the unbatched one, and each run takes ~0.1 s.
    fits = [_base_fit(model, effects, t) for t in train_list]
    z_base = jnp.stack([f[0] for f in fits])
    ok = jnp.stack([f[1] for f in fits])
    w_tr, w_te, jac_tr, jac_te = _prepare_many(model, effects, trains, tests, z_base)
    b = z_base.shape[0]
    masks = jnp.broadcast_to(jnp.concatenate([jnp.zeros((1, k)), jnp.eye(k)]), (b, k + 1, k))
    z, chi2, last, raw_te = _fit_masks_many(model, effects, masks, trains, w_tr, tests, z_base)
    return jax.device_get(
        dict(z=z, chi2=chi2, ok=ok[:, None] & last, raw_te=raw_te, w_te=w_te, w_tr=w_tr,
             jac_tr=jac_tr, jac_te=jac_te, base_ok=ok)
    )


# ---------------------------------------------------------------------------- results


class FittedModel(eqx.Module):
    """A calibrated model, possibly augmented by effects (the workflow's step 3).

    - ``model``: the :class:`AbstractDiscrepancyModel` (its base parameters are replaced by
      ``base`` here).
    - ``effects``: the effects added (static).
    - ``base``: ``Float[Array, "p"]``, fitted base parameters (library units).
    - ``thetas``: per effect ``Float[Array, "k_e"]``, fitted effect parameters (library units).
    """

    model: AbstractDiscrepancyModel
    effects: tuple[Effect, ...] = eqx.field(static=True)
    base: Float[Array, " p"]
    thetas: tuple[Float[Array, " _"], ...]

    def predict(self, data: Any) -> Float[Array, "m k"]:
        """Predicted observations for measured data (all effects)."""
        return self.model.predict(self.base, self.effects, self.thetas, data)

    def commanded(self, data: Any) -> Float[Array, "m k"]:
        """What to command to reach the rows of ``data`` (6-PSS: readings for target poses in
        ``data.poses``, with the approach directions / temperature / time the effects need).
        Measurement-side effects are dropped."""
        have = self.model.columns(data)
        for e in self.effects:
            missing = [c for c in e.requires if c not in have] if e.acts_on == "mechanism" else []
            if missing:
                raise ValueError(f"the model includes {e.name!r}, which needs {missing} to command a move")
        return self.model.predict(self.base, self.effects, self.thetas, data, control=True)

    def effect_report(self) -> list[dict[str, Any]]:
        """Per effect: name, parameters in report units, unit."""
        return [
            {
                "effect": e.name,
                "params": (np.asarray(t) * np.asarray(e.report_factor)).tolist(),
                "unit": e.unit,
                "acts_on": e.acts_on,
            }
            for e, t in zip(self.effects, self.thetas, strict=True)
        ]


@dataclasses.dataclass
class Candidate:
    """One candidate's scores (see :func:`diagnose` for the statistics)."""

    effect: str
    score: float
    bic: float
    delta_chi2: float
    dof: int
    p_value: float
    significant: bool
    heldout_chi2: float
    heldout_p: float
    heldout_rms: float
    absorbed_fraction: float
    identifiable_rank: int
    sines: tuple[float, ...]
    converged: bool
    params: list[float]
    unit: str

    def to_dict(self) -> dict[str, Any]:
        d = dataclasses.asdict(self)
        d["sines"] = list(self.sines)
        d["min_sine"] = min(self.sines) if self.sines else 0.0
        return d


@dataclasses.dataclass
class DiagnosisReport:
    """Result of :func:`diagnose`. ``to_dict()`` gives the JSON of ``stewart-jax diagnose``."""

    model: str
    detected: bool
    detect_statistic: float
    detect_dof: float
    detect_p_value: float
    named_effect: str
    indistinguishable_from: list[str]
    additional_effects: list[str]
    ranking: list[Candidate]
    absorbed: list[str]
    skipped: list[dict[str, str]]
    gap_before: float
    gap_after: float
    noise_floor: float
    noise_floor_predictive: float
    derived_before: dict[str, float]
    derived_after: dict[str, float]
    where_before: dict[str, Any]
    where_after: dict[str, Any]
    base_chi2: float
    base_dof: int
    noise_estimated: bool
    noise_scale: float
    alpha: float
    n_train: int
    n_test: int
    fitted: FittedModel
    base_fitted: FittedModel
    residuals_before: np.ndarray
    residuals_after: np.ndarray
    test_factors: dict[str, np.ndarray]
    notes: list[str] = dataclasses.field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        unit = self.fitted.model.report_unit
        return _jsonable(
            {
                "model": self.model,
                "detected": self.detected,
                "named_effect": self.named_effect,
                "indistinguishable_from": self.indistinguishable_from,
                "ranking": [c.to_dict() for c in self.ranking],
                "gap_before": self.gap_before,
                "gap_after": self.gap_after,
                "noise_floor": self.noise_floor,
                "noise_floor_predictive": self.noise_floor_predictive,
                "gap_unit": unit,
                "additional_effects": self.additional_effects,
                "absorbed": self.absorbed,
                "skipped": self.skipped,
                "detection": {
                    "test": "F (σ estimated)" if self.noise_estimated else "chi2 (σ given)",
                    "statistic": self.detect_statistic,
                    "dof": self.detect_dof,
                    "p_value": self.detect_p_value,
                    "alpha": self.alpha,
                },
                "base_fit": {"chi2": self.base_chi2, "dof": self.base_dof, "noise_scale": self.noise_scale},
                "derived_error_rms_before": self.derived_before,
                "derived_error_rms_after": self.derived_after,
                "where_before": self.where_before,
                "where_after": self.where_after,
                "augmented_model": {
                    "base_params": np.asarray(self.fitted.base).tolist(),
                    "effects": self.fitted.effect_report(),
                },
                "n_train": self.n_train,
                "n_test": self.n_test,
                "notes": self.notes,
            }
        )


def _jsonable(x):
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, float | np.floating):
        return float(x) if math.isfinite(x) else None
    if isinstance(x, np.integer | np.bool_):
        return x.item()
    return x


# ---------------------------------------------------------------------------- where


def where_analysis(
    residuals: np.ndarray, factors: dict[str, np.ndarray], output_names: Sequence[str], alpha: float, n_bins: int = 4
) -> dict[str, Any]:
    """How the residuals (``m k``, report units) depend on each factor (``m k`` each): per
    output, Pearson correlation, its two-sided p-value (t test, ``m − 2`` dof), the slope, and
    mean residuals in quantile bins (or per value for a two-valued factor). ``flags`` lists the
    (factor, output) pairs significant at ``alpha`` after Bonferroni over all pairs."""
    m, k = residuals.shape
    out: dict[str, Any] = {"outputs": list(output_names), "factors": {}}
    n_tests = max(len(factors) * k, 1)
    flags = []
    for name, x in factors.items():
        rows = {"correlation": [], "p_value": [], "slope": [], "bins": []}
        for j in range(k):
            xj, rj = np.asarray(x[:, j], dtype=float), residuals[:, j]
            sx, sr = np.std(xj), np.std(rj)
            if m < 3 or sx == 0 or sr == 0:
                r = p = slope = float("nan")
            else:
                r = float(np.corrcoef(xj, rj)[0, 1])
                r = float(np.clip(r, -1 + 1e-15, 1 - 1e-15))
                t2 = r * r * (m - 2) / (1 - r * r)
                p = f_sf(t2, 1, m - 2)
                slope = float(np.polyfit(xj, rj, 1)[0])
            values = np.unique(xj)
            if values.size <= 2:
                bins = [{"x": float(v), "mean": float(np.mean(rj[xj == v])), "n": int(np.sum(xj == v))} for v in values]
            else:
                edges = np.quantile(xj, np.linspace(0, 1, n_bins + 1))
                idx = np.clip(np.searchsorted(edges, xj, side="right") - 1, 0, n_bins - 1)
                bins = [
                    {"x": float(np.mean(xj[sel])), "mean": float(np.mean(rj[sel])), "n": int(np.sum(sel))}
                    for sel in (idx == b for b in range(n_bins))
                    if np.any(sel)
                ]
            rows["correlation"].append(r)
            rows["p_value"].append(p)
            rows["slope"].append(slope)
            rows["bins"].append(bins)
            if math.isfinite(p) and p < alpha / n_tests:
                flags.append({"factor": name, "output": output_names[j], "correlation": r, "p_value": p})
        out["factors"][name] = rows
    out["flags"] = sorted(flags, key=lambda f: f["p_value"])
    return out


# ---------------------------------------------------------------------------- driver


def split_rows(n: int, holdout_fraction: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A seeded random train/held-out split of ``n`` rows."""
    if not 0 < holdout_fraction < 1:
        raise ValueError(f"holdout_fraction must be in (0, 1), got {holdout_fraction}")
    perm = np.random.default_rng(seed).permutation(n)
    n_te = int(round(n * holdout_fraction))
    return np.sort(perm[n_te:]), np.sort(perm[:n_te])


def select_effects(
    model: AbstractDiscrepancyModel, data: Any, n_train: int, names: Sequence[str] | None = None
) -> tuple[tuple[Effect, ...], list[dict[str, str]]]:
    """The candidates that can be fitted to ``data`` (``n_train`` training rows), and the
    skipped ones with the reason (a missing column, too few rows for the parameters)."""
    registered = {e.name: e for e in effects_for(model.name)}
    if names is None:
        names = list(registered)
    unknown = [n for n in names if n not in registered]
    if unknown:
        raise ValueError(f"unknown effect(s) {unknown} for model {model.name!r}; known: {sorted(registered)}")
    have = model.columns(data)
    n_obs = n_train * len(model.output_names)
    nb = model.base_initial.shape[0]
    chosen, skipped = [], []
    for n in names:
        e = registered[n]
        missing = [c for c in e.requires if c not in have]
        if missing:
            skipped.append({"effect": n, "reason": f"needs column(s) {missing}, which the data lack"})
        elif n_obs - nb - e.n_params < MIN_DOF:
            skipped.append(
                {
                    "effect": n,
                    "reason": f"{n_train} training rows give {n_obs} observations, too few for "
                    f"{nb} + {e.n_params} parameters (need {nb + e.n_params + MIN_DOF})",
                }
            )
        else:
            chosen.append(e)
    return tuple(chosen), skipped


def check_sizes(model: AbstractDiscrepancyModel, n_rows: int, n_train: int, n_test: int) -> None:
    """Clear errors for data that cannot support the question."""
    k = len(model.output_names)
    nb = model.base_initial.shape[0]
    if n_train * k - nb < MIN_DOF:
        need = math.ceil((nb + MIN_DOF) / k)
        raise ValueError(
            f"{n_rows} rows split into {n_train} training rows ({n_train * k} observations) cannot "
            f"calibrate {nb} base parameters with ≥ {MIN_DOF} residual degrees of freedom: at least "
            f"{need} training rows are needed (lower holdout_fraction or measure more poses)"
        )
    if n_test < 2:
        raise ValueError(f"{n_rows} rows leave {n_test} held-out row(s); at least 2 are needed for the test")


def diagnose(
    data: Any,
    model: AbstractDiscrepancyModel,
    *,
    effects: Sequence[str] | None = None,
    holdout_fraction: float = 0.3,
    seed: int = 0,
    alpha: float = 0.05,
    estimate_noise: bool = False,
) -> DiagnosisReport:
    """Run the discrepancy workflow on one data set (see the module docstring).

    ``effects``: candidate names (default: every effect registered for the model; those whose
    column is missing are skipped and reported). ``alpha``: false-alarm level of the detection
    test; candidates are tested at ``alpha / K`` (Bonferroni over the ``K`` candidates).
    ``estimate_noise``: take the noise scale from the base fit's training residuals (F tests)
    instead of trusting the model's σ (χ² tests).
    """
    n = model.n_rows(data)
    train_idx, test_idx = split_rows(n, holdout_fraction, seed)
    check_sizes(model, n, len(train_idx), len(test_idx))
    chosen, skipped = select_effects(model, data, len(train_idx), effects)
    if not chosen:
        raise ValueError(f"no candidate effect can be fitted to these data: {skipped}")
    train, test = model.take(data, train_idx), model.take(data, test_idx)
    return diagnose_many(model, chosen, [train], [test], alpha=alpha, estimate_noise=estimate_noise, skipped=skipped)[0]


def _stack(items):
    return jax.tree_util.tree_map(lambda *xs: jnp.stack(xs), *items)


def diagnose_many(
    model: AbstractDiscrepancyModel,
    effects: Sequence[Effect],
    trains: Sequence[Any],
    tests: Sequence[Any],
    *,
    alpha: float = 0.05,
    estimate_noise: bool = False,
    skipped: list[dict[str, str]] | None = None,
) -> list[DiagnosisReport]:
    """:func:`diagnose` on many train/held-out pairs at once (same shapes and columns; all
    fits batched with ``jax.vmap``). ``effects`` must be applicable to every data set."""
    effects = tuple(effects)
    if not 0 < alpha < 1:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    for e in effects:
        if e.model != model.name:
            raise ValueError(f"effect {e.name!r} belongs to model {e.model!r}, not {model.name!r}")
    train_b, test_b = _stack(trains), _stack(tests)
    s1 = _run_stage1(model, effects, trains, train_b, test_b)
    nb = model.base_initial.shape[0]
    k = len(effects)
    slices, off = [], nb
    for e in effects:
        slices.append(np.arange(off, off + e.n_params))
        off += e.n_params
    known = not estimate_noise

    prelim = [_decide(b, s1, effects, slices, nb, alpha, known, model, trains[b], tests[b]) for b in range(len(trains))]
    # NOTE: the named candidate is compared with every other significant one by fitting both
    # together (encompassing tests). If the named one is rejected against the pair while the
    # other is not, the other explains everything the named one does and more: it is named
    # instead and compared again (at most once per candidate).
    visited = [{p["named_index"]} for p in prelim]
    pending = [b for b, p in enumerate(prelim) if p["named_index"] is not None and len(p["significant"]) > 1]
    while pending:
        masks = np.zeros((len(trains), k + 1, k))
        jobs = []
        for b in pending:
            a = prelim[b]["named_index"]
            others = [c for c in prelim[b]["significant"] if c != a]
            for j, c in enumerate(others):
                masks[b, j, [a, c]] = 1.0
                jobs.append((b, j, c))
        # Padded to the stage-1 shape (data sets × (K + 1) masks): the same compiled kernel.
        _, chi2_pairs, _, _ = jax.device_get(
            _fit_masks_many(model, effects, jnp.asarray(masks), train_b, s1["w_tr"], test_b, s1["z"][:, 0])
        )
        again = []
        for b in pending:
            pre = prelim[b]
            a = pre["named_index"]
            pre["pairs"] = {c: float(chi2_pairs[b, j]) for bb, j, c in jobs if bb == b}
            outcome = _pair_tests(pre, np.asarray(s1["jac_tr"][b]), slices, nb, known)
            dominating = [c for c, (p_c, p_a) in outcome.items() if p_c >= alpha and p_a < pre["level"]]
            dominating = [c for c in dominating if c not in visited[b]]
            if dominating:
                pre["named_index"] = max(dominating, key=lambda c: pre["cands"][c].score)
                visited[b].add(pre["named_index"])
                again.append(b)
            else:
                pre["outcome"] = outcome
        pending = again

    return [
        _finish(b, prelim[b], s1, effects, slices, nb, alpha, known, model, trains[b], tests[b], skipped or [])
        for b in range(len(trains))
    ]


def _prediction_factor(a_tr: np.ndarray, a_te: np.ndarray) -> np.ndarray:
    """``U = A_te V S⁻¹`` from the SVD ``A_tr = W S Vᵀ`` (columns normalised first so that the
    rank cut is scale-free): ``U Uᵀ = A_te (A_trᵀ A_tr)⁺ A_teᵀ``, the covariance of the held-out
    prediction error of a linear(ised) least-squares fit, in whitened units."""
    n = np.linalg.norm(a_tr, axis=0)
    keep = n > 0
    _, sv, vt = np.linalg.svd(a_tr[:, keep] / n[keep], full_matrices=False)
    ok = sv > RANK_RTOL * sv[0]
    return (a_te[:, keep] / n[keep]) @ (vt[ok].T / sv[ok])


def heldout_chi2(r: np.ndarray, a_tr: np.ndarray, a_te: np.ndarray) -> float:
    """``rᵀ (I + U Uᵀ)⁻¹ r`` with ``U Uᵀ = A_te (A_trᵀ A_tr)⁺ A_teᵀ`` (see
    :func:`_prediction_factor`), by Woodbury: ``rᵀr − (Uᵀr)ᵀ (I + UᵀU)⁻¹ (Uᵀr)``.

    NOTE: the held-out residual of a fit is the held-out noise minus the prediction error of
    the fitted parameters, ``r = ε_te − A_te (û − u)``, with ``Cov(û) = (A_trᵀ A_tr)⁻¹`` in
    whitened units and independent of ``ε_te``. Its covariance is therefore
    ``I + A_te C A_teᵀ``, and the statistic is exactly χ²(n_te) for a correct linear(ised) model.
    Ignoring the second term would raise the false-alarm rate: with 36 parameters fitted to a
    few hundred residuals it inflates the held-out χ² by several percent.
    """
    u = _prediction_factor(a_tr, a_te)
    ur = u.T @ r
    return float(r @ r - ur @ np.linalg.solve(np.eye(u.shape[1]) + u.T @ u, ur))


def _decide(b, s1, effects, slices, nb, alpha, known, model, train, test):
    k = len(effects)
    chi2 = np.asarray(s1["chi2"][b], dtype=float)
    jac_tr = np.asarray(s1["jac_tr"][b])
    jac_te = np.asarray(s1["jac_te"][b])
    n_tr, n_te = jac_tr.shape[0], jac_te.shape[0]
    g_cols = np.arange(nb)
    rank_g = _rank(jac_tr[:, g_cols])
    q_g = _basis(jac_tr[:, g_cols])
    dof0 = n_tr - rank_g
    w_te = np.asarray(s1["w_te"][b])
    raw_te = np.asarray(s1["raw_te"][b])
    white_te = np.einsum("mij,qmj->qmi", w_te, raw_te).reshape(k + 1, -1)
    scale2 = chi2[0] / dof0 if not known else 1.0

    t0 = heldout_chi2(white_te[0], jac_tr[:, g_cols], jac_te[:, g_cols])
    if known:
        p_detect = chi2_sf(t0, n_te)
    else:
        p_detect = f_sf((t0 / n_te) / scale2, n_te, dof0)

    cands = []
    for i, e in enumerate(effects):
        cols = np.concatenate([g_cols, slices[i]])
        ab = absorption(jac_tr[:, g_cols], jac_tr[:, slices[i]], q_g)
        df = ab.identifiable_rank
        dof_c = n_tr - rank_g - df
        p = _nested_p(chi2[0], chi2[i + 1], df, dof_c, known)
        if known:
            bic0 = chi2[0] + rank_g * math.log(n_tr)
            bic = chi2[i + 1] + (rank_g + df) * math.log(n_tr)
        else:
            bic0 = n_tr * math.log(chi2[0] / n_tr) + rank_g * math.log(n_tr)
            bic = n_tr * math.log(max(chi2[i + 1], 1e-300) / n_tr) + (rank_g + df) * math.log(n_tr)
        t = heldout_chi2(white_te[i + 1], jac_tr[:, cols], jac_te[:, cols])
        tp = chi2_sf(t, n_te) if known else f_sf((t / n_te) / scale2, n_te, dof0)
        theta = np.asarray(s1["z"][b, i + 1])[slices[i]] * np.asarray(e.scale) * np.asarray(e.report_factor)
        cands.append(
            Candidate(
                effect=e.name,
                score=float(bic0 - bic),
                bic=float(bic),
                delta_chi2=float(chi2[0] - chi2[i + 1]),
                dof=int(df),
                p_value=float(p),
                significant=False,
                heldout_chi2=float(t),
                heldout_p=float(tp),
                heldout_rms=float(np.sqrt(np.mean(raw_te[i + 1] ** 2)) * model.report_factor),
                absorbed_fraction=ab.absorbed_fraction,
                identifiable_rank=df,
                sines=ab.sines,
                converged=bool(s1["ok"][b, i + 1]),
                params=theta.tolist(),
                unit=e.unit,
            )
        )
    testable = [i for i, c in enumerate(cands) if c.identifiable_rank > 0]
    level = alpha / max(len(testable), 1)
    significant = []
    for i in testable:
        cands[i].significant = cands[i].p_value < level
        if cands[i].significant:
            significant.append(i)
    detected = p_detect < alpha
    named = max(significant, key=lambda i: cands[i].score) if (detected and significant) else None
    return dict(
        cands=cands,
        significant=significant,
        named_index=named,
        detected=detected,
        p_detect=p_detect,
        t0=t0,
        dof0=dof0,
        rank_g=rank_g,
        scale2=scale2,
        level=level,
        pairs={},
        chi2=chi2,
        n_te=n_te,
        n_tr=n_tr,
    )


def _pair_tests(pre, jac_tr, slices, nb, known):
    """For the named candidate ``a`` and each other ``c`` fitted together with it: p-values of
    "c explains all that a ∪ c does" and "a explains all that a ∪ c does" (the degrees of
    freedom are the directions of the one not spanned by the base and the other)."""
    a, chi2, n_tr = pre["named_index"], pre["chi2"], pre["n_tr"]
    g = jac_tr[:, :nb]
    q_ga = _basis(np.concatenate([g, jac_tr[:, slices[a]]], axis=1))
    out = {}
    for c, chi2_ac in pre["pairs"].items():
        q_gc = _basis(np.concatenate([g, jac_tr[:, slices[c]]], axis=1))
        df_c = int(np.sum(_sines(q_gc, jac_tr[:, slices[a]]) > SINE_TOL))
        df_a = int(np.sum(_sines(q_ga, jac_tr[:, slices[c]]) > SINE_TOL))
        dof_ac = n_tr - q_ga.shape[1] - df_a
        out[c] = (
            _nested_p(chi2[c + 1], chi2_ac, df_c, dof_ac, known),
            _nested_p(chi2[a + 1], chi2_ac, df_a, dof_ac, known),
        )
    return out


def _finish(b, pre, s1, effects, slices, nb, alpha, known, model, train, test, skipped):
    cands, chi2, rank_g = pre["cands"], pre["chi2"], pre["rank_g"]
    jac_tr = np.asarray(s1["jac_tr"][b])
    a = pre["named_index"]
    indist, additional = [], []
    for c, (p_c, p_a) in pre.get("outcome", {}).items():
        if p_c >= alpha:
            indist.append(effects[c].name)
        elif p_a < pre["level"]:
            additional.append(effects[c].name)

    z = np.asarray(s1["z"][b])
    none = np.zeros(len(effects))

    def fitted(i):
        mask = none.copy()
        effs = ()
        if i is not None:
            mask[i] = 1.0
            effs = (effects[i],)
        base, thetas = _unpack(model, effects, jnp.asarray(z[0 if i is None else i + 1]), jnp.asarray(mask))
        return FittedModel(model, effs, base, tuple(thetas[j] for j in range(len(effects)) if mask[j]))

    base_fm, aug_fm = fitted(None), fitted(a)
    raw_te = np.asarray(s1["raw_te"][b])
    rf = model.report_factor
    before = raw_te[0] * rf
    after = raw_te[0 if a is None else a + 1] * rf
    w_te = np.asarray(s1["w_te"][b])
    cov = np.einsum("mij,mkj->mik", *(2 * [np.linalg.inv(w_te)]))
    floor = float(np.sqrt(np.mean(np.diagonal(cov, axis1=1, axis2=2))) * rf * math.sqrt(pre["scale2"]))
    lw = np.linalg.inv(w_te)
    n_te_rows, kk = raw_te.shape[1], raw_te.shape[2]
    pred = _prediction_factor(jac_tr[:, :nb], np.asarray(s1["jac_te"][b])[:, :nb]).reshape(n_te_rows, kk, -1)
    pred_raw = np.einsum("mij,mjn->min", lw, pred)
    extra = np.sum(pred_raw**2) / (n_te_rows * kk)
    floor_pred = float(
        np.sqrt(np.mean(np.diagonal(cov, axis1=1, axis2=2)) + extra) * rf * math.sqrt(pre["scale2"])
    )

    def rms_dict(fm, res):
        d = model.derived_errors(fm.base, test, res)
        return {kname: float(np.sqrt(np.mean(v**2))) for kname, v in d.items()}

    factors = model.factors(test)
    ranking = sorted(cands, key=lambda c: (c.identifiable_rank > 0, c.score), reverse=True)
    absorbed = [c.effect for c in cands if c.identifiable_rank == 0]
    notes = []
    if not bool(s1["base_ok"][b]):
        notes.append("the base Levenberg–Marquardt fit did not converge within the step budget")
    if rank_g < nb:
        notes.append(f"the data determine only {rank_g} of the {nb} base parameter directions")
    return DiagnosisReport(
        model=model.name,
        detected=bool(pre["detected"]),
        detect_statistic=float(pre["t0"]),
        detect_dof=float(pre["n_te"]),
        detect_p_value=float(pre["p_detect"]),
        named_effect="none" if a is None else effects[a].name,
        indistinguishable_from=indist,
        additional_effects=additional,
        ranking=ranking,
        absorbed=absorbed,
        skipped=list(skipped),
        gap_before=float(np.sqrt(np.mean(before**2))),
        gap_after=float(np.sqrt(np.mean(after**2))),
        noise_floor=floor,
        noise_floor_predictive=floor_pred,
        derived_before=rms_dict(base_fm, raw_te[0]),
        derived_after=rms_dict(aug_fm, raw_te[0 if a is None else a + 1]),
        where_before=where_analysis(before, factors, model.output_names, alpha),
        where_after=where_analysis(after, factors, model.output_names, alpha),
        base_chi2=float(chi2[0]),
        base_dof=int(pre["dof0"]),
        noise_estimated=not known,
        noise_scale=float(math.sqrt(pre["scale2"])),
        alpha=alpha,
        n_train=model.n_rows(train),
        n_test=model.n_rows(test),
        fitted=aug_fm,
        base_fitted=base_fm,
        residuals_before=before,
        residuals_after=after,
        test_factors=factors,
        notes=notes,
    )
